"""Scene sets beyond the paper's blocks (scenes.SCENE_SETS): pieces taller and flatter than ours, a handful
of pieces, dense scenes and scenes with no impurity generate what they claim: their counts per seed, piece
heights in range standing upright, no impurity in clean scenes."""

import dataclasses
import math

import numpy as np
import pytest

from impurity_common import cell
from ur5_driver_sim.core import appearance, scenes
from ur5_driver_sim.core.scenes import SCENE_SETS, scene_set_named
from ur5_driver_sim.core.world import CellWorld

SEEDS = range(70_000, 70_060)


def vertical_extent(spec) -> float:
    """Height of a box of the spec's dims under its orientation (the bounding box's z extent)."""
    x, y, z, w = spec.orientation
    row = (2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y))  # third row of the rotation
    return sum(abs(r) * d for r, d in zip(row, spec.dims, strict=True))


def colours():
    return appearance.palette_named("").colours(0)


@pytest.mark.parametrize("name", [n for n in SCENE_SETS if n != "paper"])
def test_each_set_draws_its_counts_from_the_seed(name):
    chosen = SCENE_SETS[name]
    draws = [chosen.draw(seed) for seed in SEEDS]
    assert draws == [chosen.draw(seed) for seed in SEEDS]  # the same seed, the same scene
    for draw in draws:
        assert chosen.targets[0] <= draw.num_targets <= chosen.targets[1]
        assert chosen.pieces[0] <= draw.num_targets + draw.num_objects <= chosen.pieces[1]
        assert draw.num_targets + draw.num_objects <= scenes.MAX_BLOCKS
        assert draw.heights == chosen.heights


def test_the_sets_cover_taller_flatter_sparse_dense_and_clean_scenes():
    assert SCENE_SETS["tall"].heights[0] >= 0.040 and SCENE_SETS["flat"].heights[1] <= 0.025
    assert SCENE_SETS["mixed"].heights == (0.015, 0.060)
    assert SCENE_SETS["sparse"].pieces == (5, 10) and SCENE_SETS["dense"].pieces[0] >= 40
    assert SCENE_SETS["clean"].targets == (0, 0)
    sparse = {sum(SCENE_SETS["sparse"].draw(seed)[:2]) for seed in SEEDS}
    assert sparse == set(range(5, 11))  # every size of the range is drawn


def test_the_paper_set_leaves_counts_and_sizes_to_the_scenario():
    assert SCENE_SETS["paper"].draw(3) == (-1, -1, None)


@pytest.mark.parametrize("layout", [scenes.random_layout, scenes.challenging_layout])
@pytest.mark.parametrize("heights", [(0.015, 0.025), (0.040, 0.060), (0.050, 0.050)])
def test_pieces_of_a_set_stand_upright_with_heights_in_range(layout, heights):
    for seed in range(5):
        specs = layout(np.random.default_rng(seed), 2, 20, colours(), heights)
        assert len(specs) == 22 and sum(s.is_target for s in specs) == 2
        for spec in specs:
            assert spec.shape != "half_cylinder"
            assert heights[0] - 1e-9 <= spec.dims[2] <= heights[1] + 1e-9
            assert vertical_extent(spec) == pytest.approx(spec.dims[2])


def test_without_heights_the_layouts_keep_our_blocks_tumbled():
    specs = scenes.random_layout(np.random.default_rng(1), 2, 20, colours())
    assert any(not math.isclose(vertical_extent(s), s.dims[2], abs_tol=1e-4) for s in specs)


def test_a_set_with_piece_heights_is_named_by_them_in_mm():
    chosen = scene_set_named("sparse@50-50")
    assert chosen.heights == (0.05, 0.05) and chosen.name == "sparse@50-50"
    assert chosen.pieces == SCENE_SETS["sparse"].pieces
    assert chosen.meaning.endswith("pieces 50-50 mm tall here")
    assert SCENE_SETS["tall"].with_heights((0.015, 0.06)).name == "tall@15-60"


@pytest.mark.parametrize("name, message", [("huge", "unknown scene set 'huge'"),
                                           ("tall@x-5", "piece heights are <lowest>-<highest> in mm"),
                                           ("tall@60-15", "lowest <= highest"),
                                           ("tall@15-200", "<= 100 mm")])
def test_an_unknown_set_or_impossible_heights_are_refused_by_name(name, message):
    with pytest.raises(ValueError, match=message):
        scene_set_named(name)


@pytest.fixture(scope="module")
def world():
    w = CellWorld(mode="floating")
    yield w
    w.close()


def settled(world) -> list:
    """Each piece's (z of its own axis, z extent of its spec as it now lies, top above the table)."""
    out = []
    for body, spec in world.specs.items():
        position, orientation = world.pb.getBasePositionAndOrientation(body)
        x, y, _, _ = orientation
        spec_now = dataclasses.replace(spec, orientation=orientation)
        extent = vertical_extent(spec_now)
        out.append((1 - 2 * (x * x + y * y), extent, position[2] + extent / 2 - cell.TABLE_Z))
    return out


@pytest.mark.parametrize("name", ["tall", "flat"])
def test_a_packed_scene_of_a_set_settles_upright_with_its_piece_heights(world, name):
    chosen = SCENE_SETS[name]
    draw = chosen.draw(70_000)
    info = world.reset_scene("challenging", seed=70_000, num_targets=draw.num_targets,
                             num_objects=draw.num_objects, piece_heights=draw.heights)
    assert (info.num_targets, info.num_objects) == (draw.num_targets, draw.num_objects)
    assert info.piece_heights == chosen.heights
    low, high = chosen.heights
    for up, extent, top in settled(world):
        assert up > 0.99  # standing
        assert low - 1e-6 <= extent <= high + 1e-6
        assert low - 0.003 <= top <= high + 0.003  # on the table, not on another piece


@pytest.mark.parametrize("scenario", ["random", "challenging"])
def test_a_clean_scene_has_no_impurity(world, scenario):
    draw = SCENE_SETS["clean"].draw(70_001)
    info = world.reset_scene(scenario, seed=70_001, num_targets=draw.num_targets,
                             num_objects=draw.num_objects, piece_heights=draw.heights)
    truth = world.ground_truth()
    assert info.num_targets == truth.targets_remaining == 0
    assert truth.objects_remaining == draw.num_objects >= 5


def test_dense_and_sparse_scenes_keep_every_piece_in_the_workspace(world):
    for name in ("dense", "sparse"):
        draw = SCENE_SETS[name].draw(70_002)
        info = world.reset_scene("random", seed=70_002, num_targets=draw.num_targets,
                                 num_objects=draw.num_objects, piece_heights=draw.heights)
        assert info.num_targets + info.num_objects == sum(draw[:2])
        assert info.targets_outside_workspace == info.objects_outside_workspace == 0


def test_piece_heights_are_refused_for_the_heaps_of_invisible(world):
    with pytest.raises(ValueError, match="random and challenging"):
        world.reset_scene("invisible", seed=1, piece_heights=(0.02, 0.05))
