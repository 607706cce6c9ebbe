"""bringup/episode_client.py as an operator uses it: Ctrl-C while an episode runs cancels the goal (the
arm must stop), waits for the episode's "canceled" result, prints it and exits 130.

The episode node is scripted in this test process (an action server on /episode/run that accepts the
goal, sends one step of feedback and runs until it is canceled), so the client is the only executable
under test; it runs as its own process on the session's isolated ROS domain.
"""

import os
import signal
import subprocess
import sys
import threading
import time

import pytest
import rclpy
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import MultiThreadedExecutor

from impurity_common.names import RUN_EPISODE_ACTION
from impurity_interfaces.action import RunEpisode
from impurity_policy.core.episode import TERMINATION_CANCELED
from ros_harness import ROOT

CLIENT = ROOT / "bringup" / "episode_client.py"


class ScriptedEpisodeNode:
    """/episode/run: accepts a goal, publishes one feedback step, returns "canceled" once canceled."""

    def __init__(self):
        self.node = rclpy.create_node(f"scripted_episode_{os.getpid()}")
        self.goal_started = threading.Event()
        self.cancel_requested = threading.Event()
        self._server = ActionServer(self.node, RunEpisode, RUN_EPISODE_ACTION, execute_callback=self._execute,
                                    goal_callback=lambda _: GoalResponse.ACCEPT,
                                    cancel_callback=self._on_cancel, callback_group=ReentrantCallbackGroup())
        self._executor = MultiThreadedExecutor(num_threads=2)
        self._executor.add_node(self.node)
        self._thread = threading.Thread(target=self._executor.spin, daemon=True)
        self._thread.start()

    def _on_cancel(self, _goal):
        self.cancel_requested.set()
        return CancelResponse.ACCEPT

    def _execute(self, goal):
        feedback = RunEpisode.Feedback()
        feedback.step.step, feedback.step.attention_mode = 1, "TARGET"
        goal.publish_feedback(feedback)
        self.goal_started.set()
        deadline = time.monotonic() + 60.0
        while not goal.is_cancel_requested and time.monotonic() < deadline:
            time.sleep(0.05)
        result = RunEpisode.Result(episode_id="scripted", termination_reason=TERMINATION_CANCELED,
                                   targets_total=1)
        if goal.is_cancel_requested:
            goal.canceled()
        else:
            goal.abort()
        return result

    def destroy(self):
        self._server.destroy()
        self._executor.shutdown(timeout_sec=5.0)
        self._thread.join(5.0)
        self.node.destroy_node()


@pytest.fixture
def scripted_episode_node(ros_node):
    server = ScriptedEpisodeNode()
    yield server
    server.destroy()


def test_ctrl_c_on_the_client_cancels_the_running_episode(scripted_episode_node, tmp_path):
    log = open(tmp_path / "client.log", "w")
    client = subprocess.Popen([sys.executable, str(CLIENT), "--timeout", "120"], stdout=log,
                              stderr=subprocess.STDOUT, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        assert scripted_episode_node.goal_started.wait(60.0), "the client's goal never reached the server"
        client.send_signal(signal.SIGINT)  # what Ctrl-C sends
        code = client.wait(60.0)
    finally:
        if client.poll() is None:
            client.kill()
        log.close()
    output = (tmp_path / "client.log").read_text()
    assert scripted_episode_node.cancel_requested.is_set(), output
    assert code == 130, output
    assert "canceling the episode" in output and f"episode scripted: {TERMINATION_CANCELED}" in output


def test_an_episode_refused_before_its_first_action_prints_its_reason_and_no_metrics():
    sys.path.insert(0, str(ROOT / "bringup"))
    from episode_client import format_result

    refused = RunEpisode.Result(episode_id="", termination_reason="error: scene reset failed: unknown "
                                "palette 'teal'; known: blocks, coal_slate, ...", targets_total=-1)
    text = format_result(refused)
    assert "unknown palette 'teal'" in text and "no action was taken" in text
    assert "grasp success" not in text and "targets picked" not in text
    ran = RunEpisode.Result(episode_id="e1", termination_reason="error: driver rejected the primitive",
                            actions=3, grasp_attempts=1, targets_total=2)
    assert "grasp success" in format_result(ran)  # after an action, the metrics are the record
