"""Fast-sim episodes counted as a real cell counts (evaluate.run_episode(by_perception=True)):
no target count reaches the loop, attention's NONE ends the episode, every grasp is judged by perception,
and the simulator's truth is only recorded beside the verdicts. `python -m impurity_learning.calibrate
verdict` chooses the verdict's thresholds from such episodes."""

import json

import numpy as np
import pytest

from impurity_learning.agents import make_agent
from impurity_learning.evaluate import PerceptionSimCell, run_episode
from impurity_policy.core.checkpoint import SHIPPED_CHECKPOINT
from impurity_policy.core.episode import TERMINATION_NOTHING_LEFT, EpisodeRecorder, EpisodeRequest
from impurity_policy.core.picking import EpisodeLimits
from impurity_policy.core.verdict import GripperReport, judge_grasp
from ur5_driver_sim.core.world import CellWorld

REQUEST = EpisodeRequest("challenging", seed=50_001, num_targets=1, num_objects=5, max_actions=15)


@pytest.fixture(scope="module")
def world():
    world = CellWorld(mode="floating")
    yield world
    world.close()


def test_a_perception_counted_cell_gives_no_target_count_and_no_truth_with_its_outcomes(world):
    cell = PerceptionSimCell(world, make_agent("ours", SHIPPED_CHECKPOINT, "cell"))
    assert cell.reset(REQUEST) is None  # the loop must count by perception
    view = cell.observe()
    assert view.height is not None and view.height.shape == view.color.shape[:2]
    if view.target_mask is not None:  # a TARGET view carries the attended cells and their contrast
        assert view.target_mask.shape == view.height.shape and view.target_mask.any()
        assert view.target_score > 0
    action = cell.decide(view)
    outcome = cell.execute(action)
    assert outcome.target_grasped is False  # the simulator's truth stays out of the outcome
    truth = cell.truth()
    assert truth.targets_remaining + truth.targets_outside + truth.targets_removed == 1


def test_an_episode_counted_by_perception_records_the_truth_beside_each_verdict(world, tmp_path):
    agent = make_agent("ours", SHIPPED_CHECKPOINT, "cell")
    summary = run_episode(world, agent, REQUEST, recorder=EpisodeRecorder(tmp_path, "e"), by_perception=True)
    assert summary["counted_by"] == "perception" and summary["targets_total"] == -1
    assert summary["truth_targets_total"] == 1
    steps = [json.loads(line) for line in (tmp_path / "e" / "steps.jsonl").read_text().splitlines()]
    grasps = [s for s in steps if s.get("kind") == "grasp"]
    assert summary["verdicts_checked"] == len(grasps) >= 1
    assert all(s["verdict"] and s["truth_target_grasped"] is not None for s in grasps)
    agreeing = sum(s["target_grasped"] == s["truth_target_grasped"] for s in grasps)
    assert summary["verdicts_agreeing"] == agreeing
    assert summary["targets_picked"] == sum(s["target_grasped"] for s in grasps)


def test_a_view_handed_over_as_the_known_product_is_attended_with_until_the_next_reset(world):
    cell = PerceptionSimCell(world, make_agent("ours", SHIPPED_CHECKPOINT, "cell"))
    request = EpisodeRequest("invisible", seed=50_002)
    cell.reset(request)
    assert cell.known_product is None
    view = cell.observe()
    cell.know_product(view)
    product = cell.known_product
    assert product is not None and len(product.colors) > 100  # the heap's object cells
    cell.execute(cell.decide(view))
    assert cell.known_product is product
    cell.reset(request)
    assert cell.known_product is None


def test_rendered_views_at_another_exposure_judge_an_untouched_impurity_stays_and_a_lifted_one_gone(world):
    """The grasp verdict on the simulator's frames, the view after the grasp 0.6 to 0.8 times as bright as
    the one before (auto exposure hunting, mains flicker)."""
    def exposed(color, factor):
        return np.clip(np.rint(color * factor), 0, 255).astype(np.uint8)

    cell = PerceptionSimCell(world, make_agent("ours", SHIPPED_CHECKPOINT, "cell"))
    cell.reset(EpisodeRequest("random", seed=51_000, num_targets=1, num_objects=5, palette="blocks"))
    before = cell.observe()
    assert before.target_mask is not None
    holds = GripperReport(holding=True, opening=0.03)
    for factor in (0.6, 0.7, 0.8):  # nothing moved: the target is where it was
        untouched = judge_grasp(before.height, before.color, before.target_mask, before.height,
                                exposed(before.color, factor), holds)
        assert not untouched.impurity_picked and untouched.gone_fraction == 0.0, factor
    action = cell.decide(before)
    assert action.kind == "grasp"
    outcome = cell.execute(action)
    after = cell.observe()
    assert cell.truth().targets_removed == 1  # the simulator says the impurity was lifted
    for factor in (1.0, 0.6, 0.7, 0.8):
        lifted = judge_grasp(before.height, before.color, before.target_mask, after.height,
                             exposed(after.color, factor),
                             GripperReport(outcome.holding, outcome.gripper_opening))
        assert lifted.impurity_picked, (factor, lifted.reason)


@pytest.mark.parametrize("scenario,seed", [("random", 70_020), ("challenging", 70_021)])
def test_a_clean_scene_counted_by_perception_ends_nothing_left_well_within_the_action_limit(world, scenario,
                                                                                           seed):
    # no impurity anywhere: the end of the search takes the bin as clean after a few pushes at its heaps
    # (EpisodeLimits.search_pushes, low_heap_pushes) instead of pushing product to the 30-action limit
    limits = EpisodeLimits()
    summary = run_episode(world, make_agent("ours", SHIPPED_CHECKPOINT, "cell"),
                          EpisodeRequest(scenario, seed=seed, num_targets=0), limits, by_perception=True)
    assert summary["termination_reason"] == TERMINATION_NOTHING_LEFT
    assert summary["actions"] <= limits.search_pushes + 2  # a last look or two beside the search
    assert summary["truth_product_lifted"] == 0
