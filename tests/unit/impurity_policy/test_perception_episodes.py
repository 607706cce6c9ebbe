"""Episodes on a cell without ground truth: the picking loop counts by perception.

No target count up front; the episode ends when attention answers NONE on N consecutive fresh views, at
the action limit or after repeated failures; each grasp is judged by the next view (core/verdict.py).
A cell that offers truth() gets it recorded beside each verdict, and nothing it says steers the loop.
No simulator, no ROS: the cell below plays a script of views and outcomes."""

import dataclasses
import json

import numpy as np
import pytest

from impurity_policy.core.episode import (
    TERMINATION_ACTION_LIMIT,
    TERMINATION_NOTHING_LEFT,
    TERMINATION_REPEATED_FAILURE,
    EpisodeRecorder,
    EpisodeRequest,
    is_failure,
    read_steps,
)
from impurity_policy.core.picking import (
    Action,
    EpisodeAborted,
    EpisodeLimits,
    Outcome,
    Truth,
    View,
    run_episode,
)
from impurity_policy.core.policy import MODE_NONE, MODE_OCCLUDED_REGION, MODE_TARGET

SHAPE = (30, 30)
TARGET_CELLS = (slice(10, 20), slice(10, 20))
HEAP_CELLS = (slice(0, 8), slice(20, 30))


def view(mode=MODE_TARGET, target_there=True):
    """A view whose target (red, 3 cm) stands at TARGET_CELLS when target_there; mask on it for TARGET; an
    OCCLUDED_REGION view shows the heap attention attends, 8 cm of product at HEAP_CELLS."""
    height = np.zeros(SHAPE, np.float32)
    color = np.full((*SHAPE, 3), 60, np.uint8)
    if mode == MODE_OCCLUDED_REGION:
        height[HEAP_CELLS] = 0.08
    mask = None
    if target_there:
        height[TARGET_CELLS] = 0.03
        color[TARGET_CELLS] = (200, 30, 30)
    if mode == MODE_TARGET:
        mask = np.zeros(SHAPE, bool)
        mask[TARGET_CELLS] = True
    return View(mode, color, None, height, mask)


def grasp(holding=True, sim_says_target=False):
    """A grasp outcome as a real arm reports it; sim_says_target: a simulator's truth leaking in."""
    return "grasp", Outcome(holding, sim_says_target, "grasp", holding=holding,
                            gripper_opening=0.03 if holding else 0.0)


def push(success=True):
    return "push", Outcome(success, False, "push", holding=False)


class RealCell:
    """A cell that cannot count targets (reset -> None). `views` are returned by observe in turn (then
    NONE); `script` holds one (kind, Outcome) per executed action, or an exception to raise. `truth`:
    Truth values returned in turn by truth() (None: the cell offers none)."""

    def __init__(self, views, script, truth=None):
        self.views, self.script = list(views), list(script)
        self.truths = None if truth is None else list(truth)
        self.calls: list = []

    def reset(self, request):
        self.calls.append("reset")
        return None

    def observe(self):
        self.calls.append("observe")
        entry = self.views.pop(0) if self.views else view(MODE_NONE, target_there=False)
        if isinstance(entry, Exception):
            raise entry
        return entry

    def decide(self, v):
        self.calls.append("decide")
        kind = self.script[0][0] if self.script and isinstance(self.script[0], tuple) else "push"
        return Action(kind, (0.5, 0.0, 0.02), 0.0, 1.0, 0, (15, 15), v.mode)

    def execute(self, action):
        self.calls.append("execute")
        entry = self.script.pop(0)
        if isinstance(entry, Exception):
            raise entry
        return entry[1]

    def targets_remaining(self, outcome, before):
        raise AssertionError("a cell without counts is never asked for them")

    def truth(self):
        if self.truths is None:
            return None
        self.calls.append("truth")
        return self.truths.pop(0)


def run(views, script, truth=None, limits=EpisodeLimits(none_frames_to_finish=3), request=None, **kwargs):
    cell = RealCell(views, script, truth)
    summary = run_episode(cell, request or EpisodeRequest("random", seed=1), "ep-1", limits, **kwargs)
    return summary, cell


NONE = view(MODE_NONE, target_there=False)


def exposed(v, factor):
    """The view `v` as a camera would give it at another exposure: RGB scaled, clipped at 255."""
    color = np.clip(np.rint(v.color * float(factor)), 0, 255).astype(np.uint8)
    return dataclasses.replace(v, color=color)


@pytest.mark.parametrize("factor", [0.6, 0.7, 0.8])
def test_a_grasp_that_left_the_target_is_not_counted_when_the_next_view_came_out_darker(factor):
    after = exposed(view(MODE_NONE, target_there=True), factor)  # the target still there, the view darker
    summary, _ = run([view(), after, NONE, NONE], [grasp(holding=True)])
    assert summary["targets_picked"] == 0 and summary["grasp_success"] == 0.0
    picked, _ = run([view(), exposed(NONE, factor), NONE, NONE], [grasp(holding=True)])
    assert picked["targets_picked"] == 1  # really gone: still counted


# ---- how an episode without counts ends ---------------------------------------------------------------
def test_ends_by_perception_after_n_consecutive_none_views_without_any_target_count():
    summary, cell = run([view(), NONE, NONE, NONE], [grasp()])
    assert summary["termination_reason"] == TERMINATION_NOTHING_LEFT and summary["completed"]
    assert summary["counted_by"] == "perception" and summary["targets_total"] == -1
    assert summary["targets_picked"] == 1 and summary["actions"] == 1
    assert cell.calls == ["reset", "observe", "decide", "execute", "observe", "observe", "observe"]


def test_a_none_view_between_targets_does_not_end_the_episode():
    views = [view(), NONE, NONE, view(), NONE, NONE, NONE]  # two NONE, then a target seen again
    summary, cell = run(views, [push(), push()])
    assert summary["termination_reason"] == TERMINATION_NOTHING_LEFT and summary["actions"] == 2
    assert cell.views == []


@pytest.mark.parametrize("frames", [1, 5])
def test_none_frames_to_finish_sets_how_many_none_views_end_it(frames):
    summary, cell = run([], [], limits=EpisodeLimits(none_frames_to_finish=frames))
    assert summary["termination_reason"] == TERMINATION_NOTHING_LEFT
    assert cell.calls.count("observe") == frames and summary["actions"] == 0


@pytest.mark.parametrize("max_actions, limit, expected", [(0, 4, 4), (2, 4, 2)])
def test_the_action_limit_is_the_requests_else_max_actions_uncounted(max_actions, limit, expected):
    summary, _ = run([view()] * 10, [push()] * 10, request=EpisodeRequest(max_actions=max_actions),
                     limits=EpisodeLimits(max_actions_uncounted=limit))
    assert summary["termination_reason"] == TERMINATION_ACTION_LIMIT and summary["actions"] == expected


def test_repeated_failures_end_it():
    summary, _ = run([view()] * 10, [grasp(holding=False)] * 10,
                     limits=EpisodeLimits(max_consecutive_failures=3))
    assert summary["termination_reason"] == TERMINATION_REPEATED_FAILURE and summary["actions"] == 3


# ---- each grasp judged by perception --------------------------------------------------------------------
def test_each_grasp_is_judged_by_the_next_view_and_the_picked_count_is_the_verdicts(tmp_path):
    views = [view(), view(),  # grasp 1 lifts a neighbour: the target stays
             view(target_there=False),  # grasp 2: the target is gone
             NONE, NONE]
    recorder = EpisodeRecorder(tmp_path, "ep-1")
    summary, _ = run(views, [grasp(), grasp()], recorder=recorder)
    assert (summary["targets_picked"], summary["false_rejects"], summary["grasp_attempts"]) == (1, 1, 2)
    steps = [r for r in read_steps(recorder.steps_path) if r["event"] == "step"]
    assert [s["target_grasped"] for s in steps] == [False, True]
    assert [s["gone_fraction"] for s in steps] == [0.0, 1.0]
    assert "not the impurity" in steps[0]["verdict"] and "impurity picked" in steps[1]["verdict"]
    assert all(s["targets_remaining"] == -1 and s["holding"] for s in steps)
    assert steps[1]["gripper_opening"] == pytest.approx(0.03)


def test_the_simulators_target_grasped_in_an_outcome_is_ignored():
    # the target stays in view although the driver's simulator-only field says it was grasped
    summary, _ = run([view(), view(), NONE, NONE, NONE], [grasp(sim_says_target=True)])
    assert summary["targets_picked"] == 0 and summary["false_rejects"] == 1


def test_a_grasp_answering_an_occluded_region_is_not_counted_as_an_impurity():
    summary, _ = run([view(MODE_OCCLUDED_REGION, target_there=False), NONE, NONE, NONE], [grasp()])
    assert summary["targets_picked"] == 0 and summary["grasp_successes"] == 1


def test_a_push_is_not_judged():
    summary, cell = run([view(), NONE, NONE, NONE], [push()])
    assert summary["targets_picked"] == 0 and summary["actions"] == 1


# ---- truth beside the verdicts, never steering ----------------------------------------------------------
def test_truth_is_recorded_beside_each_verdict_and_their_agreement_summarised(tmp_path):
    views = [view(), view(), view(target_there=False), view(), view(target_there=False), NONE, NONE, NONE]
    truth = [Truth(2, 0, 0),  # at the start: 2 targets
             Truth(2, 0, 0),  # grasp 1: nothing removed (verdict: not picked -> agrees)
             Truth(1, 0, 1),  # grasp 2: a target removed (verdict: picked -> agrees)
             Truth(1, 0, 1)]  # grasp 3: nothing removed, but the view says gone (verdict disagrees)
    recorder = EpisodeRecorder(tmp_path, "ep-1")
    summary, _ = run(views, [grasp(), grasp(), grasp()], truth, recorder=recorder)
    steps = [r for r in read_steps(recorder.steps_path) if r["event"] == "step"]
    assert [s["truth_target_grasped"] for s in steps] == [False, True, False]
    assert [s["target_grasped"] for s in steps] == [False, True, True]
    assert summary["targets_picked"] == 2 and summary["truth_targets_picked"] == 1
    assert summary["truth_targets_total"] == 2
    assert (summary["verdicts_checked"], summary["verdicts_agreeing"]) == (3, 2)
    assert summary["verdict_agreement"] == pytest.approx(2 / 3) and summary["picked_matches_truth"] is False
    written = json.loads(recorder.summary_path.read_text())
    assert (written["verdicts_checked"], written["verdicts_agreeing"], written["truth_targets_picked"]) == (
        3, 2, 1)


def test_truth_saying_every_target_is_gone_does_not_end_the_episode():
    # the grasp removed the only target (truth), but the next view still shows one: the loop goes on
    views = [view(), view(), NONE, NONE, NONE]
    truth = [Truth(1, 0, 0), Truth(0, 0, 1)]
    summary, cell = run(views, [grasp(), push()], truth)
    assert summary["actions"] == 2 and summary["termination_reason"] == TERMINATION_NOTHING_LEFT
    assert cell.calls.count("truth") == 2  # at the start and after the grasp: never for a push
    assert summary["targets_picked"] == 0 and summary["truth_targets_picked"] == 1
    assert summary["picked_matches_truth"] is False


def test_without_truth_the_audit_says_so():
    summary, _ = run([view(), view(target_there=False), NONE, NONE, NONE], [grasp()])
    assert summary["truth_targets_picked"] == -1 and summary["verdicts_checked"] == 0
    assert summary["verdict_agreement"] is None and summary["picked_matches_truth"] is None


# ---- a driver that drops ------------------------------------------------------------------------------
def test_a_driver_lost_mid_motion_ends_the_episode_with_its_reason_and_intact_records(tmp_path):
    lost = EpisodeAborted("driver_lost: RTDE connection dropped during moveL")
    recorder = EpisodeRecorder(tmp_path, "ep-1")
    summary, _ = run([view(), view(target_there=False), view()], [grasp(), lost], recorder=recorder)
    assert summary["termination_reason"] == str(lost) and is_failure(summary["termination_reason"])
    assert summary["actions"] == 1 and summary["targets_picked"] == 1
    records = read_steps(recorder.steps_path)
    assert [r["event"] for r in records] == ["start", "step", "end"]
    assert records[-1]["termination_reason"] == str(lost) and recorder.summary_path.is_file()


def test_a_node_lost_while_judging_a_grasp_still_records_that_grasp(tmp_path):
    recorder = EpisodeRecorder(tmp_path, "ep-1")
    summary, _ = run([view(), EpisodeAborted("node_lost: camera")], [grasp()], recorder=recorder)
    assert summary["termination_reason"] == "node_lost: camera" and summary["actions"] == 1
    steps = [r for r in read_steps(recorder.steps_path) if r["event"] == "step"]
    assert len(steps) == 1 and not steps[0]["target_grasped"] and "not judged" in steps[0]["verdict"]


# ---- attention's last look --------------------------------------------------------------------------------
def last_look(target_there=True):
    """A TARGET attention gave as a last look (no heap left, no region judged an impurity)."""
    return dataclasses.replace(view(MODE_TARGET, target_there), last_look=True)


def test_a_last_look_is_grasped_like_a_target():
    summary, cell = run([last_look(), NONE, NONE, NONE], [grasp()])
    assert summary["termination_reason"] == TERMINATION_NOTHING_LEFT
    assert summary["targets_picked"] == 1 and summary["actions"] == 1


def test_after_a_last_look_that_lifted_no_impurity_later_last_looks_count_as_none():
    # the grasp lifts nothing: the verdict says no impurity; the same suspicious region keeps being offered
    summary, cell = run([last_look(), last_look(), last_look(), last_look()], [grasp(holding=False)])
    assert summary["termination_reason"] == TERMINATION_NOTHING_LEFT and summary["completed"]
    assert summary["actions"] == 1 and summary["targets_picked"] == 0
    assert cell.calls.count("decide") == 1  # the later last looks were not decided on


def test_a_target_that_is_no_last_look_is_still_acted_on_after_a_last_look_in_vain():
    summary, _ = run([last_look(), view(), NONE, NONE, NONE], [grasp(holding=False), grasp()])
    assert summary["actions"] == 2 and summary["targets_picked"] == 1


def test_a_last_look_answered_by_a_push_was_in_vain_too():
    summary, cell = run([last_look(), last_look(), last_look(), last_look(), last_look()], [push()])
    assert summary["termination_reason"] == TERMINATION_NOTHING_LEFT
    assert summary["actions"] == 1 and cell.calls.count("decide") == 1


# ---- the known product (picking's module docstring) ------------------------------------------------------
class KnowingCell(RealCell):
    """RealCell whose attention can take a known product: know_product's calls are logged."""

    def know_product(self, v):
        self.calls.append(("know_product", v))


def run_knowing(views, script, limits=EpisodeLimits(none_frames_to_finish=3)):
    cell = KnowingCell(views, script)
    return run_episode(cell, EpisodeRequest("invisible", seed=1), "ep-1", limits), cell


def test_a_first_view_without_target_is_handed_to_the_cell_as_the_known_product_once_before_deciding():
    first = view(MODE_OCCLUDED_REGION, target_there=False)
    summary, cell = run_knowing([first, view(MODE_OCCLUDED_REGION), view(), NONE, NONE, NONE],
                                [push(), push(), grasp()])
    handed = [c for c in cell.calls if isinstance(c, tuple)]
    assert handed == [("know_product", first), ("know_product", None)]  # forgotten when the episode ends
    assert cell.calls[:4] == ["reset", "observe", ("know_product", first), "decide"]
    assert cell.calls[-1] == ("know_product", None)
    assert summary["actions"] == 3


def test_the_known_product_is_forgotten_when_the_episode_ends_otherwise():
    first = view(MODE_OCCLUDED_REGION, target_there=False)
    summary, cell = run_knowing([first], [EpisodeAborted("node_lost: the driver")])
    assert summary["termination_reason"] == "node_lost: the driver"
    assert cell.calls[-1] == ("know_product", None)


def test_a_first_view_with_a_target_is_not_a_known_product_nor_is_any_later_view():
    _, cell = run_knowing([view(), view(MODE_OCCLUDED_REGION), NONE, NONE, NONE], [grasp(), push()])
    assert not [c for c in cell.calls if isinstance(c, tuple)]


def test_the_known_product_can_be_switched_off():
    limits = EpisodeLimits(none_frames_to_finish=3, known_product=False)
    first = view(MODE_OCCLUDED_REGION, target_there=False)
    _, cell = run_knowing([first, NONE, NONE, NONE], [push()], limits)
    assert not [c for c in cell.calls if isinstance(c, tuple)]
