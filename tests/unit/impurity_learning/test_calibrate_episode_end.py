"""scripts/calibrate_episode_end.py: the height below which a cluster cannot hide anything is chosen on
tuning episodes only, by how episodes counted by perception end: attention's NONE with no impurity left."""

import gzip
import importlib.util
import json
import pathlib

import pytest

from impurity_learning import splits

SCRIPTS = pathlib.Path(__file__).resolve().parents[3] / "scripts"

spec = importlib.util.spec_from_file_location("calibrate_episode_end", SCRIPTS / "calibrate_episode_end.py")
calibrate = importlib.util.module_from_spec(spec)
spec.loader.exec_module(calibrate)

NONE, LIMIT = "no_target_or_cluster_left", "action_limit"
OLD = calibrate.LEGACY_RULE  # rows without a recorded rule ran with it


def row(height, termination, truth_picked=1, group="tuning", palette="coal_slate", seed=60_000, picked=None,
        floor=0.0, distinct=0.0):
    return {"height": height, "colour_floor": floor, "distinct_color_contrast": distinct,
            "scenario": "invisible", "num_targets": 1,
            "num_objects": 10, "palette": palette, "group": group, "seed": seed, "termination": termination,
            "actions": 20, "picked": truth_picked if picked is None else picked, "truth_picked": truth_picked,
            "truth_total": 1, "verdicts_checked": 1, "verdicts_agreeing": 1}


def test_a_clean_end_is_attentions_none_with_nothing_left_behind():
    f = calibrate.figures([row(0.03, NONE), row(0.03, LIMIT), row(0.03, NONE, truth_picked=0),
                           row(0.03, "repeated_failure", picked=0)])
    assert f["episodes"] == 4
    assert f["clean_end"] == 0.25 and f["ended_by_none"] == 0.5 and f["left_behind"] == 1
    assert f["completion"] == 0.75 and f["count_match"] == 0.75


def test_the_choice_is_the_most_clean_ends_ties_to_the_lowest_colour_floor_then_height():
    rows = [row(0.03, LIMIT), row(0.03, NONE),  # one clean end
            row(0.04, NONE), row(0.04, NONE),  # two
            row(0.045, NONE), row(0.045, NONE),  # two as well, but higher
            row(0.05, NONE, truth_picked=0), row(0.05, NONE, truth_picked=0)]  # ends early, leaves impurities
    assert calibrate.choose(rows) == (0.04, 0.0, 0.0, *OLD)
    rows += [row(0.045, NONE, floor=2.0), row(0.045, NONE, floor=2.0),  # as clean as 0.04 without a floor
             row(0.03, NONE, floor=1.5), row(0.03, LIMIT, floor=1.5)]
    assert calibrate.choose(rows) == (0.04, 0.0, 0.0, *OLD)
    rows.append(row(0.04, LIMIT))  # 0.04 without a floor falls to 2 clean ends of 3
    assert calibrate.choose(rows) == (0.045, 0.0, 0.0, *OLD)
    rows.append(row(0.045, "repeated_failure"))  # and so does 0.045: the floor's clean ends win
    assert calibrate.choose(rows) == (0.045, 2.0, 0.0, *OLD)


def test_settings_are_compared_on_the_scenes_every_setting_ran():
    rows = [row(0.03, NONE, seed=1), row(0.04, NONE, seed=1),
            row(0.03, LIMIT, seed=2)]  # only 0.03 ran seed 2: it does not count against it
    assert calibrate.choose(rows) == (0.03, 0.0, 0.0, *OLD)
    assert calibrate.choose(rows + [row(0.04, NONE, seed=2)]) == (0.04, 0.0, 0.0, *OLD)


def test_files_from_before_the_colour_floor_and_the_distinct_colour_path_read_as_without_them():
    old = row(0.04, NONE)
    del old["colour_floor"], old["distinct_color_contrast"]
    assert calibrate.setting_of(old) == (0.04, 0.0, 0.0, *OLD)


def test_a_recorded_rule_is_part_of_the_setting_and_defaults_to_the_shipped_one():
    new = dict(row(0.04, NONE, floor=1.0, distinct=2.5), color_shading=0.15, min_relative_contrast=5.0,
               min_relative_contrast_distinct=2.3)
    # no saturation, no last look and no decision recorded: they read as 0 (off) and "rule", what those
    # rows ran with
    assert calibrate.setting_of(new) == (0.04, 1.0, 2.5, 0.15, 5.0, 2.3, 0.0, 0.0, 0.0, "rule", 0.0)
    assert calibrate.setting_of(dict(new, color_saturation=250.0))[6] == 250.0
    looked = dict(new, last_look_contrast=3.0, last_look_color_contrast=2.5)
    assert calibrate.setting_of(looked)[7:9] == (3.0, 2.5)
    assert calibrate.setting_of(dict(new, decision="verifier"))[9] == "verifier"
    assert calibrate.setting_of(dict(new, verifier_last_look=0.35))[10] == 0.35
    assert calibrate.choose([new, row(0.04, LIMIT, floor=1.0, distinct=2.5)]) == calibrate.setting_of(new)
    jobs = calibrate.jobs_of("tuning", (0.04,), seeds=1, random_palettes=1)
    assert {job[0][3:] for job in jobs} == {calibrate.default_rule()}
    jobs = calibrate.jobs_of("tuning", (0.04,), seeds=1, random_palettes=1,
                             rule=(0.3, 4.0, 2.0, 250.0, 3.0, 2.5, "verifier", 0.35))
    assert {job[0] for job in jobs} == {(0.04, 0.0, 0.0, 0.3, 4.0, 2.0, 250.0, 3.0, 2.5, "verifier", 0.35)}


def test_a_tie_in_clean_ends_goes_to_the_distinct_colour_path_on():
    rows = [row(0.04, NONE, floor=2.0), row(0.04, NONE, floor=2.0, distinct=4.0)]
    assert calibrate.choose(rows) == (0.04, 2.0, 4.0, *OLD)
    rows += [row(0.04, LIMIT, floor=2.0, distinct=4.0, seed=60_001), row(0.04, NONE, floor=2.0, seed=60_001)]
    assert calibrate.choose(rows) == (0.04, 2.0, 0.0, *OLD)


@pytest.fixture
def files(tmp_path):
    tuning = [row(0.03, NONE), row(0.04, LIMIT), row(0.04, NONE, group="default", palette="blocks")]
    # measured only: a held-out palette and an evaluation seed, where 0.04 would look better
    evaluation = splits.EVAL_SEED_BASE + 600_000
    measured = [row(0.04, NONE, group="held_out", palette="lentils_stones", seed=evaluation),
                row(0.04, NONE, group="default", palette="blocks", seed=evaluation + 1),
                row(0.04, NONE, group="default", palette="blocks", seed=evaluation + 2)]
    path = tmp_path / "episodes.jsonl.gz"
    path.write_bytes(gzip.compress("\n".join(json.dumps(r) for r in tuning + measured).encode()))
    return path


def test_the_report_chooses_on_tuning_rows_only(files, capsys):
    assert calibrate.main(["report", str(files)]) == 0
    out = capsys.readouterr().out
    assert "min_cluster_height 0.030 m, min_color_contrast 0.00" in out
    assert "== palettes: held_out" in out  # reported beside, never chosen on


def test_tuning_jobs_use_tuning_seeds_and_palettes_and_the_same_scenes_for_every_height():
    jobs = calibrate.jobs_of("tuning", (0.03, 0.04), seeds=3, random_palettes=2, floors=(0.0, 2.0), rule=OLD)
    assert len(jobs) == 2 * 2 * 3 * len(calibrate.SCENES)
    assert all(seed in splits.TUNING_SEED_RANGE for *_, seed in jobs)
    assert {splits.palette_group(palette) for *_, palette, _ in jobs} <= {"default", "tuning"}
    settings = ((0.03, 0.0, 0.0, *OLD), (0.04, 2.0, 0.0, *OLD))
    by_setting = {s: [job[1:] for job in jobs if job[0] == s] for s in settings}
    assert by_setting[settings[0]] and by_setting[settings[0]] == by_setting[settings[1]]
    evaluation = calibrate.jobs_of("evaluation", (0.04,), seeds=3, random_palettes=2)
    assert all(seed >= splits.EVAL_SEED_BASE for *_, seed in evaluation)
