"""Pip-environment launcher: every node of the cell as its own process, with the cell's parameter file
and the camera calibration.

    launch_cell [--cell sim|real] [--namespace /cell_a] [--robot-ip IP] [--dry-run true|false]
                [--config FILE] [--calibration FILE] [--param EXE:NAME:=VALUE]...
    python -m impurity_bringup.launch_cell ...   (the same)

`--cell sim` (default): the PyBullet cell, config/cell.yaml. `--cell real`: the UR5 driver on
ur-rtde instead of the simulator, config/real_cell.yaml read over cell.yaml (start the camera
driver apart: README, "Running on a real cell"); `--robot-ip` and `--dry-run` set the driver's parameters
of those names. `--namespace /cell_a` starts every node under /cell_a (the cell's names are relative:
/cell_a/heightmap, ...). Every node reads the cell's files (`--config` replaces the cell's own), then
`--calibration`, then its `--param` overrides. `--print` lists the command lines
and starts nothing. The files and executables are the installed ones (share/impurity_bringup/config,
lib/<package>/<executable> of each package's install prefix, found through the ament index).

The lifecycle nodes among them (cell_nodes.LIFECYCLE_NODES: the UR5 driver) are configured and then
activated once their process runs (impurity_bringup.lifecycle); a transition that fails stops the cell,
naming the node and its reason.

Ctrl-C (SIGINT) or SIGTERM stops all of them; if any node dies, the others are stopped and the
launcher exits non-zero, naming the node and its exit code. Output lines are prefixed with the node. A
launcher that is killed outright (SIGKILL) takes its nodes with it: on Linux each node gets SIGTERM when
the launcher dies (prctl PR_SET_PDEATHSIG), so none is left running on the domain.
"""

import argparse
import ctypes
import os
import pathlib
import shlex
import signal
import subprocess
import sys
import threading
import time

from ament_index_python.packages import PackageNotFoundError, get_package_prefix

from impurity_bringup.cell_nodes import (
    CELLS,
    DRIVER,
    LIFECYCLE_NODES,
    NotInstalledError,
    calibration_file,
    driver_overrides,
    namespace_of,
    parameter_files,
    ros_arguments,
)
from impurity_common.parameters import override_problem


def executable(package: str, name: str) -> pathlib.Path:
    """Where `ros2 run <package> <name>` finds it: lib/<package>/<name> under the package's install prefix.
    SystemExit names what is missing."""
    try:
        path = pathlib.Path(get_package_prefix(package)) / "lib" / package / name
    except PackageNotFoundError:
        raise SystemExit(f"launch_cell: package {package} is not installed; run `make setup` first") from None
    if not path.exists():
        raise SystemExit(f"launch_cell: {path} not found; run `make setup` first")
    return path


def node_commands(nodes, files: list[pathlib.Path], overrides: dict | None = None, namespace: str = ""
                  ) -> list[tuple[str, list[str]]]:
    """(executable name, command line) of every node: its installed executable with
    cell_nodes.ros_arguments (the namespace, the parameter files, then the overrides given for that
    executable)."""
    return [(name, [str(executable(package, name)),
                    *ros_arguments(files, (overrides or {}).get(name), namespace)])
            for package, name in nodes]


def parse_override(text: str) -> tuple[str, str, str]:
    """'EXECUTABLE:NAME:=VALUE' -> (executable, name, value); ValueError says the expected form."""
    target, sep, value = text.partition(":=")
    executable_name, colon, name = target.partition(":")
    if not (sep and colon and executable_name and name):
        raise ValueError(f"--param {text!r}: expected EXECUTABLE:NAME:=VALUE, e.g. ur5_driver:dry_run:=false")
    return executable_name, name, value


PR_SET_PDEATHSIG = 1  # prctl(2): the signal a process gets when its parent dies


def _die_with_launcher(launcher: int):
    """A Popen preexec_fn: SIGTERM to the child when the launcher (pid `launcher`) dies (Linux; elsewhere
    nothing); a launcher already gone by then ends the child at once."""
    def arm() -> None:
        if not sys.platform.startswith("linux"):
            return
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0)
        if os.getppid() != launcher:
            os.kill(os.getpid(), signal.SIGTERM)
    return arm


class CellProcesses:
    def __init__(self, commands: list[tuple[str, list[str]]], log_dir: pathlib.Path | None, quiet: bool):
        self.processes: list[tuple[str, subprocess.Popen]] = []
        self.quiet = quiet
        self.log_dir = log_dir
        if log_dir is not None:
            log_dir.mkdir(parents=True, exist_ok=True)
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        for name, command in commands:
            proc = subprocess.Popen(command,
                                    stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env,
                                    start_new_session=True, preexec_fn=_die_with_launcher(os.getpid()))
            self.processes.append((name, proc))
            threading.Thread(target=self._pump, args=(name, proc), daemon=True).start()

    def _pump(self, name: str, proc: subprocess.Popen) -> None:
        log = open(self.log_dir / f"{name}.log", "w") if self.log_dir else None
        for line in proc.stdout:
            if log:
                log.write(line)
                log.flush()
            if not self.quiet:
                sys.stdout.write(f"[{name}] {line}")
                sys.stdout.flush()
        if log:
            log.close()

    def first_dead(self):
        for name, proc in self.processes:
            if proc.poll() is not None:
                return name, proc.returncode
        return None

    def stop(self, timeout: float = 10.0) -> None:
        for sig, wait in ((signal.SIGINT, timeout), (signal.SIGTERM, 3.0), (signal.SIGKILL, 3.0)):
            alive = [p for _, p in self.processes if p.poll() is None]
            if not alive:
                return
            for proc in alive:
                try:
                    os.killpg(proc.pid, sig)
                except ProcessLookupError:
                    pass
            deadline = time.monotonic() + wait
            for proc in alive:
                try:
                    proc.wait(max(0.0, deadline - time.monotonic()))
                except subprocess.TimeoutExpired:
                    pass


def bring_up_lifecycle_nodes(executables: list[str], namespace: str, failed: list[str],
                             stop: threading.Event) -> None:
    """Configure and activate the lifecycle nodes among `executables`, in `namespace` ('' the root, else
    '/cell_a'), in a thread of the launcher with a ROS node of its own; a failure is appended to `failed`
    and sets `stop`."""
    import rclpy
    from rclpy.signals import SignalHandlerOptions

    from impurity_bringup.lifecycle import LifecycleFailed, bring_to_active

    managed = [LIFECYCLE_NODES[name] for name in executables if name in LIFECYCLE_NODES]
    if not managed:
        return
    context = rclpy.Context()
    rclpy.init(args=[], context=context, signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node("launch_cell", context=context)
    executor = rclpy.executors.SingleThreadedExecutor(context=context)
    executor.add_node(node)
    try:
        for name in managed:
            try:
                bring_to_active(node, f"{namespace}/{name}", should_stop=stop.is_set,
                                spin_once=executor.spin_once)
                print(f"launch_cell: {name} is active", flush=True)
            except LifecycleFailed as error:
                failed.append(str(error))
                stop.set()
                return
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cell", choices=tuple(CELLS), default="sim",
                        help="sim: the PyBullet cell (default); real: the UR5 driver, camera started apart")
    parser.add_argument("--namespace", default="",
                        help="ROS namespace of the whole cell, e.g. /cell_a (default: the root); /tf stays "
                        "global")
    parser.add_argument("--robot-ip", default="", help="--cell real: the UR controller's address (default: "
                        "config/real_cell.yaml's)")
    parser.add_argument("--dry-run", choices=("true", "false"), default="",
                        help="--cell real: true records the commands and contacts no robot, false moves the "
                        "robot (default: config/real_cell.yaml's, true)")
    parser.add_argument("--config", type=pathlib.Path, default=None,
                        help="the cell's own parameter file (default: config/cell.yaml; --cell real: "
                        "config/real_cell.yaml, read over config/cell.yaml)")
    parser.add_argument("--calibration", type=pathlib.Path, default=None,
                        help="camera calibration file, read after --config (default: config/"
                        "camera_calibration.yaml of the installed impurity_bringup)")
    parser.add_argument("--only", default="", help="comma-separated executables to start (default: all)")
    parser.add_argument("--param", action="append", default=[], metavar="EXECUTABLE:NAME:=VALUE",
                        help="a parameter override for one executable, after both files (repeatable), "
                        "e.g. ur5_driver:robot_ip:=192.168.1.10")
    parser.add_argument("--log-dir", type=pathlib.Path, default=None, help="also write one log per node")
    parser.add_argument("--quiet", action="store_true", help="do not echo node output")
    parser.add_argument("--record-dir", default=None, help="episode records directory (overrides the config)")
    parser.add_argument("--print", action="store_true", dest="print_only",
                        help="print each node's command line and start nothing")
    args = parser.parse_args(argv)
    try:
        calibration = args.calibration or calibration_file()
        files = parameter_files(args.cell, args.config, calibration)
    except NotInstalledError as error:
        parser.error(str(error))
    for path in files:
        if not path.is_file():
            what = "calibration" if path == calibration else "config"
            parser.error(f"{what} {path} not found")
    cell_nodes = CELLS[args.cell]
    wanted = {n for n in args.only.split(",") if n}
    unknown = wanted - {n for _, n in cell_nodes}
    if unknown:
        parser.error(f"unknown node(s) of the {args.cell} cell: {', '.join(sorted(unknown))}")
    nodes = [(p, n) for p, n in cell_nodes if not wanted or n in wanted]
    try:
        namespace = namespace_of(args.namespace)
    except ValueError as error:
        parser.error(f"--{error}")
    driver = driver_overrides(args.robot_ip, args.dry_run)
    if driver and args.cell != "real":
        parser.error("--robot-ip and --dry-run are the real cell's: add --cell real")
    overrides: dict[str, dict] = {"episode_node": {"record_dir": args.record_dir}} if args.record_dir else {}
    if driver:
        overrides[DRIVER] = dict(driver)
    for text in args.param:
        try:
            target, name, value = parse_override(text)
        except ValueError as error:
            parser.error(str(error))
        if target not in {n for _, n in cell_nodes}:
            parser.error(f"--param {text!r}: {target} is not a node of the {args.cell} cell")
        problem = override_problem(name, value)
        if problem is not None:  # rcl would end the node in a traceback
            parser.error(f"--param {target}: {problem}")
        overrides.setdefault(target, {})[name] = value
    commands = node_commands(nodes, files, overrides, namespace)
    if args.print_only:
        for _, command in commands:
            print(shlex.join(command))
        return 0

    stop_requested = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop_requested.set())
    cell = CellProcesses(commands, args.log_dir, args.quiet)
    lifecycle_failures: list[str] = []
    threading.Thread(target=bring_up_lifecycle_nodes, daemon=True,
                     args=([n for _, n in nodes], namespace, lifecycle_failures, stop_requested)).start()
    print(f"launch_cell: started the {args.cell} cell: {', '.join(n for _, n in nodes)} (namespace "
          f"{namespace or '/'}, ROS_DOMAIN_ID={os.environ.get('ROS_DOMAIN_ID', '0')}); Ctrl-C stops all",
          flush=True)
    exit_code = 0
    while not stop_requested.wait(0.2):
        dead = cell.first_dead()
        if dead is not None:
            print(f"launch_cell: node {dead[0]} exited with code {dead[1]}; stopping the cell",
                  file=sys.stderr, flush=True)
            exit_code = 1
            break
    for failure in lifecycle_failures:
        print(f"launch_cell: {failure}; stopping the cell", file=sys.stderr, flush=True)
        exit_code = 1
    cell.stop()
    print("launch_cell: all nodes stopped", flush=True)
    return exit_code


if __name__ == "__main__":
    sys.exit(main())
