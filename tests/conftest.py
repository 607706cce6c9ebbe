"""Test session set-up: an isolated ROS domain, one rclpy client node, process fixtures."""

import os
import random

import pytest
import rclpy

from ros_harness import NodeProcess

# Before rclpy is initialised anywhere: this session's own DDS domain, discovery on this host only,
# so parallel test runs and other sessions on the machine never see each other.
os.environ["ROS_DOMAIN_ID"] = str(os.environ.get("IMPURITY_TEST_DOMAIN_ID")
                                  or random.Random(os.getpid()).randint(20, 199))
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("RCUTILS_COLORIZED_OUTPUT", "0")


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
