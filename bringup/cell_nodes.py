"""The cell's node graph, listed once for both launchers (ROS launch file and the pip launcher)."""

# (package, executable): each runs as its own process with bringup/config/cell.yaml.
# A real cell replaces the first entry with the camera, UR and gripper drivers.
CELL_NODES = [
    ("ur5_driver_sim", "sim_cell"),
    ("impurity_attention", "heightmap_node"),
    ("impurity_attention", "attention_node"),
    ("impurity_policy", "policy_node"),
    ("impurity_policy", "episode_node"),
]
