"""The picking loop (impurity_policy.core.picking.run_episode) against a scripted cell: when an episode
ends and why, what it counts (the paper's metrics, section 6.1), what it records, and what it reports
step by step. No simulator, no ROS: the cell below plays a script of outcomes."""

import pytest

from impurity_policy.core.episode import (
    COUNTED_BY_NOTHING,
    TERMINATION_ACTION_LIMIT,
    TERMINATION_ALL_PICKED,
    TERMINATION_CANCELED,
    TERMINATION_NOTHING_LEFT,
    TERMINATION_REACHABLE_PICKED,
    TERMINATION_REPEATED_FAILURE,
    EpisodeRecorder,
    EpisodeRequest,
    read_steps,
)
from impurity_policy.core.picking import (
    Action,
    EpisodeAborted,
    EpisodeCanceled,
    EpisodeLimits,
    Outcome,
    Targets,
    View,
    run_episode,
)
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


@pytest.mark.parametrize("canceled_at_ask, actions", [
    (1, 0),  # before the first look
    (2, 0),  # while the first decision was awaited: that decision is not executed
    (3, 1),  # after the first step, before the next look
    (4, 1),  # while the second decision was awaited
])
def test_a_cancel_is_asked_before_each_look_and_each_motion_and_no_motion_follows_it(canceled_at_ask,
                                                                                      actions):
    asked = []

    def should_stop():
        asked.append(len(asked) + 1)
        return len(asked) >= canceled_at_ask

    summary, cell = run([push()] * 5, should_stop=should_stop)
    assert summary["termination_reason"] == TERMINATION_CANCELED
    assert summary["actions"] == actions == cell.calls.count("execute")
    assert len(asked) == canceled_at_ask  # asked until it said so, never after


class WaitingCell(ScriptedCell):
    """A cell whose verbs wait like RosCell's: each wait checks the should_stop it was handed and raises
    EpisodeCanceled. The client cancels during the `call`-th wait of `verb` (execute waits for the
    driver's answer before its motion)."""

    def __init__(self, script, verb=None, call=1, **kwargs):
        super().__init__(script, **kwargs)
        self.verb, self.call, self.should_stop, self.bound = verb, call, None, []
        self.waits: list = []
        self.canceled = False

    def set_should_stop(self, should_stop):
        self.bound.append(should_stop)
        self.should_stop = should_stop

    def _wait(self, verb):
        self.waits.append(verb)
        if verb == self.verb and self.waits.count(verb) == self.call:
            self.canceled = True  # the client cancels while this wait runs
        if self.should_stop is not None and self.should_stop():
            raise EpisodeCanceled(f"canceled while waiting in {verb}")

    def reset(self, request):
        self._wait("reset")
        return super().reset(request)

    def observe(self):
        self._wait("observe")
        return super().observe()

    def execute(self, action):
        self._wait("execute")
        return super().execute(action)

    def targets_remaining(self, outcome, before):
        self._wait("targets_remaining")
        return super().targets_remaining(outcome, before)


@pytest.mark.parametrize("verb, call, actions", [
    ("reset", 1, 0),  # waiting for /cell/reset_scene
    ("observe", 2, 1),  # waiting for a decision
    ("execute", 2, 1),  # waiting for the driver to answer the goal: no motion, no step
    ("targets_remaining", 2, 2),  # the motion happened: recorded, with the counts from before it
])
def test_a_cancel_seen_in_a_cell_wait_ends_the_episode_canceled_with_its_records_closed(
        tmp_path, verb, call, actions):
    cell = WaitingCell([push()] * 5, verb, call, targets=2)
    recorder = EpisodeRecorder(tmp_path, "ep-1")
    summary = run_episode(cell, EpisodeRequest("random", seed=1, num_targets=2), "ep-1", recorder=recorder,
                          should_stop=lambda: cell.canceled)
    assert summary["termination_reason"] == TERMINATION_CANCELED
    assert cell.waits[-1] == verb and cell.waits.count(verb) == call  # it ended in that very wait
    records = read_steps(recorder.steps_path)
    steps = [r for r in records if r["event"] == "step"]
    assert summary["actions"] == len(steps) == actions == 5 - len(cell.script)
    if verb == "targets_remaining":
        assert steps[-1]["message"] == "push (targets not recounted: canceled)"
        assert steps[-1]["targets_remaining"] == 2
    assert records[-1]["event"] == "end" and records[-1]["termination_reason"] == TERMINATION_CANCELED
    assert recorder.summary_path.is_file()
    assert read_steps(tmp_path / "episodes.jsonl")[-1]["termination_reason"] == TERMINATION_CANCELED
    assert cell.bound[0] is not None and cell.bound[-1] is None  # handed over, then taken back


def test_cells_without_set_should_stop_and_loops_without_should_stop_work_as_before():
    cell = WaitingCell([push(), grasp(), grasp()], targets=2)
    summary = run_episode(cell, EpisodeRequest("random", seed=1, num_targets=2), "ep-1")
    assert summary["termination_reason"] == TERMINATION_ALL_PICKED and cell.bound == []


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


class RefusingCell(ScriptedCell):
    def reset(self, request):
        raise EpisodeAborted("error: scene reset failed: unknown palette 'teal'; known: blocks, ...")


def test_on_started_is_called_once_after_the_reset_and_not_when_the_reset_fails():
    seen = []
    cell = ScriptedCell([push()], targets=1)
    run_episode(cell, EpisodeRequest("random", seed=1, num_targets=1), "ep-1",
                on_started=lambda: seen.append(list(cell.calls)))
    assert seen == [["reset"]]  # once, after the reset and before the first look
    refused = []
    summary = run_episode(RefusingCell(), EpisodeRequest("random", seed=1), "ep-2",
                          on_started=lambda: refused.append(True))
    assert refused == [] and summary["termination_reason"].startswith("error: scene reset failed")
    assert summary["actions"] == 0


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


# ---- targets outside the workspace --------------------------------------------------------------------
class CountingCell(ScriptedCell):
    """A cell that counts like a simulator: reset and every step report Targets (in the workspace,
    outside it) from `counts`, in turn."""

    def __init__(self, script, counts, **kwargs):
        super().__init__(script, **kwargs)
        self.counts = list(counts)

    def reset(self, request):
        super().reset(request)
        return self.counts.pop(0)

    def targets_remaining(self, outcome, before):
        return self.counts.pop(0)


def run_counting(script, counts, tmp_path, **kwargs):
    cell = CountingCell(script, counts)
    recorder = EpisodeRecorder(tmp_path, "ep-1")
    summary = run_episode(cell, EpisodeRequest("file", num_targets=2, scene_file="scene.json"), "ep-1",
                          recorder=recorder, **kwargs)
    return summary, read_steps(recorder.steps_path)


def test_a_target_outside_the_workspace_from_the_start_is_counted_apart(tmp_path):
    # The instance: a scene file with a second impurity at x = 0.74 m; the reset reports 2 targets, 1 of
    # them outside the workspace. Picking the other one ends "all_reachable_targets_picked", not completed.
    counts = [Targets(1, 1), Targets(1, 1), Targets(0, 1)]
    summary, records = run_counting([push(), grasp()], counts, tmp_path)
    assert summary["termination_reason"] == TERMINATION_REACHABLE_PICKED
    assert (summary["targets_total"], summary["targets_picked"], summary["targets_outside"]) == (2, 1, 1)
    assert not summary["completed"] and summary["actions"] == 2
    assert records[0]["targets_total"] == 2 and records[0]["targets_outside"] == 1
    assert records[0]["max_actions"] == 15  # 15 per target the cell can reach
    assert [r["targets_outside"] for r in records if r["event"] == "step"] == [1, 1]
    assert records[-1]["targets_outside"] == 1


def test_a_target_pushed_out_of_the_workspace_is_counted_apart(tmp_path):
    counts = [Targets(2, 0), Targets(1, 1), Targets(0, 1)]  # the push moves one target out
    summary, records = run_counting([push(), grasp()], counts, tmp_path)
    assert summary["termination_reason"] == TERMINATION_REACHABLE_PICKED
    assert (summary["targets_total"], summary["targets_picked"], summary["targets_outside"]) == (2, 1, 1)
    assert not summary["completed"]
    assert [(r["targets_remaining"], r["targets_outside"]) for r in records if r["event"] == "step"] == [
        (1, 1), (0, 1)]


def test_every_target_outside_the_workspace_ends_at_once(tmp_path):
    summary, _ = run_counting([push()], [Targets(0, 2)], tmp_path)
    assert summary["termination_reason"] == TERMINATION_REACHABLE_PICKED
    assert summary["actions"] == 0 and summary["targets_outside"] == 2 and not summary["completed"]


def test_a_cell_that_counts_more_targets_than_there_were_ends_the_episode_as_an_error(tmp_path):
    # The cell says a target was picked but also that both are still in the workspace: 1 + 2 > 2.
    seen = []
    summary, records = run_counting([grasp(), grasp()], [Targets(2, 0), Targets(2, 0)], tmp_path,
                                    on_error=seen.append)
    assert summary["termination_reason"].startswith("error: CountError")
    assert "more than the 2 target(s)" in summary["termination_reason"] and len(seen) == 1
    assert summary["targets_picked"] == 0 and summary["actions"] == 0  # nothing of the bad step counted
    assert records[-1]["event"] == "end"


def test_a_motion_the_driver_refuses_ends_the_episode_at_the_first_refusal():
    # A refusal is not one of max_consecutive_failures (bringup/config/cell.yaml says so too).
    refused = EpisodeAborted("error: driver rejected the primitive (its log says why)")
    summary, cell = run([push(), refused, push(), push()], limits=EpisodeLimits(max_consecutive_failures=5))
    assert summary["termination_reason"] == str(refused) and summary["actions"] == 1
    assert len(cell.script) == 2  # nothing was tried after the refusal


class LostResetCell(ScriptedCell):
    """A cell whose scene service is gone: reset raises EpisodeAborted."""

    def reset(self, request):
        raise EpisodeAborted("node_lost: /cell/reset_scene")


@pytest.mark.parametrize("ending", ["canceled in the reset", "aborted in the reset"])
def test_an_episode_that_ends_before_its_scene_is_ready_records_that_it_counted_nothing(tmp_path, ending):
    cell = WaitingCell([push()] * 5, "reset", 1, targets=2) if "canceled" in ending else LostResetCell()
    recorder = EpisodeRecorder(tmp_path, "ep-1")
    summary = run_episode(cell, EpisodeRequest("random", seed=1, num_targets=2), "ep-1", recorder=recorder,
                          should_stop=lambda: getattr(cell, "canceled", False))
    assert summary["counted_by"] == COUNTED_BY_NOTHING and summary["targets_total"] == -1
    assert summary["targets_picked"] == summary["actions"] == 0 and not summary["completed"]
    written = read_steps(tmp_path / "episodes.jsonl")[-1]
    assert written["counted_by"] == COUNTED_BY_NOTHING and written["targets_total"] == -1
