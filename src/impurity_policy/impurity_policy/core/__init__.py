"""Pure core (no rclpy): called directly by training, evaluation and tests."""
