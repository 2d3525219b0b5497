"""The collision transition: Transition, SpherePath, CollisionInfo, ObjectInfo."""
