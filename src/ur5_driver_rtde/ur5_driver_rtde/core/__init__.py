"""Pure cores of the real driver (no rclpy): poses, the ur-rtde arm, grippers, the plan executor."""
