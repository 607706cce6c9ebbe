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


def row(height, termination, truth_picked=1, group="tuning", palette="coal_slate", seed=60_000, picked=None):
    return {"height": height, "scenario": "invisible", "num_targets": 1,
            "num_objects": 10, "palette": palette, "group": group, "seed": seed, "termination": termination,
            "actions": 20, "picked": truth_picked if picked is None else picked, "truth_picked": truth_picked,
            "truth_total": 1, "verdicts_checked": 1, "verdicts_agreeing": 1}


def test_a_clean_end_is_attentions_none_with_nothing_left_behind():
    f = calibrate.figures([row(0.03, NONE), row(0.03, LIMIT), row(0.03, NONE, truth_picked=0),
                           row(0.03, "repeated_failure", picked=0)])
    assert f["episodes"] == 4
    assert f["clean_end"] == 0.25 and f["ended_by_none"] == 0.5 and f["left_behind"] == 1
    assert f["completion"] == 0.75 and f["count_match"] == 0.75


def test_the_choice_is_the_most_clean_ends_ties_to_the_lowest_height():
    rows = [row(0.03, LIMIT), row(0.03, NONE),  # one clean end
            row(0.04, NONE), row(0.04, NONE),  # two
            row(0.045, NONE), row(0.045, NONE),  # two as well, but higher
            row(0.05, NONE, truth_picked=0), row(0.05, NONE, truth_picked=0)]  # ends early, leaves impurities
    assert calibrate.choose(rows) == 0.04
    rows.append(row(0.04, LIMIT))  # 0.04 falls to 2 clean ends of 3
    assert calibrate.choose(rows) == 0.045


def test_heights_are_compared_on_the_scenes_every_height_ran():
    rows = [row(0.03, NONE, seed=1), row(0.04, NONE, seed=1),
            row(0.03, LIMIT, seed=2)]  # only 0.03 ran seed 2: it does not count against it
    assert calibrate.choose(rows) == 0.03
    assert calibrate.choose(rows + [row(0.04, NONE, seed=2)]) == 0.04


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
    assert "min_cluster_height 0.030 m" in out
    assert "== palettes: held_out" in out  # reported beside, never chosen on


def test_tuning_jobs_use_tuning_seeds_and_palettes_and_the_same_scenes_for_every_height():
    jobs = calibrate.jobs_of("tuning", (0.03, 0.04), seeds=3, random_palettes=2)
    assert len(jobs) == 2 * 3 * len(calibrate.SCENES)
    assert all(seed in splits.TUNING_SEED_RANGE for *_, seed in jobs)
    assert {splits.palette_group(palette) for *_, palette, _ in jobs} <= {"default", "tuning"}
    by_height = {h: [job[1:] for job in jobs if job[0] == h] for h in (0.03, 0.04)}
    assert by_height[0.03] and by_height[0.03] == by_height[0.04]
    evaluation = calibrate.jobs_of("evaluation", (0.04,), seeds=3, random_palettes=2)
    assert all(seed >= splits.EVAL_SEED_BASE for *_, seed in evaluation)
