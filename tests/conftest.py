"""Test session set-up: an isolated ROS domain, one rclpy client node, process fixtures."""

import importlib.util
import os
import random
import sys

import pytest
import rclpy

from ros_harness import NodeProcess


def session_domain_id() -> int:
    """This session's ROS domain: IMPURITY_TEST_DOMAIN_ID if set, else drawn from the run's process id in
    20..190. Under pytest-xdist (make test runs two workers) every worker takes the run's domain plus its
    number (PYTEST_XDIST_WORKER "gw<N>"; the controller's pid is the workers' parent), so the workers'
    graphs never see each other."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")
    index = int(worker[2:]) if worker.startswith("gw") and worker[2:].isdigit() else 0
    if os.environ.get("IMPURITY_TEST_DOMAIN_ID"):
        return int(os.environ["IMPURITY_TEST_DOMAIN_ID"]) + index
    return random.Random(os.getppid() if worker else os.getpid()).randint(20, 190) + index


# Before rclpy is initialised anywhere: this session's own DDS domain, discovery on this host only,
# so parallel test runs and other sessions on the machine never see each other.
os.environ["ROS_DOMAIN_ID"] = str(session_domain_id())
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("RCUTILS_COLORIZED_OUTPUT", "0")


def pytest_configure(config):
    config.addinivalue_line("markers", "simulator: needs the simulator's PyBullet; skipped on CPython 3.12, "
                                       "which sets up the runtime only")


def simulator_missing() -> str | None:
    """Why the simulator's tests cannot run in this venv, or None. Only a CPython 3.12 venv lacks PyBullet
    by design (requirements.txt: PyBullet 3.2.7 has no cp312 wheel); on 3.11 the simulator's tests always
    run, and a missing PyBullet fails them as the broken set-up it is."""
    if sys.version_info < (3, 12) or importlib.util.find_spec("pybullet") is not None:
        return None
    return (f"needs PyBullet (the simulator), which has no wheel for CPython "
            f"{sys.version_info.major}.{sys.version_info.minor}: run it in a CPython 3.11 venv "
            f"(PYTHON=python3.11 make setup)")


def pytest_collection_modifyitems(config, items):
    """Skips the cases marked `simulator` when this venv has no simulator (simulator_missing)."""
    reason = simulator_missing()
    if reason is not None:
        for item in items:
            if item.get_closest_marker("simulator") is not None:
                item.add_marker(pytest.mark.skip(reason=reason))


@pytest.fixture(scope="session")
def rcl_context():
    """rclpy's default context, initialised once for the session: one DDS participant in the test process
    for every client node and every parameter file read (parameter_files.as_declared)."""
    rclpy.init()
    yield rclpy.get_default_context()
    rclpy.try_shutdown()


@pytest.fixture(scope="session")
def ros_node(rcl_context):
    """One rclpy node for the whole session, used as the client side of graph tests."""
    node = rclpy.create_node(f"test_client_{os.getpid()}", context=rcl_context)
    yield node
    node.destroy_node()


@pytest.fixture
def launch(request):
    """Start executables as separate processes; every one is stopped (and its log shown) at teardown."""
    started: list[NodeProcess] = []

    def start(package: str, executable: str, args=None, env=None) -> NodeProcess:
        proc = NodeProcess(package, executable, args, env)
        started.append(proc)
        return proc

    yield start
    failed = getattr(request.node, "rep_call", None) is not None and request.node.rep_call.failed
    for proc in started:
        proc.stop()
        if failed:
            print(f"\n----- output of {proc.name} ({proc.log_path}) -----\n{proc.output()[-4000:]}")


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """Let fixtures know whether the test body failed (to print process logs)."""
    outcome = yield
    report = outcome.get_result()
    setattr(item, "rep_" + report.when, report)
