"""The calibration tool (python -m impurity_learning.calibrate): it fits on the tuning split only, chooses
each threshold by its stated rule, and writes what the cell reads. Small synthetic data; the simulator
runs in tests/integration/test_calibrate_product_sim.py."""

import gzip
import json

import numpy as np
import pytest

from impurity_learning import splits
from impurity_learning.calibrate import CalibrationRefused, attention_fit, episodes, scenes
from impurity_learning.calibrate.__main__ import main

NONE, LIMIT = "no_target_or_cluster_left", "action_limit"


# ------------------------------------------------------------------------------------------ the split
@pytest.mark.parametrize("palette", ["durum_wheat_stones", "random-1005000", "mushrooms_stones",
                                     "random-10000", "marble"])
def test_a_palette_outside_the_tuning_split_is_refused(palette):
    with pytest.raises(CalibrationRefused, match=f"palette '{palette}'"):
        scenes.plan_scenes(["blocks", palette])


@pytest.mark.parametrize("seed_base", [splits.EVAL_SEED_BASE, splits.TUNING_SEED_RANGE.stop - 10])
def test_scene_seeds_outside_the_tuning_seeds_are_refused(seed_base):
    with pytest.raises(CalibrationRefused, match="a calibration fits on tuning seeds 0..99999 only"):
        scenes.plan_scenes(["blocks"], seed_base=seed_base)


def test_each_palette_gets_the_plans_scenes_on_layouts_of_its_own():
    planned = scenes.plan_scenes(["blocks", "coal_slate"], scale=2)
    assert len(planned) == 2 * 2 * 19
    seeds = [seed for *_, seed, _ in planned]
    assert len(set(seeds)) == len(seeds) and all(seed in splits.TUNING_SEED_RANGE for seed in seeds)
    assert [p for p, *_ in planned[:38]] == ["blocks"] * 38  # palette by palette (--limit: whole palettes)
    assert {(scenario, targets) for _, scenario, _, targets in planned[:38]} == \
        {(scenario, targets) for scenario, targets, _ in scenes.PLAN}


def test_the_default_palettes_are_the_default_and_tuning_palettes():
    assert {splits.palette_group(p) for p in scenes.default_palettes()} == {"default", "tuning"}


def test_episode_files_with_a_held_out_palette_or_evaluation_seed_are_refused():
    with pytest.raises(CalibrationRefused, match="held_out"):
        episodes.check_episodes([{"palette": "durum_wheat_stones", "seed": 50_000}])
    with pytest.raises(CalibrationRefused, match="evaluation"):
        episodes.check_episodes([{"palette": "blocks", "seed": splits.EVAL_SEED_BASE + 3}])
    episodes.check_episodes([{"palette": "coal_slate@x2", "seed": 50_000}])


def test_episode_jobs_stay_in_the_tuning_split():
    jobs = episodes.verdict_jobs(splits.tuning_palettes(2), seeds=3)
    assert all(seed in splits.TUNING_SEED_RANGE for *_, seed in jobs)
    jobs = episodes.episode_end_jobs((0.03, 0.04), splits.tuning_palettes(1), seeds=2)
    assert len(jobs) == 2 * len(episodes.END_SCENES) * 2
    assert {splits.palette_group(palette) for _, _, palette, _ in jobs} <= {"default", "tuning"}


def test_episode_end_jobs_of_scene_sets_run_their_scenes_on_tuning_seeds():
    from ur5_driver_sim.core.scenes import SCENE_SETS, UPRIGHT_LAYOUTS

    jobs = episodes.scene_set_end_jobs((0.03, 0.04), splits.tuning_palettes(1), 3, ["sparse", "clean@50-50"])
    assert len(jobs) == 2 * 2 * len(UPRIGHT_LAYOUTS) * 3
    assert {splits.scene_seed_split(seed) for *_, seed in jobs} == {"tuning"}
    for _, (scenario, targets, objects, max_actions, scene_set), _, seed in jobs:
        assert scenario in UPRIGHT_LAYOUTS and max_actions == 0
        chosen = SCENE_SETS[scene_set.split("@")[0]]
        assert (targets, objects) == chosen.draw(seed)[:2]
    assert {job[1][4] for job in jobs} == {"sparse", "clean@50-50"}


def test_an_episode_of_a_scene_set_is_a_scene_of_its_own_when_heights_are_compared():
    paper = {"height": 0.03, "scenario": "random", "num_targets": 1, "num_objects": 5, "palette": "blocks",
             "seed": 70_000}
    assert episodes.key_of(paper) != episodes.key_of({**paper, "scene_set": "sparse"})


# ------------------------------------------------------------------- the verifier and its thresholds
def test_the_threshold_lets_at_most_the_capped_share_of_clean_scenes_through():
    best = np.array([0.9, 0.8, 0.5, 0.4, 0.3, 0.2, 0.1, 0.05, 0.02, 0.01, 0.0, 0.7])
    visible = np.array([True, True] + [False] * 10)
    assert attention_fit.threshold_at(best, visible, 0.0) == np.nextafter(0.7, 1.0)
    assert attention_fit.threshold_at(best, visible, 0.1) == np.nextafter(0.5, 1.0)  # one of ten through
    assert attention_fit.threshold_at(best, visible, 1.0) == 0.0


def synthetic_rows(rng, scenes_count=60):
    """verifier_rows-shaped rows: 3 regions a scene, half the scenes with an impurity whose region reads
    high on the first two features; 6 palettes."""
    from impurity_attention.core.verifier import ALL_FEATURES
    rows, on, scene, group = [], [], [], []
    visible = np.arange(scenes_count) % 2 == 0
    for s in range(scenes_count):
        for k in range(3):
            hit = bool(visible[s] and k == 0)
            row = rng.normal(size=len(ALL_FEATURES))
            row[:2] += 3.0 if hit else 0.0
            rows.append(row)
            on.append(hit)
            scene.append(s)
            group.append(f"palette-{s % 6}")
    return np.array(rows), np.array(on), np.array(scene), np.array(group), visible


def test_the_verifier_separates_impurity_regions():
    from impurity_attention.core.verifier import FEATURES
    rows = synthetic_rows(np.random.default_rng(0))
    verifier, figures = attention_fit.fit_verifier(*rows, feature_names=FEATURES, provenance="test")
    assert figures["fitted"]["found"] > 0.9 and figures["fitted"]["false_target"] <= 0.01
    assert "out_of_fold" in figures  # six palettes: palette-grouped cross-validation


def test_the_fitted_verifier_carries_its_three_thresholds_chosen_on_its_own_probabilities():
    from impurity_attention.core.verifier import FEATURES
    verifier, figures = attention_fit.fit_verifier(*synthetic_rows(np.random.default_rng(0)),
                                                   feature_names=FEATURES)
    chosen = figures["thresholds"]
    assert (verifier.threshold, verifier.last_look, verifier.stall_look) == \
        (chosen["threshold"]["value"], chosen["last_look"]["value"], chosen["stall_look"]["value"])
    assert verifier.threshold >= verifier.last_look >= verifier.stall_look


def test_the_fitted_verifier_round_trips_through_the_shipped_format(tmp_path):
    from impurity_attention.core.verifier import FEATURES, read_verifier, write_verifier
    rows = synthetic_rows(np.random.default_rng(0))
    verifier, _ = attention_fit.fit_verifier(*rows, feature_names=FEATURES, provenance="test")
    path = tmp_path / "verifier.json"
    write_verifier(verifier, path)
    written = json.loads(path.read_text())
    assert written["features"] == list(FEATURES) and len(written["coef"]) == len(FEATURES)
    assert {"intercept", "threshold", "last_look", "stall_look", "mean", "scale", "low", "high"} \
        <= set(written)
    assert read_verifier(path) == verifier


def test_a_refit_learns_an_added_feature_and_holds_the_other_weights():
    """A model fitted where the last feature said nothing misses impurities that only it tells; refitting
    that feature alone finds them and leaves every other weight as it was."""
    from impurity_attention.core.verifier import ALL_FEATURES, FEATURES
    rng = np.random.default_rng(3)
    features, on, scene, group, visible = synthetic_rows(rng)
    model, _ = attention_fit.fit_verifier(features, on, scene, group, visible, feature_names=FEATURES[:-2])
    told = ALL_FEATURES.index("network_high")
    half = visible & (np.arange(len(visible)) % 4 == 0)  # half the impurities tell only by network_high
    for s in np.flatnonzero(half):
        features[(scene == s) & on, :2] -= 2.0
        features[(scene == s) & on, told] += 6.0
    before, _ = attention_fit.extend_verifier(model, features, on, scene, group, visible, added=("rank",))
    after, figures = attention_fit.extend_verifier(model, features, on, scene, group, visible,
                                                   added=("network_high",), provenance="refit")
    assert after.features == model.features + ("network_high",) and after.provenance == "refit"
    assert after.coef[:-1] == model.coef and after.coef[-1] > 1.0
    assert figures["fitted"]["found"] > figures["before"]["found"] + 0.1
    with pytest.raises(ValueError, match="ALL_FEATURES"):
        attention_fit.extend_verifier(model, features, on, scene, group, visible, added=("shoe_size",))
    assert before.features == model.features


def test_the_verifier_refuses_rows_of_one_class():
    from impurity_attention.core.verifier import FEATURES
    features, on, scene, group, visible = synthetic_rows(np.random.default_rng(1))
    with pytest.raises(ValueError, match="regions on an impurity and regions off one"):
        attention_fit.fit_verifier(features, np.zeros_like(on), scene, group, visible, FEATURES)


def test_the_looks_thresholds_let_more_clean_scenes_through_than_the_decisions():
    rng = np.random.default_rng(2)
    best = np.concatenate([rng.uniform(0.5, 1.0, 100), rng.uniform(0.0, 0.6, 400)])
    visible = np.arange(500) < 100
    chosen = attention_fit.choose_thresholds(best, visible)
    order = ("threshold", "last_look", "stall_look")
    assert set(chosen) == set(order)
    values = [chosen[field]["value"] for field in order]
    assert values == sorted(values, reverse=True)
    for entry in chosen.values():
        assert entry["clean_scenes"] == 400 and entry["clean_through"] <= entry["cap"] * 400


def test_an_empty_calibration_directory_leaves_attention_as_shipped(tmp_path):
    assert attention_fit.attention_params(tmp_path) == attention_fit.AttentionParams()


def test_the_shipped_verifier_read_from_a_calibration_directory_keeps_its_thresholds(tmp_path):
    from impurity_attention.core.checkpoints import shipped_path
    from impurity_attention.core.verifier import default_verifier

    shipped = shipped_path("verifier.json")
    (tmp_path / "verifier.json").write_text(shipped.read_text())
    verifier = attention_fit.attention_params(tmp_path).verifier
    assert verifier == default_verifier()
    assert (verifier.threshold, verifier.last_look, verifier.stall_look) == \
        tuple(json.loads(shipped.read_text())[name] for name in ("threshold", "last_look", "stall_look"))


# ------------------------------------------------------------------------------------------- verdict
BLUE = [[40, 120, 200]] * 40 + [[30, 90, 150]] * 40  # a product's first view: lit and shaded blue


def grasp(rgb, truth, gone=1.0, holding=True):
    return {"target": True, "region_rgb": rgb, "truth": truth, "gone_fraction": gone, "holding": holding}


def verdict_episode(grasps, palette="blocks", seed=50_000):
    return {"scenario": "random", "num_objects": 5, "palette": palette, "seed": seed, "termination": NONE,
            "truth_total": 1, "grasps": grasps, "reference_rgb": BLUE}


@pytest.fixture
def verdict_file(tmp_path):
    rows = [verdict_episode([grasp([200, 30, 30], True), grasp([36, 108, 180], False)]),
            verdict_episode([grasp([220, 200, 40], True), grasp([38, 112, 190], False),
                             {"step": 3, "target": False, "truth": False}], palette="coal_slate")]
    path = tmp_path / "episodes.jsonl.gz"
    path.write_bytes(gzip.compress("\n".join(json.dumps(r) for r in rows).encode()))
    return path


def test_a_lifted_product_agrees_with_the_truth_only_through_the_colour_test(verdict_file):
    rows = episodes.with_contrast(episodes.read_episodes([verdict_file]), 8.0)
    assert episodes.agreement(rows, 0.0)["false"] == 2  # every product lifted counts as an impurity
    judged = episodes.agreement(rows, 1.25)
    assert judged["agreement"] == 1.0 and judged["count_match"] == 1.0
    assert not episodes.verdict_of(grasp([200, 30, 30], True, holding=False) | {"color_contrast": 9.0}, 0)


def test_the_verdict_subcommand_chooses_from_recorded_episodes_and_writes_its_choice(verdict_file, tmp_path):
    out = tmp_path / "calibration"
    assert main(["verdict", "--out", str(out), "--episodes", str(verdict_file), "--no-progress"]) == 0
    chosen = json.loads((out / "verdict.json").read_text())
    assert chosen["agreement"] == 1.0 and chosen["min_color_contrast"] > 0 and chosen["episodes"] == 2
    assert {"min_color_spread", "color_shading"} <= set(chosen)
    assert "min_target_score" not in chosen  # the verdict has no score threshold


def test_the_verdict_subcommand_refuses_held_out_episodes(tmp_path, capsys):
    path = tmp_path / "held_out.jsonl"
    path.write_text(json.dumps(verdict_episode([grasp([200, 30, 30], True)], palette="pla_flakes_pet")))
    assert main(["verdict", "--out", str(tmp_path / "c"), "--episodes", str(path)]) == 2
    assert "'pla_flakes_pet' is in the held_out split" in capsys.readouterr().err
    assert not (tmp_path / "c" / "verdict.json").exists()


# --------------------------------------------------------------------------------------- episode end
def end_row(height, termination, truth_picked=1, seed=60_000):
    return {"height": height, "scenario": "invisible", "num_targets": 1, "num_objects": 10,
            "palette": "coal_slate", "seed": seed, "termination": termination, "actions": 20,
            "picked": truth_picked, "truth_picked": truth_picked, "truth_total": 1}


def test_a_clean_end_is_attentions_none_with_nothing_left_behind():
    f = episodes.end_figures([end_row(0.03, NONE), end_row(0.03, LIMIT), end_row(0.03, NONE, truth_picked=0)])
    assert f["episodes"] == 3 and f["clean_end"] == pytest.approx(1 / 3) and f["left_behind"] == 1


def test_the_height_with_the_most_clean_ends_is_chosen_ties_to_the_lowest():
    rows = [end_row(0.03, LIMIT), end_row(0.03, NONE, seed=60_001),
            end_row(0.04, NONE), end_row(0.04, NONE, seed=60_001),
            end_row(0.045, NONE), end_row(0.045, NONE, seed=60_001),
            end_row(0.05, NONE, truth_picked=0), end_row(0.05, NONE, truth_picked=0, seed=60_001)]
    assert episodes.choose_height(rows)[0] == 0.04


def test_heights_are_compared_on_the_scenes_every_height_ran():
    rows = [end_row(0.03, NONE, seed=1), end_row(0.04, NONE, seed=1),
            end_row(0.03, LIMIT, seed=2)]  # only 0.03 ran seed 2: it does not count against it
    assert episodes.choose_height(rows)[0] == 0.03
    assert episodes.choose_height(rows + [end_row(0.04, NONE, seed=2)])[0] == 0.04


def test_the_episode_end_subcommand_writes_the_chosen_height(tmp_path):
    path = tmp_path / "ends.jsonl"
    path.write_text("\n".join(json.dumps(r) for r in [end_row(0.03, LIMIT), end_row(0.04, NONE)]))
    assert main(["episode-end", "--out", str(tmp_path), "--episodes", str(path)]) == 0
    assert json.loads((tmp_path / "episode_end.json").read_text())["min_cluster_height"] == 0.04


# ------------------------------------------------------------------------------------------- --help
@pytest.mark.parametrize("command, writes", [
    ("network", "OUT/impurity_net.pt"), ("verifier", "OUT/verifier.json"),
    ("verdict", "OUT/verdict.json"), ("episode-end", "OUT/episode_end.json"),
    ("search-pushes", "OUT/search_pushes.json"),
    ("colour-reference", "OUT/colour_reference.json")])
def test_each_subcommands_help_says_what_it_fits_on_which_data_and_what_it_writes(command, writes, capsys):
    with pytest.raises(SystemExit):
        main([command, "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "Fits on the tuning split only" in text
    assert "Refuses held-out palettes and evaluation seeds" in text
    assert "Writes OUT/" in text and writes in text


# ---------------------------------------------------------------------------------- colour reference
def test_the_colour_reference_is_the_lab_statistics_of_the_seen_cells(tmp_path, capsys):
    from impurity_attention.core import evaluation
    from impurity_attention.core.colour_adaptation import lab_statistics

    color = np.zeros((8, 8, 3), np.uint8)
    color[:, :4], color[:, 4:6] = (200, 40, 40), (40, 160, 60)  # columns 6, 7: unseen, black
    labels = np.full((8, 8), -1, np.int32)
    labels[:, :6] = 3
    record = evaluation.SceneRecord("random", 20_000, 0, 5, color, np.zeros((8, 8), np.float32), labels, (),
                                    (), "coal_slate")
    views = tmp_path / "views.npz"
    evaluation.save_records(views, [record])
    assert main(["colour-reference", "--out", str(tmp_path / "c"), "--views", str(views)]) == 0
    written = json.loads((tmp_path / "c" / "colour_reference.json").read_text())
    expected = lab_statistics([color[:, :6]])
    assert written["colour_reference_mean"] == [round(v, 2) for v in expected.mean]
    assert written["colour_reference_std"] == [round(v, 2) for v in expected.std]
    printed = capsys.readouterr().out
    assert f"colour_reference_mean: {written['colour_reference_mean']}" in printed
    assert "colour_adaptation: true" in printed


def test_the_colour_reference_refuses_held_out_views(tmp_path):
    from impurity_attention.core import evaluation

    record = evaluation.SceneRecord("random", 20_000, 0, 5, np.zeros((4, 4, 3), np.uint8),
                                    np.zeros((4, 4), np.float32), np.zeros((4, 4), np.int32), (), (),
                                    "pla_flakes_pet")
    evaluation.save_records(tmp_path / "views.npz", [record])
    assert main(["colour-reference", "--out", str(tmp_path), "--views", str(tmp_path / "views.npz")]) == 2
    assert not (tmp_path / "colour_reference.json").exists()
