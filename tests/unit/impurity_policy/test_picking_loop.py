"""The picking loop (impurity_policy.core.picking.run_episode) against a scripted cell: when an episode
ends and why, what it counts (the paper's metrics, section 6.1), what it records, and what it reports
step by step. No simulator, no ROS: the cell below plays a script of outcomes."""

import pytest

from impurity_policy.core.episode import (
    TERMINATION_ACTION_LIMIT,
    TERMINATION_ALL_PICKED,
    TERMINATION_CANCELED,
    TERMINATION_NOTHING_LEFT,
    TERMINATION_REPEATED_FAILURE,
    EpisodeRecorder,
    EpisodeRequest,
    read_steps,
)
from impurity_policy.core.picking import Action, EpisodeAborted, EpisodeLimits, Outcome, View, run_episode
from impurity_policy.core.policy import MODE_NONE, MODE_OCCLUDED_REGION, MODE_TARGET


def grasp(success=True, target=None):
    """A grasp that lifts something (success) and, by default, the target when it does."""
    return "grasp", Outcome(success, success if target is None else target, "grasp")


def push(success=True):
    return "push", Outcome(success, False, "push")


class ScriptedCell:
    """A cell that plays `script`: one (kind, Outcome) per executed action, or an exception that
    `execute` raises. Attention sees `modes` in turn (then TARGET); the decision is None once the
    script is played out. A grasp that lifts the target takes one target out of the scene."""

    def __init__(self, script=(), targets=2, modes=()):
        self.script, self.targets, self.modes = list(script), targets, list(modes)
        self.calls: list = []

    def reset(self, request):
        self.calls.append("reset")
        return self.targets

    def observe(self):
        self.calls.append("observe")
        return View(self.modes.pop(0) if self.modes else MODE_TARGET)

    def decide(self, view):
        self.calls.append("decide")
        if not self.script:
            return None
        kind = self.script[0][0] if isinstance(self.script[0], tuple) else "push"
        index = sum(call == "execute" for call in self.calls)
        return Action(kind, (0.5, 0.0, 0.02), 0.1 * index, 0.5 + index, index, (100, 100 + index), view.mode)

    def execute(self, action):
        self.calls.append("execute")
        entry = self.script.pop(0)
        if isinstance(entry, Exception):
            raise entry
        return entry[1]

    def targets_remaining(self, outcome, before):
        return before - 1 if outcome.target_grasped else before


def run(script=(), targets=2, modes=(), request=None, **kwargs):
    cell = ScriptedCell(script, targets, modes)
    summary = run_episode(cell, request or EpisodeRequest("random", seed=1, num_targets=targets), "ep-1",
                          **kwargs)
    return summary, cell


# ---- why an episode ends -------------------------------------------------------------------------------
def test_ends_with_all_targets_picked_when_none_remains():
    summary, cell = run([grasp(), push(), grasp(), push()], targets=2)
    assert summary["termination_reason"] == TERMINATION_ALL_PICKED
    assert summary["actions"] == 3 and summary["targets_picked"] == 2 and summary["completed"]
    assert len(cell.script) == 1  # the last push was never asked for


def test_a_scene_without_targets_ends_at_once_and_is_not_completed():
    summary, cell = run([push()], targets=0)
    assert summary["termination_reason"] == TERMINATION_ALL_PICKED
    assert summary["actions"] == 0 and not summary["completed"] and cell.calls == ["reset"]


@pytest.mark.parametrize("max_actions, limits, targets, expected", [
    (3, EpisodeLimits(), 2, 3),  # the request's own limit
    (0, EpisodeLimits(actions_per_target=2), 3, 6),  # else actions_per_target x targets in the scene
    (0, EpisodeLimits(actions_per_target=4), 1, 4),
])
def test_ends_at_the_action_limit(max_actions, limits, targets, expected):
    # the scene the cell builds holds `targets`, whatever the request asked for
    request = EpisodeRequest("random", seed=1, num_targets=5, max_actions=max_actions)
    summary, _ = run([push()] * 20, targets=targets, request=request, limits=limits)
    assert summary["termination_reason"] == TERMINATION_ACTION_LIMIT
    assert summary["actions"] == expected and summary["targets_total"] == targets


def test_ends_after_max_consecutive_failed_grasps_in_a_row():
    limits = EpisodeLimits(max_consecutive_failures=3)
    script = [grasp(False), grasp(False), grasp(True, target=False),  # lifting a neighbour ends the run
              grasp(False), grasp(False), grasp(False), grasp(False)]  # of failures; then 3 in a row
    summary, cell = run(script, targets=2, limits=limits)
    assert summary["termination_reason"] == TERMINATION_REPEATED_FAILURE
    assert summary["actions"] == 6 and len(cell.script) == 1


def test_a_failed_push_counts_as_a_failure_too():
    summary, _ = run([push(False), grasp(False)], targets=1, limits=EpisodeLimits(max_consecutive_failures=2))
    assert summary["termination_reason"] == TERMINATION_REPEATED_FAILURE and summary["actions"] == 2


def test_ends_with_nothing_left_when_attention_finds_nothing_without_asking_the_decision():
    summary, cell = run([push(), push(), push()], modes=[MODE_OCCLUDED_REGION, MODE_NONE])
    assert summary["termination_reason"] == TERMINATION_NOTHING_LEFT and summary["actions"] == 1
    assert cell.calls == ["reset", "observe", "decide", "execute", "observe"]


def test_ends_with_nothing_left_when_the_decision_is_none():
    summary, cell = run([push()])
    assert summary["termination_reason"] == TERMINATION_NOTHING_LEFT and summary["actions"] == 1
    assert cell.calls[-2:] == ["observe", "decide"]


def test_ends_canceled_when_should_stop_says_so_after_a_step():
    asked = []

    def should_stop():
        asked.append(len(asked) + 1)
        return len(asked) == 2

    summary, _ = run([push()] * 5, should_stop=should_stop)
    assert summary["termination_reason"] == TERMINATION_CANCELED
    assert summary["actions"] == 2 and asked == [1, 2]  # asked once after each step


def test_an_aborted_episode_ends_with_its_reason_and_still_writes_its_records(tmp_path):
    recorder = EpisodeRecorder(tmp_path, "ep-1")
    summary, _ = run([push(), grasp(False), EpisodeAborted("node_lost: x")], recorder=recorder,
                     clock_ns=lambda: 123)
    assert summary["termination_reason"] == "node_lost: x" and summary["actions"] == 2
    records = read_steps(recorder.steps_path)
    assert [r["event"] for r in records] == ["start", "step", "step", "end"]
    assert records[0]["scene_ready_ns"] == 123 and records[0]["targets_total"] == 2
    assert [r["kind"] for r in records[1:3]] == ["push", "grasp"]
    assert records[-1]["termination_reason"] == "node_lost: x"
    assert recorder.summary_path.is_file() and summary["record_path"] == str(recorder.directory)
    assert read_steps(tmp_path / "episodes.jsonl")[-1]["termination_reason"] == "node_lost: x"


def test_an_unexpected_exception_ends_as_an_error_and_is_reported():
    seen = []
    error = RuntimeError("gripper on fire")
    summary, _ = run([push(), error], on_error=seen.append)
    reason = summary["termination_reason"]
    assert reason.startswith("error: ") and "gripper on fire" in reason
    assert seen == [error] and summary["actions"] == 1


# ---- what it counts and reports ------------------------------------------------------------------------
def test_metrics_are_the_papers_on_a_scripted_episode():
    script = [push(), grasp(False), grasp(True, target=False), grasp(True), push(False), grasp(True)]
    summary, _ = run(script, targets=2)
    assert summary["termination_reason"] == TERMINATION_ALL_PICKED and summary["completed"]
    assert (summary["actions"], summary["pushes"], summary["grasp_attempts"]) == (6, 2, 4)
    assert (summary["grasp_successes"], summary["targets_picked"], summary["false_rejects"]) == (3, 2, 1)
    assert summary["grasp_success"] == pytest.approx(2 / 4)  # targets picked / grasp attempts
    assert summary["action_efficiency"] == pytest.approx(2 / 6)  # targets picked / actions
    partial, _ = run([grasp(False), grasp()], targets=2, request=EpisodeRequest(num_targets=2, max_actions=2))
    assert partial["termination_reason"] == TERMINATION_ACTION_LIMIT and not partial["completed"]
    assert partial["grasp_success"] == 0.5 and partial["action_efficiency"] == 0.5
    nothing, _ = run([], targets=2)
    assert nothing["grasp_success"] == 0.0 and nothing["action_efficiency"] == 0.0  # no division by zero


def test_on_step_sees_every_step_in_order():
    steps = []
    script = [push(), grasp(False), grasp(), push(False), grasp()]
    summary, _ = run(script, targets=2, modes=[MODE_OCCLUDED_REGION], on_step=steps.append)
    assert [s.step for s in steps] == [1, 2, 3, 4, 5] and summary["actions"] == 5
    assert [s.kind for s in steps] == [kind for kind, _ in script]
    assert [s.success for s in steps] == [True, False, True, False, True]
    assert [s.targets_remaining for s in steps] == [2, 2, 1, 1, 0]
    assert [s.attention_mode for s in steps] == ["OCCLUDED_REGION"] + ["TARGET"] * 4
    assert [s.pixel for s in steps] == [(100, 100 + i) for i in range(5)]  # each step its own action
