"""make eval counted by perception (perception_figures.py, eval_cli --count, --clean-scenes): episodes
counted as a real cell counts, reported by the simulator's truth recorded beside, with a 95 % t interval
beside each mean and how the episodes ended."""

import json
import math

import pytest

from impurity_learning import perception_figures
from impurity_learning.eval_cli import main
from impurity_learning.perception_figures import (
    by_scenario,
    clean_figures,
    mean_interval,
    perception_section,
    product_lifted,
)
from impurity_policy.core.episode import StepRecord


def record(picked, total, actions, reason="no_target_or_cluster_left", lifted=0, scenario="random",
           clean=False, grasps=None) -> dict:
    """A perception-counted episode's record, as eval_cli.run_task writes it (the figures' fields only);
    grasps: grasp attempts (default: one per impurity picked)."""
    return {"scenario": scenario, "clean_scene": clean, "counted_by": "perception",
            "truth_targets_picked": picked, "truth_targets_total": total, "truth_product_lifted": lifted,
            "actions": actions, "termination_reason": reason, "grasp_attempts": picked if grasps is None
            else grasps}


def test_the_interval_is_students_t_over_episodes():
    figure = mean_interval([1.0, 2.0, 3.0, 4.0])
    # mean 2.5, sample sd 1.29, t(0.975, 3) = 3.182: half width 3.182 * 1.29 / 2 = 2.054
    assert figure["mean"] == pytest.approx(2.5)
    assert (figure["low"], figure["high"]) == pytest.approx((0.446, 4.554), abs=1e-3)


def test_one_episode_has_a_mean_but_no_interval_and_none_has_neither():
    one = mean_interval([3.0])
    assert one["mean"] == 3.0 and math.isnan(one["low"]) and math.isnan(one["high"])
    assert all(math.isnan(v) for v in mean_interval([]).values())


def test_equal_episodes_give_an_interval_of_no_width():
    assert mean_interval([2.0, 2.0, 2.0]) == {"mean": 2.0, "low": 2.0, "high": 2.0}


def test_figures_count_picked_left_product_and_efficiency_by_truth():
    episodes = [record(2, 2, 4), record(1, 2, 10, lifted=2),
                record(0, 2, 30, reason="action_limit", lifted=1)]
    figures = perception_figures.perception_figures(episodes)
    assert figures["episodes"] == 3
    assert figures["picked"]["mean"] == pytest.approx(1.0)
    assert figures["left"]["mean"] == pytest.approx(1.0)  # 0, 1 and 2 impurities left behind
    assert figures["product_lifted"]["mean"] == pytest.approx(1.0)
    assert figures["actions"]["mean"] == pytest.approx(44 / 3)
    assert figures["efficiency"]["mean"] == pytest.approx((50.0 + 10.0 + 0.0) / 3)
    assert (figures["picked_total"], figures["targets_total"]) == (3, 6)
    assert figures["picked"]["low"] < 1.0 < figures["picked"]["high"]


def test_grasp_success_is_counted_by_truth_per_episode_as_the_truth_count_counts_it():
    # 2 of 2 grasps removed an impurity, 1 of 4, and no grasp at all (0, as episode.EpisodeTracker counts it)
    episodes = [record(2, 2, 4), record(1, 2, 10, grasps=4), record(0, 2, 6, grasps=0)]
    figures = perception_figures.perception_figures(episodes)
    assert figures["grasp_success"]["mean"] == pytest.approx((100.0 + 25.0 + 0.0) / 3)


def test_endings_split_the_cells_own_nothing_left_from_the_action_limit_and_the_rest():
    episodes = [record(2, 2, 4), record(2, 2, 5), record(0, 2, 30, reason="action_limit"),
                record(0, 2, 5, reason="repeated_failure")]
    assert perception_figures.perception_figures(episodes)["ended"] == {
        "nothing_left": 2, "action_limit": 1, "other": 1}


def test_an_episode_without_actions_has_no_efficiency_but_counts():
    figures = perception_figures.perception_figures([record(0, 2, 0)])
    assert figures["efficiency"]["mean"] == 0.0 and figures["actions"]["mean"] == 0.0


def test_clean_scenes_give_actions_and_product_lifted():
    figures = clean_figures([record(0, 0, 3, lifted=1, clean=True), record(0, 0, 0, clean=True)])
    assert figures["episodes"] == 2
    assert figures["actions"]["mean"] == pytest.approx(1.5)
    assert figures["product_lifted"]["mean"] == pytest.approx(0.5)
    assert figures["ended"]["nothing_left"] == 2


def test_a_rows_episodes_are_split_by_scenario_and_clean_scene():
    episodes = [record(1, 2, 4), record(2, 2, 3, scenario="invisible"), record(0, 0, 2, clean=True)]
    split = by_scenario(episodes, ["random", "invisible"])
    assert [split["scenarios"][s]["episodes"] for s in ("random", "invisible")] == [1, 1]
    assert [split["clean_scenes"][s]["episodes"] for s in ("random", "invisible")] == [1, 0]
    assert split["episodes"] == episodes


def test_product_lifted_counts_grasps_that_lifted_something_but_no_target():
    def step(kind, success, truth):
        return StepRecord(1, "TARGET", kind, (0, 0, 0), 0.0, 0.0, 0, (0, 0), 0, 0, success, False, success,
                          -1, truth_target_grasped=truth)

    steps = [step("grasp", True, False), step("grasp", True, True), step("grasp", False, False),
             step("push", True, None), step("grasp", True, None)]
    assert product_lifted(steps) == 1


def test_the_section_names_the_interval_and_lists_each_row_and_scenario():
    results = {"ours@cell": {"by_perception": by_scenario([record(1, 2, 4), record(2, 2, 6),
                                                           record(0, 0, 1, clean=True)], ["random"])},
               "vpg@cell": {"missing": True}}
    section = perception_section(results, ["ours@cell", "vpg@cell"], ["random"], lambda row: row)
    assert section.startswith("## Counted by perception")
    assert "95 % t interval" in section
    assert "| ours@cell | random | 2 | 1.50 [" in section
    assert "| 100.0 [100.0, 100.0] | 2 / 0 / 0 |" in section  # grasp success by truth, then the endings
    assert "Clean scenes" in section and "| ours@cell | random | 1 | 1.0 [–, –] |" in section
    assert "vpg@cell" not in section


def test_eval_cli_counts_the_same_episodes_by_truth_and_by_perception(tmp_path):
    out = tmp_path / "docs"
    assert main(["--count", "both", "--episodes", "1", "--scenarios", "random", "--methods", "ours",
                 "--rules", "cell", "--clean-scenes", "1", "--palette-groups", "default",
                 "--perception-scenes", "1",
                 "--markdown", str(out / "results.md"), "--no-progress", "--jobs", "1"]) == 0
    records = json.loads((out / "results.json").read_text())
    (truth,) = records["ours@cell"]["episodes"]
    by_perception = records["ours@cell"]["by_perception"]["episodes"]
    (counted,), (clean,) = ([e for e in by_perception if e["clean_scene"] == c] for c in (False, True))
    assert truth["counted_by"] == "truth" and counted["counted_by"] == "perception"
    assert (truth["seed"], truth["scenario"]) == (counted["seed"], counted["scenario"])
    assert (truth["seed"], truth["scenario"]) == (900_000_000, "random")
    assert counted["clean_scene"] is False and counted["truth_targets_total"] == truth["targets_total"]
    figures = records["ours@cell"]["by_perception"]["scenarios"]["random"]
    assert figures["episodes"] == 1 and sum(figures["ended"].values()) == 1
    assert records["ours@cell"]["scenarios"]["random"]["episodes"] == 1  # the truth table: its own episode
    assert clean["counted_by"] == "perception" and clean["seed"] == 900_000_000
    assert clean["truth_targets_total"] == clean["truth_targets_picked"] == 0
    assert records["ours@cell"]["by_perception"]["clean_scenes"]["random"]["episodes"] == 1
    markdown = (out / "results.md").read_text()
    assert "## Counted by perception" in markdown and "| Ours [rules: cell] | random | 1 |" in markdown
    assert "Clean scenes" in markdown


def test_other_palette_groups_are_counted_by_perception_on_their_own_rows(tmp_path):
    out = tmp_path / "docs"
    assert main(["--count", "both", "--episodes", "1", "--scenarios", "random", "--methods", "ours",
                 "--rules", "cell", "--clean-scenes", "1", "--palette-groups", "default", "held_out",
                 "--group-episodes", "1", "--perception-scenes", "1",
                 "--markdown", str(out / "results.md"), "--no-progress", "--jobs", "1"]) == 0
    records = json.loads((out / "results.json").read_text())["ours@cell"]
    assert [e["group"] for e in records["by_perception"]["episodes"]] == ["default", "default"]
    held_out = records["by_perception_groups"]["held_out"]
    assert {e["group"] for e in held_out["episodes"]} == {"held_out"}
    (counted,), (clean,) = ([e for e in held_out["episodes"] if e["clean_scene"] == c] for c in (False, True))
    assert counted["palette"] == clean["palette"] != ""
    assert held_out["scenarios"]["random"]["episodes"] == held_out["clean_scenes"]["random"]["episodes"] == 1
    assert records["groups"]["held_out"]["random"]["episodes"] == 1  # its truth count: one episode
    markdown = (out / "results.md").read_text()
    assert "| Ours [rules: cell] · held-out palettes | random | 1 |" in markdown


def test_the_main_tables_episodes_are_counted_by_perception_whichever_palette_groups_are_asked(tmp_path):
    out = tmp_path / "docs"
    assert main(["--count", "perception", "--episodes", "1", "--scenarios", "random", "--methods", "ours",
                 "--rules", "cell", "--palette-groups", "held_out", "--group-episodes", "0",
                 "--perception-scenes", "1", "--markdown", str(out / "results.md"), "--no-progress",
                 "--jobs", "1"]) == 0
    records = json.loads((out / "results.json").read_text())["ours@cell"]
    assert records["by_perception"]["scenarios"]["random"]["episodes"] == 1
    assert "by_perception_groups" not in records
