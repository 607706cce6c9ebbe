"""The Ray runtime for evaluation and training beyond one machine: start a local one or join a
cluster, with clear errors, and measure what it costs (start-up seconds, resident memory of its
processes).

Ray is optional at run time: only `--ray` / `--ray-address` / `--actors` import it, the one-process and
process-pool paths never do, and the runtime packages (impurity_policy, impurity_attention, the drivers)
never import this module. Every node of a cluster needs this checkout and its .venv
(`source scripts/env.sh` before `ray start`), so that Ray's workers import the same code.

    started = connect(None, num_cpus=2)        # a local runtime with 2 CPUs (True: we started it)
    started = connect("10.0.0.5:6379")         # join the cluster whose head is there
    ...
    disconnect(started)
"""

from __future__ import annotations

import os
import pathlib
import time

CONNECT_TIMEOUT_S = 5.0  # the head's port must accept a connection within this long


class RayUnavailable(RuntimeError):
    """Ray is not installed or the cluster cannot be reached; the message says what to do."""


def import_ray():
    try:
        import ray
    except ImportError as error:
        raise RayUnavailable(f"Ray is not importable ({error}); it is pinned in requirements.txt "
                             "(ray==2.60.0): run `make setup`, then `source scripts/env.sh`") from error
    return ray


def connect(address: str | None = None, num_cpus: int | None = None) -> bool:
    """Start a local Ray runtime (`address` None; `num_cpus` CPUs, default the machine's) or join the
    cluster at `address` ("host:port" of the head's GCS, or "auto"). A runtime this process already
    has (ray.init done by the caller, e.g. a test's cluster) is used as it is. Returns True when this
    call started or joined the runtime (disconnect() shuts it down again), False when it was there."""
    ray = import_ray()
    if ray.is_initialized():
        return False
    common = {"include_dashboard": False, "log_to_driver": False, "configure_logging": True,
              "logging_level": "warning"}
    if address is None:
        ray.init(num_cpus=num_cpus, **common)
        return True
    check_reachable(address)
    try:
        ray.init(address=address, log_to_driver=False, configure_logging=True, logging_level="warning")
    except (ConnectionError, TimeoutError, ValueError, RuntimeError) as error:
        raise RayUnavailable(f"cannot join the Ray cluster at {address!r}: {error}. Start its head with "
                             "`ray start --head` (it prints the address to pass) on a machine with this "
                             "checkout, or drop --ray-address for a local runtime") from error
    return True


def check_reachable(address: str, timeout: float = CONNECT_TIMEOUT_S) -> None:
    """RayUnavailable unless "host:port" accepts a TCP connection (ray.init itself retries an
    unreachable head for minutes); "auto" and ray:// addresses are left to Ray."""
    import socket

    if address == "auto" or "://" in address:
        return
    host, _, port = address.rpartition(":")
    if not host or not port.isdigit():
        raise RayUnavailable(f"--ray-address {address!r} is not host:port (ray start --head prints it)")
    try:
        socket.create_connection((host, int(port)), timeout=timeout).close()
    except OSError as error:
        raise RayUnavailable(f"the Ray head at {address} does not answer ({error}); is `ray start --head` "
                             "running there, and is the port open from here?") from error


def disconnect(started: bool) -> None:
    """Shut Ray down if connect() started it; leave a runtime the caller owns alone."""
    if started:
        import_ray().shutdown()


def cluster_cpus() -> int:
    """CPUs the connected runtime offers (all nodes)."""
    return int(import_ray().cluster_resources().get("CPU", 0))


# ---- costs ------------------------------------------------------------------------------------------
RAY_PROCESS_NAMES = ("raylet", "gcs_server", "ray::", "default_worker", "log_monitor", "dashboard",
                     "runtime_env", "monitor.py", "ray_client_server")


def _rss_kib(pid: int) -> int:
    try:
        for line in pathlib.Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    except (OSError, ValueError, IndexError):
        pass
    return 0


def _command(pid: int) -> str:
    try:
        return pathlib.Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return ""


def process_kind(command: str) -> str:
    """gcs_server, raylet, helpers (monitor, log monitor, dashboard and its agents), idle workers
    (prestarted, "ray::IDLE") or actors ("ray::<class>")."""
    program = command.split(" ")[0]
    if "gcs_server" in program:
        return "gcs_server"
    if program.endswith("raylet"):
        return "raylet"
    if program in ("ray::DashboardAgent", "ray::RuntimeEnvAgent") or not program.startswith("ray::") \
            and "default_worker" not in command:
        return "helpers"
    if program == "ray::IDLE" or "default_worker" in command:
        return "idle workers"
    return "actors"


def ray_processes() -> dict:
    """Resident memory (MiB) of this machine's Ray processes, by kind (process_kind); from /proc
    (Linux), {} elsewhere."""
    kinds: dict = {}
    proc = pathlib.Path("/proc")
    if not proc.is_dir():
        return kinds
    me = os.getpid()
    for entry in proc.iterdir():
        if not entry.name.isdigit() or int(entry.name) == me:
            continue
        command = _command(int(entry.name))
        if not any(name in command for name in RAY_PROCESS_NAMES):
            continue
        kind = process_kind(command)
        entry_kind = kinds.setdefault(kind, {"processes": 0, "rss_mib": 0.0})
        entry_kind["processes"] += 1
        entry_kind["rss_mib"] += _rss_kib(int(entry.name)) / 1024.0
    return kinds


def start_up_cost(num_cpus: int = 2) -> dict:
    """Seconds to import Ray and start a local runtime, and its processes' memory right after
    (before any actor); the runtime is shut down again. For the benchmark."""
    t0 = time.perf_counter()
    ray = import_ray()
    t1 = time.perf_counter()
    ray.init(num_cpus=num_cpus, include_dashboard=False, log_to_driver=False, configure_logging=True,
             logging_level="warning")
    t2 = time.perf_counter()
    memory = ray_processes()
    t3 = time.perf_counter()
    ray.shutdown()
    return {"import_s": t1 - t0, "init_s": t2 - t1, "shutdown_s": time.perf_counter() - t3,
            "memory": memory}
