"""Objects movers collide with: static props and other live objects.

- `obstacle.py`: `Obstacle` (shape, placement, flags as an obstacle) and its
  `find_obj_collisions(transition)` (PhysicsObj.FindObjCollisions);
  `MoverObstacle`, a live Mover seen by the others.
- `gfx_obj.py`: `GfxObj` (a part's physics BSP and bounding sphere) and
  `PhysicsPart` (a GfxObj placed in the world), shared by obstacles and
  buildings.
- `sphere_collision.py`: a mover's spheres against an obstacle sphere
  (Sphere.IntersectsSphere, StepSphereUp/Down, LandOnSphere, CollideWithPoint).
- `cylsphere_collision.py`: `CylSphere` and the same against a cylsphere.
- `setup.py`: the one model loader: `Setup`, `ModelLibrary` and the scene's
  frame reader, `frame_from_dict`.

Nothing is imported here, so importing one module does not pull in the rest.
"""
