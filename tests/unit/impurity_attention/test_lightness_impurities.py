"""Impurities that differ from the product mainly in lightness (a darker or lighter piece of the product's
hue: stones among grain, ash among ore) are found, and clean scenes of such a product stay quiet.

Rendered scenes of tuning lightness palettes (ur5_driver_sim.core.appearance.lightness_palette) on tuning
scene seeds, judged against the simulator's truth as the evaluation judges them (evaluation.judge): a
visible impurity is found when attention's TARGET mask lies on it; a scene without one is quiet when
attention gives no TARGET. Each of these scenes was judged wrongly by the verifier before its lightness
terms (verifier.LIGHTNESS_SIZE_FEATURES, relative_i, oriented_lightness) were fitted on lightness palettes.
"""

import pytest

from impurity_attention.core import evaluation
from impurity_attention.core.attention import AttentionMode, attend
from impurity_learning import splits
from ur5_driver_sim.core.world import CellWorld

NUM_OBJECTS = 20  # as the calibration's scenes (impurity_learning.calibrate.scenes.NUM_OBJECTS)


@pytest.fixture(scope="module")
def world():
    world = CellWorld(mode="floating")
    yield world
    world.close()


def rendered(world, palette: str, seed: int, targets: int) -> evaluation.SceneRecord:
    assert splits.palette_group(palette) == "tuning" and splits.scene_seed_split(seed) == "tuning"
    return evaluation.record_from_world(world, "random", seed, targets, NUM_OBJECTS, palette=palette)


@pytest.mark.parametrize("palette, seed", [("lightness-109", 40009), ("lightness-111", 40011),
                                           ("lightness-130", 40030)])
def test_an_impurity_differing_from_the_product_only_in_lightness_is_found(world, palette, seed):
    record = rendered(world, palette, seed, -1)
    output = attend(record.color, record.height)
    verdict = evaluation.judge(record, output)
    assert verdict.category == "visible"
    assert output.mode == AttentionMode.TARGET and verdict.success, output.reason


@pytest.mark.parametrize("palette, seed", [("lightness-101", 40001), ("lightness-118", 40018)])
def test_a_clean_scene_of_a_lightness_palette_gives_no_target(world, palette, seed):
    record = rendered(world, palette, seed, 0)
    output = attend(record.color, record.height)
    assert evaluation.judge(record, output).category == "no_impurity"
    assert output.mode != AttentionMode.TARGET, output.reason
