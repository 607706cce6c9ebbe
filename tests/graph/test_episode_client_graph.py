"""The episode client (impurity_bringup.episode_client) as an operator uses it: Ctrl-C while an episode
runs cancels the goal (the arm must stop), waits for the episode's "canceled" result, prints it and exits
130; bad options and requests are refused before anything is sent; against the real episode node, the
palette is echoed, a busy rejection of the action says why, and --stop ends an episode started with
--start-only.

For Ctrl-C the episode node is scripted in this test process (an action server on /episode/run that
accepts the goal, sends one step of feedback and runs until it is canceled), so the client is the only
executable under test; it runs as its own process on the session's isolated ROS domain.
"""

import json
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

from impurity_bringup.episode_client import format_result
from impurity_common.names import RUN_EPISODE_ACTION
from impurity_interfaces.action import RunEpisode
from impurity_policy.core.episode import COUNTED_BY_NOTHING, TERMINATION_CANCELED
from ros_harness import ros_args

CLIENT = [sys.executable, "-m", "impurity_bringup.episode_client"]


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
    client = subprocess.Popen([*CLIENT, "--timeout", "120"], stdout=log,
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
    refused = RunEpisode.Result(episode_id="", termination_reason="error: scene reset failed: unknown "
                                "palette 'teal'; known: blocks, coal_slate, ...", targets_total=-1)
    text = format_result(refused)
    assert "unknown palette 'teal'" in text and "no action was taken" in text
    assert "grasp success" not in text and "targets picked" not in text
    ran = RunEpisode.Result(episode_id="e1", termination_reason="error: driver rejected the primitive",
                            actions=3, grasp_attempts=1, targets_total=2)
    assert "grasp success" in format_result(ran)  # after an action, the metrics are the record


def test_an_episode_canceled_before_its_scene_was_ready_prints_its_reason_and_no_count():
    canceled = RunEpisode.Result(episode_id="e1", termination_reason=TERMINATION_CANCELED,
                                 counted_by=COUNTED_BY_NOTHING, targets_total=-1)
    text = format_result(canceled)
    assert f"episode e1: {TERMINATION_CANCELED}" in text and "no action was taken" in text
    assert "targets picked" not in text and "/-1" not in text


def run_client(*args: str) -> subprocess.CompletedProcess:
    """The client as a process, to its end (bounded): its exit code and output."""
    return subprocess.run([*CLIENT, *args], capture_output=True, text=True, timeout=120,
                          env={**os.environ, "PYTHONUNBUFFERED": "1"})


@pytest.mark.parametrize("args, message", [
    # a negative seed printed a traceback naming another field (OverflowError ... num_targets)
    (["--seed", "-3"], "argument --seed: must be an integer from 0 to 4294967295 (got -3)"),
    (["--seed", "-3", "--start-only"], "argument --seed: must be an integer from 0 to 4294967295 (got -3)"),
    (["--seed", "4294967296"], "argument --seed: must be an integer from 0 to 4294967295"),
    (["--objects", "-1"], "argument --objects: must be an integer from 0 to"),
    (["--max-actions", "3000000000"], "argument --max-actions: must be an integer from 0 to 2147483647"),
    # accepted before (750-action limit): refused with the episode node's own reason, before sending
    (["--start-only", "--targets", "50", "--objects", "5"], "--targets (50) must not exceed --objects (5)"),
    (["--targets", "50", "--objects", "5"], "--targets (50) must not exceed --objects (5)"),
])
def test_bad_options_are_refused_by_name_before_anything_is_sent(args, message):
    refused = run_client(*args)
    assert refused.returncode == 2, refused.stderr
    assert message in refused.stderr and "Traceback" not in refused.stderr


def test_palette_echoed_busy_explained_and_a_started_episode_stopped(launch, tmp_path):
    """Against the real episode node (no cell: the episode waits for a decision): the start line names
    the palette, the action route's rejection says "busy" with the episode it waits for, and --stop ends
    the episode started by --start-only, its record closed with the palette in its summary."""
    episode = launch("impurity_policy", "episode_node", ros_args(
        {"record_dir": str(tmp_path), "use_ground_truth": False, "decision_timeout": 120.0}))
    started = run_client("--start-only", "--scenario", "random", "--seed", "3", "--palette", "coal_slate")
    assert started.returncode == 0, started.stdout + started.stderr + episode.output()
    assert ("episode_client: random seed 3, palette coal_slate, 2 target(s) among 20 object(s)"
            in started.stdout)
    episode_id = started.stdout.split("episode_id=")[1].split()[0]

    rejected = run_client("--seed", "4")
    assert rejected.returncode == 1, rejected.stdout + rejected.stderr
    assert (f"goal rejected: busy: an episode is already running ({episode_id}, started by /episode/start)"
            in rejected.stderr)

    stopped = run_client("--stop")
    assert stopped.returncode == 0, stopped.stdout + stopped.stderr
    assert f"episode {episode_id} ended: canceled" in stopped.stdout
    summary = json.loads((tmp_path / episode_id / "summary.json").read_text())
    assert summary["termination_reason"] == "canceled" and summary["request"]["palette"] == "coal_slate"
    nothing = run_client("--stop")
    assert nothing.returncode == 1 and "no episode is running" in nothing.stdout
