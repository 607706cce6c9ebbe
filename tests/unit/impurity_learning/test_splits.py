"""The split that is kept (splits.py): tuning, held-out and retired palettes never overlap, and a rotated
held-out set is retired, never returned to tuning."""

import pytest

from impurity_learning import splits
from ur5_driver_sim.core.appearance import PALETTES


def test_every_named_palette_of_the_split_exists_in_the_simulator():
    for name in (*splits.TUNING_NAMED, *splits.HELD_OUT_NAMED, *splits.RETIRED_NAMED):
        assert name in PALETTES


def test_groups_do_not_overlap():
    named = [set(splits.TUNING_NAMED), set(splits.HELD_OUT_NAMED), set(splits.RETIRED_NAMED)]
    assert all(not (a & b) for i, a in enumerate(named) for b in named[i + 1:])
    seeds = [set(splits.TUNING_RANDOM_SEEDS), set(splits.HELD_OUT_RANDOM_SEEDS),
             *(set(s) for _, s in splits.RETIRED_SETS), set(splits.TRAINING_RANDOM_SEEDS)]
    assert all(not (a & b) for i, a in enumerate(seeds) for b in seeds[i + 1:])


def test_the_held_out_set_is_held_out_and_every_earlier_set_is_retired():
    assert {splits.palette_group(p) for p in splits.held_out_palettes()} == {"held_out"}
    assert {splits.palette_group(p) for p in splits.retired_palettes()} == {"retired"}
    assert len(splits.retired_palettes(random_count=2)) == sum(len(n) + 2 for n, _ in splits.RETIRED_SETS)
    assert splits.palette_group(f"{splits.HELD_OUT_NAMED[1]}@x2") == "held_out"  # exposure suffix ignored


def test_a_palette_outside_the_split_is_refused():
    with pytest.raises(ValueError, match="no group"):
        splits.palette_group("random-9000")


def test_held_out_perception_scenes_are_evaluation_seeds_of_their_own_below_the_picking_runs():
    # palette-evaluate's PALETTE_PLAN: 7 rows of at most 6 scenes. Every palette's scenes are its own, never a
    # tuning seed, and below the eighth set's picking run (HELD_OUT_LAYOUT_SEED_BASE + 900 000 + k,
    # docs/experiments.md thirteenth section)
    palettes = len(splits.held_out_palettes())
    seeds = [splits.held_out_layout_seed(row, k, 6) + i for row in range(7) for k in range(palettes)
             for i in range(6)]
    assert len(set(seeds)) == len(seeds)
    assert min(seeds) == splits.HELD_OUT_LAYOUT_SEED_BASE >= splits.EVAL_SEED_BASE
    assert not any(seed in splits.TUNING_SEED_RANGE for seed in seeds)
    assert max(seeds) < splits.HELD_OUT_LAYOUT_SEED_BASE + 900_000
