"""The cell's node graph and the parameter files its nodes read, listed once for both launchers (the ROS
launch file bringup/launch/cell.launch.py and the pip launcher bringup/launch_cell.py).

Two cells share every node but the hardware's:
  sim   ur5_driver_sim/sim_cell: PyBullet world, simulated camera, UR5 and gripper (bringup/config/cell.yaml)
  real  ur5_driver_rtde/ur5_driver: a UR5 through ur-rtde and a Robotiq 2F-85 (bringup/config/real_cell.yaml,
        read over cell.yaml); the camera driver (realsense2_camera) is started apart (README, "Running on a
        real cell")
Every node reads cell.yaml, on the real cell then real_cell.yaml (only what differs: the arm driver, the
episode without simulator truth), then the camera calibration (bringup/config/camera_calibration.yaml, the
camera pose in a `/**` section), then any `-p` override.
"""

import pathlib

BRINGUP = pathlib.Path(__file__).resolve().parent
CONFIG_DIR = BRINGUP / "config"
CALIBRATION = CONFIG_DIR / "camera_calibration.yaml"

# (package, executable): each runs as its own process. Perception, decisions, episodes and the 3-D view
# (TF, /robot_description, markers) run on either cell.
COMMON_NODES = (
    ("impurity_attention", "heightmap_node"),
    ("impurity_attention", "attention_node"),
    ("impurity_policy", "policy_node"),
    ("impurity_policy", "episode_node"),
    ("impurity_viz", "cell_state_publisher"),
    ("impurity_viz", "decision_markers"),
)
CELLS = {
    "sim": (("ur5_driver_sim", "sim_cell"), *COMMON_NODES),
    "real": (("ur5_driver_rtde", "ur5_driver"), *COMMON_NODES),
}
BASE_CONFIG = CONFIG_DIR / "cell.yaml"  # every node's settings; the simulated cell's whole file
CONFIGS = {"sim": BASE_CONFIG, "real": CONFIG_DIR / "real_cell.yaml"}  # each cell's own file
CELL_NODES = list(CELLS["sim"])  # the simulated cell's nodes (make demo, the graph tests)


def nodes_of(cell: str) -> tuple[tuple[str, str], ...]:
    """The (package, executable) pairs of `cell` ("sim" or "real"); ValueError names the cells."""
    if cell not in CELLS:
        raise ValueError(f"unknown cell {cell!r}: choose one of {', '.join(CELLS)}")
    return CELLS[cell]


def parameter_files(cell: str, config: str | pathlib.Path | None = None,
                    calibration: str | pathlib.Path | None = CALIBRATION) -> list[pathlib.Path]:
    """The parameter files every node of `cell` reads, in order (a later file wins): the cell's own file
    (`config`, default CONFIGS[cell]), on the real cell read over BASE_CONFIG (its own file holds only what
    differs), then `calibration` (None: none, the nodes' built-in camera pose). ValueError for an unknown
    cell."""
    nodes_of(cell)
    own = pathlib.Path(config) if config else CONFIGS[cell]
    files = [own] if cell == "sim" else [BASE_CONFIG, own]
    if calibration:
        files.append(pathlib.Path(calibration))
    return files


def format_value(value) -> str:
    """A parameter value as `-p name:=value` spells it (YAML: true/false, [a,b,c])."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (list, tuple)):
        return "[" + ",".join(format_value(v) for v in value) + "]"
    return str(value)


def ros_arguments(files: list[pathlib.Path], overrides: dict | None = None) -> list[str]:
    """`--ros-args` of one node: the parameter files (parameter_files: the cell's, then the calibration),
    then the `-p` overrides ({name: value}).

    The order is rcl's: of two parameter files the later one wins, and a `-p` wins over the files only
    when it comes after them (tests/workspace/test_cell_config.py).
    """
    args = ["--ros-args"]
    for path in files:
        args += ["--params-file", str(path)]
    for name, value in (overrides or {}).items():
        args += ["-p", f"{name}:={format_value(value)}"]
    return args
