"""The demo (`make demo`, impurity_bringup.demo) on a ROS domain where a cell already runs: it says so and
starts nothing.

The other cell is an action server on /episode/run in this test process, on the session's isolated domain."""

import subprocess
import sys
import time

import rclpy
from rclpy.action import ActionServer
from rclpy.executors import SingleThreadedExecutor

from impurity_common.names import RUN_EPISODE_ACTION
from impurity_interfaces.action import RunEpisode


def test_the_demo_refuses_to_start_beside_another_cell_and_names_the_domain(ros_node, tmp_path):
    other = rclpy.create_node("other_cell_episode")
    server = ActionServer(other, RunEpisode, RUN_EPISODE_ACTION, execute_callback=lambda goal: None)
    executor = SingleThreadedExecutor()
    executor.add_node(other)
    try:
        demo = subprocess.Popen([sys.executable, "-m", "impurity_bringup.demo", "--probe", "20",
                                 "--out", str(tmp_path / "demo")],
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        deadline = time.monotonic() + 60.0  # the demo decides within its probe (20 s) once discovered
        while demo.poll() is None and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.1)  # serve discovery until the demo has decided
        if demo.poll() is None:
            demo.kill()
        output = demo.communicate(timeout=30)[0]
    finally:
        server.destroy()
        executor.shutdown()
        other.destroy_node()
    assert demo.returncode == 1, output
    assert "another cell is running on ROS_DOMAIN_ID=" in output and "make demo" in output
    assert "cell starting" not in output and not (tmp_path / "demo" / "logs").exists()
