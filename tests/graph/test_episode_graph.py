"""Whole picking episodes through the separate executables of the cell.

The graph: sim_cell (PyBullet, floating gripper for speed), heightmap_node, attention_node,
policy_node, episode_node, each its own process on the test's isolated ROS domain.
"""

import itertools
import json
import pathlib
import signal

import pytest

from impurity_interfaces.action import RunEpisode
from impurity_interfaces.srv import GetGroundTruth, ResetScene, StartEpisode
from impurity_policy.core.episode import read_steps
from ros_harness import ROOT, ActionHelper, call_service, ros_args, spin_until, wait_for_service

CONFIG = ROOT / "bringup" / "config" / "cell.yaml"
GRAPH = [("ur5_driver_sim", "sim_cell"), ("impurity_attention", "heightmap_node"),
         ("impurity_attention", "attention_node"), ("impurity_policy", "policy_node")]


def launch_cell(launch, record_dir, **episode_parameters) -> dict:
    """The cell's processes with bringup/config/cell.yaml, the sim in its fast floating-gripper mode; the
    episode node's parameters overridden by `episode_parameters`. {executable: process}."""
    processes = {}
    for package, executable in GRAPH:
        overrides = {"mode": "floating"} if executable == "sim_cell" else {}
        processes[executable] = launch(package, executable, ros_args(overrides, params_file=CONFIG))
    processes["episode_node"] = launch("impurity_policy", "episode_node", ros_args(
        {"record_dir": str(record_dir), "decision_timeout": 60.0, **episode_parameters}, params_file=CONFIG))
    return processes


@pytest.fixture
def cell(launch, tmp_path):
    # start_wait 120 s: /episode/start answers when the scene is reset, not when the wait runs out (a start
    # that waited for its episode's end would be refused, and one longer than call_service's wait fails)
    return launch_cell(launch, tmp_path, start_wait=120.0)


def steps_of(record_path):
    return [r for r in read_steps(f"{record_path}/steps.jsonl") if r["event"] == "step"]


def test_complete_episode_matches_ground_truth(ros_node, cell):
    procs = list(cell.values())
    # A start whose scene the cell cannot build is refused with the driver's reason, naming the known palettes
    wait_for_service(ros_node, ResetScene, "/cell/reset_scene", 60.0, procs)
    teal = call_service(ros_node, StartEpisode, "/episode/start",
                        StartEpisode.Request(scenario="random", seed=11, palette="teal"), processes=procs)
    assert not teal.accepted and teal.episode_id
    assert "unknown palette 'teal'" in teal.reason and "coal_slate" in teal.reason, teal.reason
    episode = ActionHelper(ros_node, RunEpisode, "/episode/run", timeout=60.0, processes=procs)
    handle, wrapped = episode.run(RunEpisode.Goal(scenario="random", seed=11, num_targets=1, num_objects=6,
                                                  max_actions=6), timeout=400.0)
    assert handle.accepted
    result = wrapped.result
    truth = call_service(ros_node, GetGroundTruth, "/cell/ground_truth", GetGroundTruth.Request(),
                         processes=procs, resend_after=5.0)
    assert result.termination_reason in ("all_targets_picked", "action_limit", "repeated_failure",
                                         "no_target_or_cluster_left")
    assert result.targets_total == 1
    assert result.targets_picked == truth.targets_removed
    assert result.false_rejects == truth.non_targets_removed
    assert result.actions == len(episode.feedback) >= 1
    records = read_steps(f"{result.record_path}/steps.jsonl")
    steps = [r for r in records if r["event"] == "step"]
    assert len(steps) == result.actions
    assert result.grasp_attempts == sum(s["kind"] == "grasp" for s in steps)
    if result.grasp_attempts:
        assert result.grasp_success == pytest.approx(result.targets_picked / result.grasp_attempts)
    assert result.action_efficiency == pytest.approx(result.targets_picked / result.actions)
    # No stale decisions: each executed primitive came from a frame stamped after the previous motion.
    assert steps[0]["decision_stamp_ns"] > records[0]["scene_ready_ns"]
    for before, after in itertools.pairwise(steps):
        assert after["decision_stamp_ns"] > before["motion_finished_ns"]
    summary = json.loads((ROOT / result.record_path / "summary.json").read_text())
    assert summary["targets_picked"] == result.targets_picked
    episode.destroy()

    # A start whose scene is built is accepted once it is, while its episode runs (not after it ended)
    started = call_service(ros_node, StartEpisode, "/episode/start", StartEpisode.Request(
        scenario="random", seed=12, num_targets=1, num_objects=4, max_actions=2), processes=procs)
    assert started.accepted and started.episode_id, started.reason
    record = ROOT / pathlib.Path(result.record_path).parent / started.episode_id
    spin_until(ros_node, (record / "summary.json").exists, 300.0, "the started episode's end", procs)
    ended = json.loads((record / "summary.json").read_text())
    assert ended["actions"] <= 2 and ended["termination_reason"] != "", ended  # the request's max_actions


def episode_under_way(ros_node, cell, seed: int):
    """A 30-action challenging episode that has executed its first action: (ActionHelper, goal handle)."""
    procs = list(cell.values())
    episode = ActionHelper(ros_node, RunEpisode, "/episode/run", timeout=60.0, processes=procs)
    handle = episode.send_goal(RunEpisode.Goal(scenario="challenging", seed=seed, num_targets=2,
                                               num_objects=16, max_actions=30))
    assert handle.accepted
    spin_until(ros_node, lambda: len(episode.feedback) >= 1, 300.0, "the first executed action", procs)
    return episode, handle


def test_cancel_stops_after_the_current_motion(ros_node, cell):
    episode, handle = episode_under_way(ros_node, cell, seed=4)
    episode.cancel(handle)
    result = episode.get_result(handle, timeout=300.0).result
    assert result.termination_reason == "canceled"
    assert 1 <= result.actions < 30
    assert len(steps_of(result.record_path)) == result.actions
    episode.destroy()


def test_a_node_killed_mid_episode_ends_it_with_a_reason_and_intact_records(ros_node, cell):
    episode, handle = episode_under_way(ros_node, cell, seed=5)
    cell["policy_node"].send_signal(signal.SIGKILL)
    episode.processes = [p for name, p in cell.items() if name != "policy_node"]  # its death is expected
    result = episode.get_result(handle, timeout=300.0).result
    assert result.termination_reason.startswith("node_lost")
    steps = steps_of(result.record_path)
    assert len(steps) == result.actions >= 1
    assert json.loads((ROOT / result.record_path / "summary.json").read_text())["termination_reason"] == \
        result.termination_reason
    episode.destroy()


def test_a_target_outside_the_workspace_is_counted_apart(ros_node, cell, tmp_path):
    """A scene file with a second impurity at x = 0.74 m (the workspace ends at 0.724).
    The reset reported 2 targets, the ground truth counted 1 in the workspace, and the episode ended
    "all_targets_picked" with 1 of 2 picked."""
    procs = list(cell.values())
    blocks = [dict(shape="cube", dims=[0.04] * 3, position=[0.50, 0.0, 0.021], is_target=True),
              dict(shape="cube", dims=[0.03] * 3, position=[0.74, 0.0, 0.016], is_target=True)]
    blocks += [dict(shape="cube", dims=[0.04] * 3, position=[x, y, 0.021], is_target=False)
               for x, y in ((0.40, -0.10), (0.60, 0.10), (0.45, 0.12))]
    scene = tmp_path / "outside.json"
    scene.write_text(json.dumps(blocks))
    reset = call_service(ros_node, ResetScene, "/cell/reset_scene",
                         ResetScene.Request(scenario="file", scene_file=str(scene)), processes=procs,
                         resend_after=5.0)  # the same file scene again: idempotent
    assert reset.success and (reset.num_targets, reset.targets_outside_workspace) == (2, 1), reset.message
    assert "1 target(s) outside the workspace" in reset.message
    episode = ActionHelper(ros_node, RunEpisode, "/episode/run", timeout=60.0, processes=procs)
    handle, wrapped = episode.run(RunEpisode.Goal(scenario="file", scene_file=str(scene), num_targets=2,
                                                  max_actions=4), timeout=400.0)
    assert handle.accepted
    result = wrapped.result
    truth = call_service(ros_node, GetGroundTruth, "/cell/ground_truth", GetGroundTruth.Request(),
                         processes=procs, resend_after=5.0)
    assert truth.success and truth.targets_outside_workspace == 1
    assert (result.targets_total, result.targets_outside) == (2, 1)
    assert result.targets_picked == truth.targets_removed <= 1
    assert result.termination_reason != "all_targets_picked"
    if truth.targets_remaining == 0:  # the reachable one was picked
        assert result.termination_reason == "all_reachable_targets_picked"
    records = read_steps(f"{result.record_path}/steps.jsonl")
    assert records[0]["targets_total"] == 2 and records[0]["targets_outside"] == 1
    summary = json.loads((ROOT / result.record_path / "summary.json").read_text())
    assert summary["targets_outside"] == 1 and not summary["completed"]
    episode.destroy()
