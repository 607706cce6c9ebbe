#!/usr/bin/env python3
"""Pip-environment launcher: every node of the cell as its own process, with bringup/config/cell.yaml.

Ctrl-C (SIGINT) or SIGTERM stops all of them; if any node dies, the others are stopped and the
launcher exits non-zero, naming the node and its exit code. Output lines are prefixed with the node.
"""

import argparse
import os
import pathlib
import signal
import subprocess
import sys
import threading
import time

BRINGUP = pathlib.Path(__file__).resolve().parent
ROOT = BRINGUP.parent
sys.path.insert(0, str(BRINGUP))
from cell_nodes import CELL_NODES  # noqa: E402

INSTALL = ROOT / "ros2_ws" / "install"


def executable(package: str, name: str) -> pathlib.Path:
    path = INSTALL / package / "lib" / package / name
    if not path.exists():
        raise SystemExit(f"launch_cell: {path} not found; run `make setup` first")
    return path


class CellProcesses:
    def __init__(self, config: pathlib.Path, nodes, log_dir: pathlib.Path | None, quiet: bool,
                 overrides: dict | None = None):
        self.processes: list[tuple[str, subprocess.Popen]] = []
        self.quiet = quiet
        self.log_dir = log_dir
        if log_dir is not None:
            log_dir.mkdir(parents=True, exist_ok=True)
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        for package, name in nodes:
            command = [str(executable(package, name)), "--ros-args", "--params-file", str(config)]
            for param, value in (overrides or {}).get(name, {}).items():
                command += ["-p", f"{param}:={value}"]
            proc = subprocess.Popen(command,
                                    stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env,
                                    start_new_session=True)
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


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", type=pathlib.Path, default=BRINGUP / "config" / "cell.yaml")
    parser.add_argument("--only", default="", help="comma-separated executables to start (default: all)")
    parser.add_argument("--log-dir", type=pathlib.Path, default=None, help="also write one log per node")
    parser.add_argument("--quiet", action="store_true", help="do not echo node output")
    parser.add_argument("--record-dir", default=None, help="episode records directory (overrides cell.yaml)")
    args = parser.parse_args(argv)
    if not args.config.is_file():
        parser.error(f"config {args.config} not found")
    wanted = {n for n in args.only.split(",") if n}
    nodes = [(p, n) for p, n in CELL_NODES if not wanted or n in wanted]
    unknown = wanted - {n for _, n in CELL_NODES}
    if unknown:
        parser.error(f"unknown node(s): {', '.join(sorted(unknown))}")

    stop_requested = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop_requested.set())
    overrides = {"episode_node": {"record_dir": args.record_dir}} if args.record_dir else {}
    cell = CellProcesses(args.config, nodes, args.log_dir, args.quiet, overrides)
    print(f"launch_cell: started {', '.join(n for _, n in nodes)} (ROS_DOMAIN_ID="
          f"{os.environ.get('ROS_DOMAIN_ID', '0')}); Ctrl-C stops all", flush=True)
    exit_code = 0
    while not stop_requested.wait(0.2):
        dead = cell.first_dead()
        if dead is not None:
            print(f"launch_cell: node {dead[0]} exited with code {dead[1]}; stopping the cell",
                  file=sys.stderr, flush=True)
            exit_code = 1
            break
    cell.stop()
    print("launch_cell: all nodes stopped", flush=True)
    return exit_code


if __name__ == "__main__":
    sys.exit(main())
