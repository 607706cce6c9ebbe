"""scripts/calibrate_verdict.py: the verdict's thresholds are chosen on tuning episodes only, by the
agreement of the verdict with the simulator's truth, computed with the loop's own ProductReference."""

import gzip
import importlib.util
import json
import pathlib

import pytest

SCRIPTS = pathlib.Path(__file__).resolve().parents[3] / "scripts"

spec = importlib.util.spec_from_file_location("calibrate_verdict", SCRIPTS / "calibrate_verdict.py")
calibrate = importlib.util.module_from_spec(spec)
spec.loader.exec_module(calibrate)

BLUE = [[40, 120, 200]] * 40 + [[30, 90, 150]] * 40  # a product's first view: lit and shaded blue


def grasp(rgb, truth, gone=1.0, holding=True, score=8.0):
    return {"target": True, "region_rgb": rgb, "truth": truth, "gone_fraction": gone, "holding": holding,
            "target_score": score}


def episode(group, grasps, palette="blocks"):
    return {"scenario": "random", "num_objects": 5, "palette": palette, "seed": 1, "group": group,
            "termination": "no_target_or_cluster_left", "truth_total": 1, "grasps": grasps,
            "reference_rgb": BLUE}


@pytest.fixture
def files(tmp_path):
    tuning = [episode("default", [grasp([200, 30, 30], True), grasp([36, 108, 180], False)]),
              episode("tuning", [grasp([220, 200, 40], True), grasp([38, 112, 190], False),
                                 {"step": 3, "target": False, "truth": False}], palette="coal_slate")]
    held_out = [episode("held_out", [grasp([35, 100, 170], False)], palette="lentils_stones")]
    path = tmp_path / "episodes.jsonl.gz"
    path.write_bytes(gzip.compress("\n".join(json.dumps(r) for r in tuning + held_out).encode()))
    return path


def test_a_lifted_product_agrees_only_with_the_colour_test(files):
    rows = calibrate.load([files])
    assert calibrate.agreement(rows, 0.0)["false"] == 3  # every product lifted counts as an impurity
    judged = calibrate.agreement(rows, 1.25)
    assert judged["agreement"] == 1.0 and judged["count_match"] == 1.0
    nothing_held = grasp([200, 30, 30], True, holding=False)
    assert not calibrate.verdict(calibrate.load([files])[0]["grasps"][0] | nothing_held, 0.0)


def test_the_sweep_reads_tuning_episodes_only_and_writes_its_choice(files, tmp_path, capsys):
    out = tmp_path / "chosen.json"
    assert calibrate.main(["sweep", str(files), "--json", str(out)]) == 0
    chosen = json.loads(out.read_text())
    assert chosen["episodes"] == 2  # the held-out episode is only measured
    assert chosen["chosen"]["agreement"] == 1.0 and chosen["chosen"]["min_color_contrast"] > 0
    assert "held-out palettes ignored" in capsys.readouterr().err
