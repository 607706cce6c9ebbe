"""Episode bookkeeping: request checks, the paper's metrics, termination, crash-safe records."""

import json

import numpy as np
import pytest

from impurity_policy.core.episode import (
    FIELD_RANGES,
    TERMINATION_ACTION_LIMIT,
    TERMINATION_ALL_PICKED,
    TERMINATION_REACHABLE_PICKED,
    TERMINATION_REPEATED_FAILURE,
    CountError,
    EpisodeRecorder,
    EpisodeRequest,
    EpisodeTracker,
    StepRecord,
    action_limit,
    describe_request,
    draw_episode,
    is_failure,
    read_steps,
    validate_request,
)


def step(index, kind="grasp", success=False, target=False, remaining=2, pixel=(100, 100), outside=0):
    return StepRecord(step=index, attention_mode="TARGET", kind=kind, position=(0.5, 0.0, 0.02), yaw=0.3,
                      q_value=0.7, rotation_index=1, pixel=pixel, decision_stamp_ns=10 * index,
                      motion_finished_ns=10 * index + 5, success=success, target_grasped=target,
                      object_grasped=success, targets_remaining=remaining, targets_outside=outside)


@pytest.mark.parametrize("request_fields, fragment", [
    (dict(scenario="upside_down"), "unknown scenario"),
    (dict(num_targets=0), "num_targets"),
    (dict(num_targets=-3), "num_targets"),
    (dict(num_objects=-1), "num_objects"),
    (dict(max_actions=-5), "max_actions"),
    (dict(scenario="file"), "scene_file"),
    (dict(scenario="file", scene_file="/nonexistent/scene.json"), "does not exist"),
    # more impurities than product (episode_client --targets 50 --objects 5 was accepted: 750 actions)
    (dict(num_targets=50, num_objects=5), "num_targets (50) must not exceed num_objects (5)"),
    (dict(scenario="invisible", num_targets=3, num_objects=2), "must not exceed num_objects"),
    # outside the messages' fields (seed: uint32; counts: int32): refused here, before rclpy sees them
    (dict(seed=-3), "seed must be >= 0"),
    (dict(seed=2**32), "seed must be <= 4294967295"),
    (dict(num_objects=2**31), "num_objects must be <= 2147483647"),
    (dict(max_actions=2**31), "max_actions must be <= 2147483647"),
])
def test_bad_requests_are_refused_with_a_reason(request_fields, fragment):
    assert fragment in validate_request(EpisodeRequest(**request_fields))


def test_the_field_ranges_hold_what_the_messages_carry():
    assert FIELD_RANGES["seed"] == (0, 2**32 - 1)
    assert all(high == 2**31 - 1 for name, (_, high) in FIELD_RANGES.items() if name != "seed")
    assert validate_request(EpisodeRequest(seed=2**32 - 1, num_targets=20, num_objects=20)) is None


def test_a_scene_file_brings_its_own_counts(tmp_path):
    scene = tmp_path / "scene.json"
    scene.write_text("{}")
    assert validate_request(EpisodeRequest(scenario="file", scene_file=str(scene), num_targets=3,
                                           num_objects=0)) is None


def test_a_request_is_described_with_its_palette():
    assert describe_request(EpisodeRequest("random", seed=3, palette="coal_slate")) == (
        "random seed 3, palette coal_slate, 2 target(s) among 20 object(s)")
    assert "palette default" in describe_request(EpisodeRequest())
    assert describe_request(EpisodeRequest(max_actions=7)).endswith("at most 7 actions")


def test_good_request_passes_and_action_limit_scales_with_targets():
    request = EpisodeRequest(scenario="invisible", num_targets=3)
    assert validate_request(request) is None
    assert action_limit(request, 3) == 45
    assert action_limit(EpisodeRequest(max_actions=7), 3) == 7


def test_metrics_follow_the_paper_definitions():
    tracker = EpisodeTracker("e", EpisodeRequest(), targets_total=2, max_actions=30)
    tracker.record(step(1, kind="push", success=True))
    tracker.record(step(2, success=False))
    tracker.record(step(3, success=True, target=True, remaining=1))
    tracker.record(step(4, success=True, target=False, remaining=1))  # a product block: false reject
    tracker.record(step(5, success=True, target=True, remaining=0))
    metrics = tracker.metrics()
    assert metrics["targets_picked"] == 2
    assert metrics["grasp_attempts"] == 4
    assert metrics["grasp_success"] == pytest.approx(2 / 4)
    assert metrics["action_efficiency"] == pytest.approx(2 / 5)
    assert metrics["false_rejects"] == 1
    assert metrics["pushes"] == 1
    assert tracker.termination() == TERMINATION_ALL_PICKED


def test_termination_by_action_limit_and_repeated_failure():
    limited = EpisodeTracker("e", EpisodeRequest(), 2, max_actions=2)
    limited.record(step(1, kind="push", success=True))
    assert limited.termination() is None
    limited.record(step(2, kind="push", success=True))
    assert limited.termination() == TERMINATION_ACTION_LIMIT

    failing = EpisodeTracker("e", EpisodeRequest(), 2, max_actions=50, max_consecutive_failures=3)
    failing.record(step(1))
    failing.record(step(2))
    failing.record(step(3, success=True))  # lifting anything resets the count
    for i in range(4, 7):
        failing.record(step(i))
    assert failing.termination() == TERMINATION_REPEATED_FAILURE


def test_targets_outside_the_workspace_are_counted_apart():
    # 2 targets in the scene, 1 of them outside the workspace (x = 0.74 m).
    tracker = EpisodeTracker("e", EpisodeRequest(), targets_total=2, max_actions=30)
    tracker.set_scene(in_workspace=1, outside=1)
    assert (tracker.targets_total, tracker.targets_remaining, tracker.targets_outside) == (2, 1, 1)
    tracker.record(step(1, kind="push", success=True, remaining=1, outside=1))
    assert tracker.termination() is None
    tracker.record(step(2, success=True, target=True, remaining=0, outside=1))
    assert tracker.termination() == TERMINATION_REACHABLE_PICKED  # not "all_targets_picked"
    metrics = tracker.metrics()
    assert (metrics["targets_total"], metrics["targets_picked"], metrics["targets_outside"]) == (2, 1, 1)
    inside = EpisodeTracker("e", EpisodeRequest(), 2, 30)
    inside.set_scene(2)
    inside.record(step(1, success=True, target=True, remaining=1))
    inside.record(step(2, success=True, target=True, remaining=0))
    assert inside.termination() == TERMINATION_ALL_PICKED and inside.metrics()["targets_outside"] == 0


@pytest.mark.parametrize("bad, fragment", [
    (step(2, success=True, target=True, remaining=0, outside=1), "1 outside it is more than the 1 target"),
    (step(2, success=True, target=True, remaining=1), "2 picked + 1 left"),
    (step(2, kind="push", success=True, remaining=0, outside=2), "2 outside it is more than"),
    (step(2, kind="push", success=True, remaining=-1), "negative target counts (-1 left"),
])
def test_a_step_that_counts_more_targets_than_there_were_is_refused_and_not_counted(bad, fragment):
    tracker = EpisodeTracker("e", EpisodeRequest(), targets_total=1, max_actions=30)
    tracker.set_scene(1)
    tracker.record(step(1, success=True, target=True, remaining=0))
    with pytest.raises(CountError, match="the cell counts targets wrongly") as refused:
        tracker.record(bad)
    assert fragment in str(refused.value)
    assert tracker.metrics()["targets_picked"] == 1 and tracker.actions == 1


def test_no_sequence_of_steps_shows_more_picked_than_there_were():
    """The tracker's invariant over random counts from a (possibly wrong) cell: picked <= total, and
    picked + left + outside <= total, whatever it is told."""
    rng = np.random.default_rng(0)
    for episode in range(200):
        total = int(rng.integers(0, 4))
        outside = int(rng.integers(0, total + 1))
        tracker = EpisodeTracker(f"e{episode}", EpisodeRequest(), total, 50)
        tracker.set_scene(total - outside, outside)
        for index in range(1, 12):
            kind = ("push", "grasp")[int(rng.integers(2))]
            candidate = step(index, kind=kind, success=bool(rng.integers(2)), target=bool(rng.integers(2)),
                             remaining=int(rng.integers(-1, total + 1)),
                             outside=int(rng.integers(0, total + 1)))
            try:
                tracker.record(candidate)
            except CountError:
                pass
            m = tracker.metrics()
            assert 0 <= m["targets_picked"] <= m["targets_total"] == total
            assert m["targets_picked"] + tracker.targets_remaining + m["targets_outside"] <= total
            assert m["grasp_success"] <= 1.0 and m["action_efficiency"] <= 1.0


def test_failure_reasons_are_the_cells_not_the_pickings():
    assert is_failure("node_lost: driver did not answer the goal")
    assert is_failure("stale_input: attention results are stamped 1000.2 s before this node's clock")
    assert is_failure("error: driver rejected the primitive")
    assert is_failure("unusable_input: the heightmap node dropped 3 camera frames in a row "
                      "(/heightmap/dropped): depth does not fit the table")
    assert not any(is_failure(reason) for reason in (TERMINATION_ALL_PICKED, TERMINATION_REACHABLE_PICKED,
                                                     TERMINATION_ACTION_LIMIT, "canceled"))


def test_records_survive_a_crash_mid_line(tmp_path):
    recorder = EpisodeRecorder(tmp_path, "ep1")
    recorder.write_start(EpisodeRequest(), 2, 30, scene_ready_ns=5)
    recorder.write_step(step(1))
    with open(recorder.steps_path, "a") as stream:  # a writer killed halfway through a line
        stream.write('{"event": "step", "step": 2, "kin')
    records = read_steps(recorder.steps_path)
    assert [r["event"] for r in records] == ["start", "step"]
    assert records[1]["pixel"] == [100, 100]


def test_summary_is_written_to_the_episode_and_the_index(tmp_path):
    tracker = EpisodeTracker("ep2", EpisodeRequest(), 1, 15)
    tracker.record(step(1, success=True, target=True, remaining=0))
    recorder = EpisodeRecorder(tmp_path, "ep2")
    summary = recorder.write_summary(tracker.metrics(), tracker.termination())
    assert json.loads(recorder.summary_path.read_text()) == summary
    index = [json.loads(line) for line in (tmp_path / "episodes.jsonl").read_text().splitlines()]
    assert index[0]["episode_id"] == "ep2" and index[0]["termination_reason"] == TERMINATION_ALL_PICKED


def test_the_summary_keeps_the_request_with_its_palette(tmp_path):
    request = EpisodeRequest("random", seed=3, palette="coal_slate")
    recorder = EpisodeRecorder(tmp_path, "ep3", request)
    recorder.write_summary(EpisodeTracker("ep3", request, 2, 30).metrics(), "canceled")
    summary = json.loads(recorder.summary_path.read_text())
    assert summary["request"]["palette"] == "coal_slate" and summary["request"]["seed"] == 3


def test_a_discarded_record_leaves_no_folder_and_its_index_line(tmp_path):
    recorder = EpisodeRecorder(tmp_path, "refused", EpisodeRequest(palette="teal"))
    recorder.write_summary(EpisodeTracker("refused", EpisodeRequest(), 2, 30).metrics(),
                           "error: scene reset failed: unknown palette 'teal'")
    recorder.discard()
    assert [path.name for path in tmp_path.iterdir()] == ["episodes.jsonl"]
    assert "unknown palette" in read_steps(tmp_path / "episodes.jsonl")[0]["termination_reason"]


def test_episode_picture_draws_each_primitive():
    heightmap = np.full((224, 224, 3), 90, np.uint8)
    steps = [dict(step=1, kind="push", pixel=[50, 60], yaw=0.0, target_grasped=False, object_grasped=False),
             dict(step=2, kind="grasp", pixel=[150, 150], yaw=1.2, target_grasped=True, object_grasped=True)]
    picture = draw_episode(heightmap, steps, scale=2)
    assert picture.shape == (448, 448, 3)
    blank = draw_episode(heightmap, [], scale=2)
    changed = np.any(picture != blank, axis=2)
    # The push arrow runs along +col from pixel (50, 60); the grasp mark is green around (150, 150).
    assert changed[101, 122:200].sum() > 40
    assert picture[301, 301, 1] > 150 and picture[301, 301, 0] < 50
