"""PyBullet UR5 + parallel-gripper cell: scenes, primitives, simulated RealSense camera and the driver node."""
