"""The cell's node graph and the parameter files its nodes read, listed once for both launchers (the ROS
launch file share/impurity_bringup/launch/cell.launch.py and the pip launcher impurity_bringup.launch_cell).

Two cells share every node but the hardware's:
  sim   ur5_driver_sim/sim_cell: PyBullet world, simulated camera, UR5 and gripper (config/cell.yaml)
  real  ur5_driver_rtde/ur5_driver: a UR5 through ur-rtde and a Robotiq 2F-85 (config/real_cell.yaml,
        read over cell.yaml); the camera driver (realsense2_camera) is the launch file's camera:=true, or
        started apart (README, "Running on a real cell")
Every node reads cell.yaml, on the real cell then real_cell.yaml (only what differs: the arm driver, the
episode without simulator truth), then the camera calibration (config/camera_calibration.yaml, the
camera pose in a `/**` section), then any `-p` override. With a namespace every node runs in it
(`-r __ns:=/cell_a`); the files key each node's section /**/<node name>, which matches in any namespace.

The files are the installed ones, share/impurity_bringup/config/ (bringup/config/ in the source tree;
colcon --symlink-install links them, so an edit there is read at once).
"""

import pathlib
import re

PACKAGE = "impurity_bringup"
BASE_CONFIG_NAME = "cell.yaml"  # every node's settings; the simulated cell's whole file
CONFIG_NAMES = {"sim": BASE_CONFIG_NAME, "real": "real_cell.yaml"}  # each cell's own file
CALIBRATION_NAME = "camera_calibration.yaml"


def node_section(node_name: str) -> str:
    """The key of a node's section in the cell's parameter files: /**/<node name>, which rcl matches in
    any namespace (a plain `heightmap:` is /heightmap's alone, not /cell_a/heightmap's)."""
    return f"/**/{node_name}"


class NotInstalledError(RuntimeError):
    """impurity_bringup's share directory cannot be found: the package is not built or not sourced."""


def share_dir() -> pathlib.Path:
    """share/impurity_bringup of the install (ament index); NotInstalledError says how to install it."""
    from ament_index_python.packages import PackageNotFoundError, get_package_share_directory

    try:
        return pathlib.Path(get_package_share_directory(PACKAGE))
    except (PackageNotFoundError, OSError) as error:  # OSError: AMENT_PREFIX_PATH unset
        raise NotInstalledError(
            f"{PACKAGE} is not installed ({error}): run `make setup` (bash scripts/setup.sh) and "
            "`source scripts/env.sh`; on a ROS install, colcon build the workspace and source "
            "install/setup.bash") from None


def config_dir() -> pathlib.Path:
    """The installed parameter files: share/impurity_bringup/config."""
    return share_dir() / "config"


def config_file(cell: str) -> pathlib.Path:
    """The installed own parameter file of `cell` (ValueError for an unknown cell)."""
    nodes_of(cell)
    return config_dir() / CONFIG_NAMES[cell]


def base_config() -> pathlib.Path:
    """The installed cell.yaml: every node's settings, read first on either cell."""
    return config_dir() / BASE_CONFIG_NAME


def calibration_file() -> pathlib.Path:
    """The installed camera calibration (the camera pose), read after the cell's files."""
    return config_dir() / CALIBRATION_NAME


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
CELL_NODES = list(CELLS["sim"])  # the simulated cell's nodes (make demo, the graph tests)
# executable -> node name of the lifecycle nodes among them: the launchers configure and then activate
# each once its process runs (ur5_driver connects to the arm on configure and takes goals once active)
LIFECYCLE_NODES = {"ur5_driver": "ur5_driver"}


# SROS2 (docs/real_cell.md, "Security (SROS2)"): every process runs in its own enclave,
# ENCLAVE_ROOT/<executable>, whose permissions are config/sros2/policy.xml's.
ENCLAVE_ROOT = "/impurity_cell"
SECURITY_POLICY_NAME = "sros2/policy.xml"  # under config_dir()


def enclave(executable: str) -> str:
    """The SROS2 enclave `executable` runs in (`--ros-args --enclave <it>`): ENCLAVE_ROOT/<executable>."""
    return f"{ENCLAVE_ROOT}/{executable}"


def security_environment(keystore: str | pathlib.Path) -> dict[str, str]:
    """The environment of a node with SROS2 enforced: the keystore that `ros2 security generate_artifacts`
    made from the policy, security on, and Enforce (a node without valid security files fails to start,
    rather than running unsecured). ValueError when `keystore` is empty."""
    if not str(keystore):
        raise ValueError("security needs a keystore: pass keystore:=<dir> or set ROS_SECURITY_KEYSTORE")
    return {"ROS_SECURITY_KEYSTORE": str(keystore), "ROS_SECURITY_ENABLE": "true",
            "ROS_SECURITY_STRATEGY": "Enforce"}


def nodes_of(cell: str) -> tuple[tuple[str, str], ...]:
    """The (package, executable) pairs of `cell` ("sim" or "real"); ValueError names the cells."""
    if cell not in CELLS:
        raise ValueError(f"unknown cell {cell!r}: choose one of {', '.join(CELLS)}")
    return CELLS[cell]


class _Installed:
    """parameter_files' default calibration: the installed camera_calibration.yaml."""

    def __repr__(self) -> str:
        return "INSTALLED"


INSTALLED = _Installed()


def parameter_files(cell: str, config: str | pathlib.Path | None = None,
                    calibration: str | pathlib.Path | _Installed | None = INSTALLED) -> list[pathlib.Path]:
    """The parameter files every node of `cell` reads, in order (a later file wins): the cell's own file
    (`config`, default config_file(cell)), on the real cell read over base_config() (its own file holds
    only what differs), then `calibration` (INSTALLED: calibration_file(); None or "": none, the nodes'
    built-in camera pose). ValueError for an unknown cell; NotInstalledError when a default file is
    needed and impurity_bringup is not installed."""
    nodes_of(cell)
    own = pathlib.Path(config) if config else config_file(cell)
    files = [own] if cell == "sim" else [base_config(), own]
    if calibration is INSTALLED:
        calibration = calibration_file()
    if calibration:
        files.append(pathlib.Path(calibration))
    return files


# namespace: the whole cell under one ROS namespace ('' or '/': the root). Every name of the cell is
# relative (impurity_common.names), so /cell_a puts /cell_a/heightmap, /cell_a/episode/start, ... beside
# another cell's; /tf and /tf_static stay global (the frames of two cells must then differ, or each cell
# runs on its own ROS_DOMAIN_ID).
_NAMESPACE_TOKEN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def namespace_of(text: str) -> str:
    """The launchers' `namespace` as a ROS namespace: '' for the root ('' or '/'), else absolute without a
    trailing slash ('cell_a' -> '/cell_a'). ValueError names the argument and the rule it breaks."""
    tokens = text.strip().strip("/").split("/") if text.strip().strip("/") else []
    bad = [token for token in tokens if not _NAMESPACE_TOKEN.fullmatch(token)]
    if bad:
        raise ValueError(f"namespace {text!r}: each part must start with a letter or '_' and hold only "
                         f"letters, digits and '_' (not {', '.join(repr(b) for b in bad)}), e.g. /cell_a")
    return "/" + "/".join(tokens) if tokens else ""


# The real cell's arm driver: the launchers' robot_ip and dry_run set these parameters of it (after the
# files: a command-line value wins over real_cell.yaml's).
DRIVER = "ur5_driver"


def driver_overrides(robot_ip: str = "", dry_run: str = "") -> dict[str, str | bool]:
    """{parameter: value} of the arm driver from the launchers' robot_ip and dry_run ('' = real_cell.yaml's
    value); ValueError when dry_run is neither true nor false."""
    overrides: dict[str, str | bool] = {}
    if robot_ip:
        overrides["robot_ip"] = robot_ip
    if dry_run:
        if dry_run.lower() not in ("true", "false"):
            raise ValueError(f"dry_run {dry_run!r}: true (record the commands, contact no robot) or false")
        overrides["dry_run"] = dry_run.lower() == "true"
    return overrides


# camera:=true (the ROS launch file): realsense2_camera's rs_launch.py with what heightmap_node reads
# (config/real_cell.yaml's comment): colour and depth aligned, synchronised, 640x480 at 30 Hz, no TF of its
# own (cell_state_publisher publishes the calibrated camera pose). Its camera_namespace and camera_name stay
# "camera", under the cell's namespace: names.COLOR_TOPIC and the others.
CAMERA_PACKAGE = "realsense2_camera"
CAMERA_LAUNCH_FILE = "rs_launch.py"
CAMERA_LAUNCH_ARGUMENTS = {
    "camera_namespace": "camera", "camera_name": "camera", "align_depth.enable": "true",
    "enable_sync": "true", "publish_tf": "false",
    "rgb_camera.color_profile": "640,480,30", "depth_module.depth_profile": "640,480,30",
}

# rviz:=true: rviz2 with config/cell.rviz, started in the cell's namespace so that its relative topics
# (the markers, the robot model, the images) are the cell's.
RVIZ_CONFIG_NAME = "cell.rviz"


def rviz_config() -> pathlib.Path:
    """The installed RViz configuration of the cell."""
    return config_dir() / RVIZ_CONFIG_NAME


def format_value(value) -> str:
    """A parameter value as `-p name:=value` spells it (YAML: true/false, [a,b,c])."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (list, tuple)):
        return "[" + ",".join(format_value(v) for v in value) + "]"
    return str(value)


def ros_arguments(files: list[pathlib.Path], overrides: dict | None = None, namespace: str = "") -> list[str]:
    """`--ros-args` of one node: its namespace (namespace_of; '' none), the parameter files
    (parameter_files: the cell's, then the calibration), then the `-p` overrides ({name: value}).

    The order is rcl's: of two parameter files the later one wins, and a `-p` wins over the files only
    when it comes after them (tests/workspace/test_cell_config.py).
    """
    args = ["--ros-args"]
    if namespace_of(namespace):
        args += ["-r", f"__ns:={namespace_of(namespace)}"]
    for path in files:
        args += ["--params-file", str(path)]
    for name, value in (overrides or {}).items():
        args += ["-p", f"{name}:={format_value(value)}"]
    return args
