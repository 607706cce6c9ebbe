"""scripts/check_rules.py: the rules presets are re-checked on tuning seeds and tuning palettes only,
every rule of `cell` left out in turn, and the table reads each variant against `cell`."""

import importlib.util
import pathlib

from impurity_learning import splits
from impurity_policy.core.rules import RULE_ORDER

SCRIPTS = pathlib.Path(__file__).resolve().parents[3] / "scripts"
spec = importlib.util.spec_from_file_location("check_rules", SCRIPTS / "check_rules.py")
check = importlib.util.module_from_spec(spec)
spec.loader.exec_module(check)


def test_the_episodes_are_tuning_episodes_and_every_rule_is_left_out_once():
    tasks = check.tasks(2, "policy.pt")
    assert {t[0] for t in tasks} == {"none", "cell", *(f"cell - {rule}" for rule in RULE_ORDER)}
    assert all(t[5] in splits.TUNING_SEED_RANGE for t in tasks)
    assert all(splits.palette_group(t[4]) in ("default", "tuning") for t in tasks)
    assert len(tasks) == (2 + len(RULE_ORDER)) * len(check.SCENARIOS) * 2
    left_out = {t[0]: t[2] for t in tasks}
    assert left_out["cell"] == () and left_out["cell - finger_clearance"] == ("finger_clearance",)


def test_the_table_gives_each_variant_against_cell():
    def record(variant, grasp, efficiency, completed):
        return {"variant": variant, "scenario": "random", "grasp_success": grasp,
                "action_efficiency": efficiency, "completed": completed}

    text = check.table([record("cell", 1.0, 0.5, True), record("cell", 0.5, 0.3, True),
                        record("none", 0.5, 0.2, False)])
    rows = {line.split(" | ")[0].strip("| "): line for line in text.splitlines()[2:]}
    assert "75.0 / 40.0 / 100 (+0.0 / +0.0 / +0)" in rows["cell"]
    assert "50.0 / 20.0 / 0 (-25.0 / -20.0 / -100)" in rows["none"]
