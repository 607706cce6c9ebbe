"""The split (splits.py, palettes.yaml's split field): what may be tuned on and what is only measured never
overlap, every palette is in exactly one split, and evaluation reads its fixed seeds and palettes."""

import pytest

from impurity_learning import generalisation, splits
from ur5_driver_sim.core.appearance import DEFAULT_PALETTE, PALETTE_SPLITS, PALETTES, SPLITS


def seeds_of(ranges, split):
    return [block.seeds for block in ranges if block.split == split]


def overlaps(a: range, b: range) -> bool:
    return max(a.start, b.start) < min(a.stop, b.stop)


def test_every_named_palette_is_in_exactly_one_split():
    assert set(PALETTE_SPLITS) == set(PALETTES)
    assert all(PALETTE_SPLITS[name] in SPLITS for name in PALETTES)


def test_the_default_palette_alone_is_the_default_split():
    assert [name for name, split in PALETTE_SPLITS.items() if split == "default"] == [DEFAULT_PALETTE]
    assert splits.palette_group("") == splits.palette_group(DEFAULT_PALETTE) == "default"


def test_tuning_and_held_out_named_palettes_come_from_the_palettes_file_and_are_disjoint():
    assert splits.TUNING_NAMED and splits.HELD_OUT_NAMED
    assert not set(splits.TUNING_NAMED) & set(splits.HELD_OUT_NAMED)
    assert {PALETTE_SPLITS[name] for name in splits.TUNING_NAMED} == {"tuning"}
    assert {PALETTE_SPLITS[name] for name in splits.HELD_OUT_NAMED} == {"held_out"}


def test_random_palette_seed_ranges_never_overlap():
    ranges = [block.seeds for block in splits.RANDOM_PALETTE_SEEDS]
    assert not any(overlaps(a, b) for i, a in enumerate(ranges) for b in ranges[i + 1:])


def test_every_random_palette_range_belongs_to_a_known_split_and_says_what_it_is_for():
    for block in splits.RANDOM_PALETTE_SEEDS:
        assert block.split in (*SPLITS, "training") and block.meaning
        assert splits.palette_group(f"random-{block.seeds[0]}") == block.split
        assert splits.palette_group(f"random-{block.seeds[-1]}") == block.split


def test_tuning_and_evaluation_scene_seeds_never_overlap():
    tuning, evaluation = seeds_of(splits.SCENE_SEEDS, "tuning"), seeds_of(splits.SCENE_SEEDS, "evaluation")
    assert tuning and evaluation
    assert not any(overlaps(a, b) for a in tuning for b in evaluation)
    assert splits.scene_seed_split(0) == "tuning"
    assert splits.scene_seed_split(splits.EVAL_SEED_BASE) == "evaluation"
    assert splits.scene_seed_split(splits.TUNING_SEED_RANGE.stop) is None


def test_evaluation_episodes_start_at_the_evaluation_seed_base():
    from impurity_learning import eval_cli, evaluate
    assert splits.EVAL_SEED_BASE == evaluate.EVAL_SEED_BASE == 900_000_000
    assert eval_cli.parse_args([]).seed_base == splits.EVAL_SEED_BASE


def test_the_held_out_group_is_held_out_and_the_tuning_group_is_tuning():
    assert {splits.palette_group(p) for p in splits.held_out_palettes()} == {"held_out"}
    assert {splits.palette_group(p) for p in splits.tuning_palettes(96)} == {"default", "tuning"}
    assert {splits.palette_group(p) for p in generalisation.group_palettes("held_out")} == {"held_out"}
    assert {splits.palette_group(p) for p in generalisation.group_palettes("tuning")} == {"tuning"}


def test_the_evaluations_palette_groups_are_fixed():
    held_out = splits.held_out_palettes()
    assert len(held_out) == len(splits.HELD_OUT_NAMED) + splits.HELD_OUT_RANDOM_COUNT == 200
    assert held_out[:4] == ["durum_wheat_stones", "green_lentils_stones", "brazil_nuts_shells",
                            "pla_flakes_pet"]
    assert held_out[4] == "random-1005000" and held_out[-1] == "random-1005195"
    assert generalisation.group_palettes("tuning") == [
        "coal_slate", "beans_stones", "plastic_flakes", "rice_husks", "random-0", "random-1", "random-2",
        "random-3"]
    assert generalisation.group_palettes("default") == [DEFAULT_PALETTE]


def test_training_draws_no_held_out_palette():
    assert not any(overlaps(splits.TRAINING_RANDOM_SEEDS, r) for r in seeds_of(splits.RANDOM_PALETTE_SEEDS,
                                                                               "held_out"))


def test_a_suffix_does_not_change_a_palettes_split():
    assert splits.palette_group(f"{splits.HELD_OUT_NAMED[1]}@x2") == "held_out"
    assert splits.palette_group("random-5@j0.05@x0.5") == "tuning"


@pytest.mark.parametrize("name", ["random-10000000", "marble", "random-x"])
def test_a_palette_in_no_split_is_refused(name):
    with pytest.raises(ValueError, match="belongs to no split"):
        splits.palette_group(name)


def test_tuning_random_palettes_refuse_a_range_leaving_the_tuning_split():
    assert splits.tuning_random_palettes(998, 2) == ["random-998", "random-999"]
    with pytest.raises(ValueError, match="random-999 ... 1000: not all tuning palettes"):
        splits.tuning_random_palettes(999, 2)


def test_held_out_perception_scenes_are_evaluation_seeds_of_their_own():
    palettes = len(splits.held_out_palettes())
    seeds = [splits.held_out_layout_seed(row, k, 6) + i for row in range(7) for k in range(palettes)
             for i in range(6)]
    assert len(set(seeds)) == len(seeds)
    assert min(seeds) == splits.HELD_OUT_LAYOUT_SEED_BASE == 918_000_000
    assert {splits.scene_seed_split(seed) for seed in seeds} == {"evaluation"}


def test_scene_set_tuning_and_evaluation_seeds_are_disjoint_and_each_in_its_split():
    tuning = splits.scene_set_seeds("tuning", len(splits.SCENE_SET_TUNING_SEEDS))
    evaluation = splits.scene_set_seeds("evaluation", 10_000)
    assert not set(tuning) & set(evaluation)
    assert {splits.scene_seed_split(seed) for seed in tuning} == {"tuning"}
    assert {splits.scene_seed_split(seed) for seed in evaluation} == {"evaluation"}
    assert evaluation[0] == splits.EVAL_SEED_BASE


def test_scene_set_tuning_seeds_are_apart_from_the_calibrate_tools_episode_seeds():
    from impurity_learning.calibrate import episodes

    calibrate = {*range(episodes.VERDICT_SEED_BASE, episodes.VERDICT_SEED_BASE + 10_000),
                 *range(episodes.EPISODE_END_SEED_BASE, episodes.EPISODE_END_SEED_BASE + 100 * 100)}
    assert not calibrate & set(splits.SCENE_SET_TUNING_SEEDS)


def test_scene_set_seeds_beyond_their_split_are_refused_naming_its_size():
    size = len(splits.SCENE_SET_TUNING_SEEDS)
    assert splits.scene_set_seeds("tuning", 2, start=size - 2)[-1] == splits.SCENE_SET_TUNING_SEEDS[-1]
    with pytest.raises(ValueError, match=f"the split holds {size} seeds"):
        splits.scene_set_seeds("tuning", 3, start=size - 2)
    with pytest.raises(ValueError, match="unknown split 'held_out'"):
        splits.scene_set_seeds("held_out", 1)


def test_eval_cli_runs_a_scene_set_on_the_split_asked_and_writes_it_apart():
    from impurity_learning import eval_cli
    tuned = eval_cli.parse_args(["--scene-set", "sparse", "--split", "tuning"])
    assert tuned.seed_base == splits.SCENE_SET_TUNING_SEEDS[0]
    assert tuned.scenarios == ["random", "challenging"]  # the layouts that take piece heights
    assert tuned.markdown == f"{eval_cli.SCENE_SET_OUTPUTS}/sparse-tuning/results.md"
    measured = eval_cli.parse_args(["--scene-set", "tall"])
    assert measured.seed_base == splits.EVAL_SEED_BASE and measured.markdown != eval_cli.MARKDOWN
    heights = eval_cli.parse_args(["--scene-set", "sparse", "--piece-heights", "50", "50"])
    assert heights.scene_set == "sparse@50-50" and "sparse_50-50-evaluation" in heights.markdown
    paper = eval_cli.parse_args([])
    assert (paper.scene_set, paper.markdown, paper.scenarios) == ("", eval_cli.MARKDOWN,
                                                                  list(eval_cli.SCENARIOS))


def test_lightness_palette_seed_ranges_never_overlap_and_each_has_a_split():
    ranges = [block.seeds for block in splits.LIGHTNESS_PALETTE_SEEDS]
    assert not any(overlaps(a, b) for i, a in enumerate(ranges) for b in ranges[i + 1:])
    for block in splits.LIGHTNESS_PALETTE_SEEDS:
        assert block.split in SPLITS and block.meaning
        assert splits.palette_group(f"lightness-{block.seeds[0]}") == block.split
        assert splits.palette_group(f"lightness-{block.seeds[-1]}@x1.5") == block.split
    with pytest.raises(ValueError, match="no split"):
        splits.palette_group(f"lightness-{max(block.seeds.stop for block in splits.LIGHTNESS_PALETTE_SEEDS)}")


def test_the_lightness_group_is_held_out_and_its_tuning_palettes_are_among_the_calibrations():
    group = generalisation.group_palettes("lightness")
    assert len(group) == splits.HELD_OUT_LIGHTNESS_COUNT
    assert all(p.startswith("lightness-") for p in group)
    assert {splits.palette_group(p) for p in group} == {"held_out"}
    tuned = [p for p in splits.tuning_palettes() if p.startswith("lightness-")]
    assert len(tuned) == splits.TUNING_LIGHTNESS_COUNT
    assert {splits.palette_group(p) for p in tuned} == {"tuning"}
    assert not set(tuned) & set(group)


def test_eval_cli_takes_the_lightness_group_but_runs_it_only_when_asked():
    from impurity_learning import eval_cli
    assert "lightness" not in eval_cli.parse_args([]).palette_groups
    assert eval_cli.parse_args(["--palette-groups", "lightness"]).palette_groups == ["lightness"]
