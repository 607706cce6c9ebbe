"""scripts/calibrate_attention.py palette-evaluate's summary line: counts beside the shares, and whether each
issue-17 aim is met judged on the exact share, so that 1899/2000 (94.95 %) does not read as a met 95.0 %."""

import importlib.util
import pathlib

SCRIPTS = pathlib.Path(__file__).resolve().parents[3] / "scripts"

spec = importlib.util.spec_from_file_location("calibrate_attention", SCRIPTS / "calibrate_attention.py")
calibrate = importlib.util.module_from_spec(spec)
spec.loader.exec_module(calibrate)


def rates(found, visible, false, clean, hidden=0, invisible=0):
    return {"one": {"visible": [True] * found + [False] * (visible - found),
                    "no_impurity": [True] * (clean - false) + [False] * false,
                    "invisible": [True] * hidden + [False] * (invisible - hidden), "separable": []}}


def summary(capsys, *args) -> tuple[str, dict]:
    totals = calibrate.print_palette_rates(rates(*args), per_palette=False)
    return capsys.readouterr().out, totals


def test_one_scene_short_of_95_percent_is_not_met(capsys):
    line, totals = summary(capsys, 1899, 2000, 11, 1200, 540, 600)
    assert "impurity found 1899/2000 = 94.95 % (aim >= 95 %: NOT met)" in line
    assert "false TARGET 11/1200 = 0.92 % (aim <= 5 %: met)" in line
    assert "hidden target in chosen cluster 540/600 = 90.0 %" in line
    assert totals["found"] == 0.9495 and totals["visible_scenes"] == 2000


def test_exactly_95_percent_found_and_5_percent_false_target_meet_the_aims(capsys):
    line, _ = summary(capsys, 1900, 2000, 60, 1200)
    assert "1900/2000 = 95.00 % (aim >= 95 %: met)" in line
    assert "60/1200 = 5.00 % (aim <= 5 %: met)" in line
    line, _ = summary(capsys, 1900, 2000, 61, 1200)
    assert "61/1200 = 5.08 % (aim <= 5 %: NOT met)" in line


def test_no_scenes_is_said_not_judged(capsys):
    line, _ = summary(capsys, 0, 0, 0, 3)
    assert "impurity found 0/0 = nan % (aim >= 95 %: no scenes)" in line
