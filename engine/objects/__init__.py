"""Objects movers collide with: static props and other live objects.

- `obstacle.py`: `Obstacle` (shape, placement, flags as an obstacle) and its
  `find_obj_collisions(transition)` (PhysicsObj.FindObjCollisions);
  `MoverObstacle`, a live Mover seen by the others; `ObstaclePart`.
- `sphere_collision.py`: a mover's spheres against an obstacle sphere
  (Sphere.IntersectsSphere, StepSphereUp/Down, LandOnSphere, CollideWithPoint).
- `cylsphere_collision.py`: `CylSphere` and the same against a cylsphere.
- `setup.py`: shapes from acphys-scene/1 Setups and GfxObjs (`ModelLibrary`).

Nothing is imported here, so importing one module does not pull in the rest.
"""
