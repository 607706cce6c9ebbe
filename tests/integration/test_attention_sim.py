"""Attention on 15 scenes rendered by the PyBullet cell (~20 s), judged against the simulator's ground
truth (impurity_attention.core.evaluation): visible impurities found, no TARGET in a clean scene, hidden
ones inside the chosen heap."""

import pytest

from impurity_attention.core.attention import attend
from impurity_attention.core.evaluation import judge, record_from_world, summarize

pytestmark = pytest.mark.acceptance
world_module = pytest.importorskip("ur5_driver_sim.core.world")

SCENES = ([("random", seed, 2) for seed in (1000, 1001, 1002)]
          + [("challenging", seed, 2) for seed in (1100, 1101, 1102)]
          + [("random", 1200, 0), ("challenging", 1300, 0), ("random", 1201, 0), ("invisible", 1400, 0)]
          + [("invisible", seed, 2) for seed in (1500, 1501, 1502, 1503, 1504)])


@pytest.fixture(scope="module")
def verdicts():
    world = world_module.CellWorld(mode="floating")
    try:
        results = []
        for scenario, seed, targets in SCENES:
            record = record_from_world(world, scenario, seed, targets, 20)
            results.append(judge(record, attend(record.color, record.height)))
        return results
    finally:
        world.close()


def test_visible_targets_are_found(verdicts):
    visible = summarize(verdicts)["visible"]
    assert visible["scenes"] >= 5
    assert visible["successes"] >= visible["scenes"] - 1, [v for v in verdicts if v.category == "visible"]


def test_scenes_without_impurity_raise_no_target(verdicts):
    assert summarize(verdicts)["no_impurity"]["modes"]["TARGET"] == 0


def test_hidden_targets_lie_in_the_chosen_cluster(verdicts):
    invisible = summarize(verdicts)["invisible"]
    assert invisible["scenes"] == 5 and invisible["successes"] >= 4, [
        v for v in verdicts if v.category == "invisible"]
