"""PyBullet UR5 + gripper cell: scenes, primitives, camera, driver node."""
