"""make eval's tables show both counts with 95 % intervals: the paper's truth-counted metrics with their
intervals (eval_cli.aggregate, results_table), and the README block with the same episodes counted by
perception (the headline) beside those counted by truth (eval_cli.readme_table); scene sets run apart
from the paper's table (eval_cli --scene-set, --split)."""

import json

import pytest

from impurity_learning import eval_cli
from impurity_learning.eval_cli import aggregate, main, readme_table, results_table
from impurity_learning.perception_figures import by_scenario
from ur5_driver_sim.core.scenes import SCENE_SETS


def truth_record(picked, attempts, actions, total=2) -> dict:
    """A truth-counted episode's record (the fields aggregate reads)."""
    return {"grasp_success": picked / attempts if attempts else 0.0,
            "action_efficiency": picked / actions if actions else 0.0, "completed": picked == total,
            "false_rejects": 0, "actions": actions, "targets_picked": picked, "targets_total": total}


def perception_record(picked, actions, reason="no_target_or_cluster_left", lifted=0, clean=False,
                      grasps=None) -> dict:
    """grasps: grasp attempts (default: one per impurity picked)."""
    return {"scenario": "random", "clean_scene": clean, "counted_by": "perception",
            "truth_targets_picked": picked, "truth_targets_total": 0 if clean else 2,
            "truth_product_lifted": lifted, "actions": actions, "termination_reason": reason,
            "grasp_attempts": picked if grasps is None else grasps}


def test_truth_counted_metrics_carry_their_95_percent_t_interval():
    figures = aggregate([truth_record(2, 2, 2), truth_record(2, 4, 4), truth_record(1, 2, 6),
                         truth_record(2, 2, 8)])
    # action efficiency per episode 100, 50, 16.7, 25: mean 47.92, sd 37.5, t(0.975, 3) = 3.182 -> +- 59.67
    efficiency = figures["intervals"]["action_efficiency"]
    assert efficiency["mean"] == pytest.approx(figures["action_efficiency"])
    assert efficiency["mean"] == pytest.approx(47.917, abs=1e-3)
    assert (efficiency["high"] - efficiency["low"]) / 2 == pytest.approx(59.67, abs=0.01)
    assert figures["intervals"]["actions"]["mean"] == pytest.approx(5.0)
    assert figures["intervals"]["actions"]["low"] == pytest.approx(5.0 - 4.108, abs=1e-3)
    assert figures["intervals"]["grasp_success"]["mean"] == pytest.approx(figures["grasp_success"])


def results(with_perception: bool) -> dict:
    truth = [truth_record(2, 2, 2), truth_record(2, 4, 4)]
    entry = {"scenarios": {"random": aggregate(truth)}}
    if with_perception:
        entry["by_perception"] = by_scenario(
            [perception_record(2, 10), perception_record(1, 30, reason="action_limit", lifted=2),
             perception_record(0, 4, clean=True), perception_record(0, 8, lifted=1, clean=True)], ["random"])
    return {"ours@cell": entry, "vpg@cell": {"missing": True}}


def test_the_results_table_gives_each_truth_figure_its_interval_then_the_papers():
    table = results_table(results(False), ["ours@cell"], ["random"])
    # efficiency 100 and 50: mean 75, half width 12.706 x 35.36 / 1.414 = 317.7
    assert "| Ours [rules: cell] | 75.0 [-242.7, 392.7] (46.3) |" in table
    assert "**Actions per scene** [95 % interval]" in table and "| 3.0 [-9.7, 15.7] |" in table


def test_the_readme_block_heads_with_the_perception_count_beside_the_truth_count():
    block = readme_table(results(True), ["ours@cell", "vpg@cell"], ["random"])
    titles = [line for line in block.splitlines() if line.startswith("**")]
    assert titles[0] == "**Action efficiency, %: counted by perception / by truth (paper)**"
    # perception: 2 of 2 in 10 actions (20 %), 1 in 30 (3.3 %); truth 100 % and 50 %
    assert "| Ours [rules: cell] | 11.7 ± 105.9 / 75.0 ± 317.7 (46.3) |" in block
    assert "| Ours [rules: cell] | 20.0 ± 127.1 / 3.0 ± 12.7 | 6.0 ± 25.4 / 0.50 ± 6.35 |" in block
    assert "| Ours [rules: cell] | 0.50 ± 6.35 / 1.00 ± 12.71 · 1 of 2 |" in block  # left / lifted · ended
    assert "| VPG [rules: cell] | not trained |" in block


def test_a_readme_block_from_a_run_without_the_perception_count_says_so_with_a_dash():
    block = readme_table(results(False), ["ours@cell"], ["random"])
    assert "| Ours [rules: cell] | – / 75.0 ± 317.7 (46.3) |" in block
    assert "| Ours [rules: cell] | – / 3.0 ± 12.7 | – |" in block


def test_a_scene_set_run_counts_both_ways_on_tuning_seeds_and_leaves_the_readme_alone(tmp_path):
    out = tmp_path / "docs"
    out.mkdir()
    readme = out / "README.md"
    readme.write_text("<!-- results:start -->\nold\n<!-- results:end -->\n")
    assert main(["--scene-set", "tall", "--split", "tuning", "--count", "both", "--episodes", "1",
                 "--scenarios", "challenging", "--methods", "ours", "--rules", "cell",
                 "--palette-groups", "default", "--perception-scenes", "1",
                 "--markdown", str(out / "results.md"), "--no-progress", "--jobs", "1"]) == 0
    records = json.loads((out / "results.json").read_text())
    (truth,) = records["ours@cell"]["episodes"]
    (counted,) = records["ours@cell"]["by_perception"]["episodes"]
    tall = SCENE_SETS["tall"]
    for record in (truth, counted):
        assert (record["seed"], record["scene_set"]) == (70_000, "tall")
        assert record["piece_heights"] == [0.04, 0.06]
        assert record["num_targets"] + record["num_objects"] == tall.pieces[0]
    assert counted["truth_targets_total"] == truth["targets_total"] == tall.targets[0]
    assert records["_meta"]["scene_set"] == "tall" and records["_meta"]["split"] == "tuning"
    assert readme.read_text() == "<!-- results:start -->\nold\n<!-- results:end -->\n"
    markdown = (out / "results.md").read_text()
    assert "scene set `tall`" in markdown and "tuning seeds 70000" in markdown
    assert "## Counted by perception" in markdown


@pytest.mark.parametrize("arguments, message", [
    (["--scene-set", "tall", "--scenarios", "invisible"], "scenarios random, challenging only"),
    (["--scene-set", "huge"], "--scene-set/--piece-heights: unknown scene set 'huge'"),
    (["--split", "tuning", "--seed-base", str(eval_cli.EVAL_SEED_BASE)], "are not all tuning scene seeds"),
])
def test_a_run_that_cannot_hold_its_split_or_scene_set_is_refused_before_any_episode(arguments, message,
                                                                                    capsys):
    assert main([*arguments, "--no-progress", "--jobs", "1"]) == 2
    assert message in capsys.readouterr().err


def test_the_scene_set_table_puts_each_sets_counts_side_by_side_and_reads_clean_sets_from_clean_scenes():
    from impurity_learning import scene_set_table

    def run(scene_set, records, truth):
        return {"_meta": {"rows": ["ours@cell"], "scenarios": ["random"], "scene_set": scene_set,
                          "split": "tuning"},
                "ours@cell": {"scenarios": {"random": aggregate(truth)},
                              "by_perception": by_scenario(records, ["random"])}}

    tall = run("tall", [perception_record(2, 30, reason="action_limit"),
                        perception_record(1, 10, lifted=1, grasps=2)],
               [truth_record(2, 2, 4), truth_record(2, 2, 6)])
    clean = run("clean", [perception_record(0, 12, lifted=1, clean=True),
                          perception_record(0, 4, clean=True)], [truth_record(0, 0, 0, total=0)] * 2)
    table = scene_set_table.markdown(scene_set_table.table_rows(tall) + scene_set_table.table_rows(clean))
    assert ("| tall | tuning | ours@cell | random | 2 | 20.0 [-107.1, 147.1] | 5.0 [-7.7, 17.7] | "
            "75.0 [-242.7, 392.7] | 100.0 [100.0, 100.0] | "
            "1 / 1 / 0 | 0.50 [-5.85, 6.85] | 0.50 [-5.85, 6.85] |") in table
    assert ("| clean | tuning | ours@cell | random | 2 | 8.0 [-42.8, 58.8] | 0.0 [0.0, 0.0] | – | – | "
            "2 / 0 / 0 | (clean) | 0.50 [-5.85, 6.85] |") in table


def test_the_scene_set_table_gives_another_palette_group_rows_of_its_own_beside_its_truth_count():
    from impurity_learning import scene_set_table

    results = {"_meta": {"rows": ["ours@cell"], "scenarios": ["random"], "scene_set": "paper",
                         "split": "evaluation"},
               "ours@cell": {"scenarios": {"random": aggregate([truth_record(2, 2, 4)])},
                             "groups": {"held_out": {"random": aggregate([truth_record(2, 2, 3)])}},
                             "by_perception": by_scenario([perception_record(2, 7)], ["random"]),
                             "by_perception_groups": {
                                 "held_out": by_scenario([perception_record(1, 9, grasps=2)], ["random"])}}}
    table = scene_set_table.markdown(scene_set_table.table_rows(results))
    assert "| paper | evaluation | ours@cell | random | 1 | 7.0 [–, –] | 4.0 [–, –] | 100.0 [–, –] |" in table
    assert ("| paper | evaluation | ours@cell · held_out | random | 1 | 9.0 [–, –] | 3.0 [–, –] | "
            "50.0 [–, –] | 100.0 [–, –] |") in table
