"""Evaluation harness: baselines' decisions, the paper's metrics, and `make eval`'s outputs."""

import json
import math
import pathlib
from types import SimpleNamespace

import numpy as np
import pytest
import torch

from impurity_common import cell
from impurity_learning import eval_cli, splits
from impurity_learning.agents import NetworkAgent, SalientGraspHeuristic, grasp_rectangle
from impurity_learning.eval_cli import aggregate, main
from impurity_learning.trainer import Trainer
from impurity_policy.core.network import GRASP, PUSH, NetworkConfig, QNetwork
from impurity_policy.core.policy import MODE_OCCLUDED_REGION, MODE_TARGET, Observation, Policy
from impurity_policy.core.rules import RulePipeline

SIZE = cell.HEIGHTMAP_SIZE


def bar_mask(rows: slice, cols: slice) -> np.ndarray:
    mask = np.zeros((SIZE, SIZE), bool)
    mask[rows, cols] = True
    return mask


@pytest.mark.parametrize("rows, cols, closing_yaw", [
    (slice(100, 110), slice(80, 140), math.pi / 2),  # long along columns (base x): close along y
    (slice(80, 140), slice(100, 110), 0.0),  # long along rows (base y): close along x
])
def test_grasp_rectangle_closes_across_the_short_side(rows, cols, closing_yaw):
    (row, col), yaw = grasp_rectangle(bar_mask(rows, cols))
    centre = ((rows.start + rows.stop - 1) / 2, (cols.start + cols.stop - 1) / 2)
    assert (row, col) == pytest.approx(centre, abs=1)
    assert math.cos(2 * (yaw - closing_yaw)) == pytest.approx(1.0, abs=1e-3)  # same axis, either way


def test_grasp_rectangle_of_a_diagonal_bar():
    mask = np.zeros((SIZE, SIZE), bool)
    for k in range(60):
        mask[80 + k: 80 + k + 8, 80 + k: 80 + k + 8] = True  # long along the +row+col diagonal
    _, yaw = grasp_rectangle(mask)
    assert math.cos(2 * (yaw - 3 * math.pi / 4)) == pytest.approx(1.0, abs=0.05)
    assert grasp_rectangle(np.zeros((SIZE, SIZE), bool)) is None


def sensed_scene(mode=MODE_TARGET):
    """A red target bar between two neighbours, as the attention module would report it."""
    height = np.zeros((SIZE, SIZE), np.float32)
    target = bar_mask(slice(100, 112), slice(90, 130))
    height[target] = 0.03
    height[100:112, 136:160] = 0.03  # a neighbour just right of the target (+col, +x)
    cluster = SimpleNamespace(centroid=(106.0, 120.0))
    attention = SimpleNamespace(mode=mode, target_mask=target if mode == MODE_TARGET else None,
                                cluster=cluster)
    color = np.zeros((SIZE, SIZE, 3), np.uint8)
    obs = Observation(mode, color, height, np.full((SIZE, SIZE), 255, np.uint8), (0, 0), height)
    return SimpleNamespace(obs=obs, attention=attention, maps=SimpleNamespace(height=height, color=color))


def test_s_rgm_grasps_the_target_then_pushes_it_away_from_its_neighbour_after_a_failure():
    agent = SalientGraspHeuristic()
    agent.reset(0)
    sensed = sensed_scene()
    grasp = agent.act(sensed)
    assert grasp.kind == "grasp" and grasp.pose.heightmap_pixel == pytest.approx((105.5, 109.5), abs=1)
    assert math.cos(2 * (grasp.pose.yaw - math.pi / 2)) > 0.99  # across the bar's short side
    agent.observe_outcome(grasp, SimpleNamespace(success=False))
    push = agent.act(sensed)
    assert push.kind == "push"
    assert math.cos(push.pose.yaw - math.pi) > 0.9  # away from the neighbour: towards -x
    assert push.pose.heightmap_pixel[1] > 110  # starts on the neighbour's side of the target
    agent.observe_outcome(push, SimpleNamespace(success=True))
    assert agent.act(sensed).kind == "grasp"  # the scene changed: grasp again


def test_s_rgm_pushes_through_the_cluster_without_a_target_and_stops_with_nothing():
    agent = SalientGraspHeuristic()
    agent.reset(0)
    push = agent.act(sensed_scene(MODE_OCCLUDED_REGION))
    assert push.kind == "push" and push.mode == MODE_OCCLUDED_REGION
    end_x = push.pose.x + cell.PUSH_LENGTH * math.cos(push.pose.yaw)
    end_y = push.pose.y + cell.PUSH_LENGTH * math.sin(push.pose.yaw)
    centre_x, centre_y = cell.pixel_to_base(106, 120)
    midpoint = ((push.pose.x + end_x) / 2, (push.pose.y + end_y) / 2)
    assert math.dist(midpoint, (centre_x, centre_y)) < 0.01  # the push runs through the cluster centre
    second = agent.act(sensed_scene(MODE_OCCLUDED_REGION))
    assert second.pose.rotation != push.pose.rotation  # a different direction each time
    nothing = sensed_scene(MODE_OCCLUDED_REGION)
    nothing.attention.mode = 0
    assert agent.act(nothing) is None


def test_s_vpg_acts_inside_the_grown_saliency_mask_and_vpg_may_not():
    torch.manual_seed(3)
    network = QNetwork(NetworkConfig(crop_size=SIZE))
    sensed = sensed_scene()
    s_vpg = NetworkAgent("s_vpg", Policy(network, rules=RulePipeline.preset("cell")))
    vpg = NetworkAgent("vpg", Policy(network, rules=RulePipeline.preset("cell")))
    restricted = s_vpg.restriction(sensed)
    assert restricted[105, 110] and not restricted[105, 150] and vpg.restriction(sensed) is None
    action = s_vpg.act(sensed)
    assert restricted[action.pose.heightmap_pixel]
    assert action.kind in ("push", "grasp") and math.isfinite(action.q_value)


def test_a_network_agent_remembers_its_outcomes_for_the_rules_and_forgets_them_at_reset():
    torch.manual_seed(3)
    agent = NetworkAgent("vpg", Policy(QNetwork(NetworkConfig(crop_size=SIZE)),
                                       rules=RulePipeline.preset("cell")))
    agent.reset(0)
    sensed = sensed_scene()
    policy = agent.policy
    action = agent.act(sensed)

    def ruled_out_at_the_action() -> bool:
        q = np.zeros((16, 2, SIZE, SIZE), np.float32)
        kept = policy.rules.apply(q, sensed.obs, policy.masks(sensed.obs), policy.pose_rules, sensed.obs.grid)
        primitive = GRASP if action.kind == "grasp" else PUSH
        return bool(np.isneginf(kept[action.pose.rotation, primitive][action.pose.heightmap_pixel]))

    assert not ruled_out_at_the_action()
    agent.observe_outcome(action, SimpleNamespace(success=False))  # it changed nothing
    assert ruled_out_at_the_action()  # tried_actions: not again in the same scene
    agent.reset(1)  # the next episode
    assert not ruled_out_at_the_action()


def test_aggregate_averages_per_episode_like_the_paper():
    episodes = [dict(grasp_success=1.0, action_efficiency=0.5, completed=True, false_rejects=0, actions=4,
                     targets_picked=2, targets_total=2),
                dict(grasp_success=0.5, action_efficiency=0.25, completed=False, false_rejects=1, actions=4,
                     targets_picked=1, targets_total=2)]
    summary = aggregate(episodes)
    assert summary["grasp_success"] == pytest.approx(75.0)
    assert summary["action_efficiency"] == pytest.approx(37.5)
    assert summary["completion"] == pytest.approx(50.0)
    assert (summary["false_rejects"], summary["targets_picked"], summary["targets_total"]) == (1, 3, 4)


def generalisation_paths(out) -> list:
    return ["--generalisation", str(out / "generalisation.md"),
            "--generalisation-chart", str(out / "images" / "generalisation.png"),
            "--generalisation-scenes", str(out / "images" / "generalisation_scenes.png")]


def test_eval_cli_writes_table_chart_and_records_with_untrained_methods_listed(tmp_path):
    checkpoints = tmp_path / "checkpoints"
    checkpoints.mkdir()
    Trainer(seed=0).save(checkpoints / "policy.pt")  # "ours"; no vpg.pt
    out = tmp_path / "docs"
    readme = tmp_path / "README.md"
    readme.write_text("intro\n<!-- results:start -->\nold table\n<!-- results:end -->\nrest\n")
    code = main(["--readme", str(readme), "--methods", "ours", "s_rgm", "vpg", "--scenarios", "random",
                 "--episodes", "1",
                 "--checkpoint-dir", str(checkpoints), "--policy-checkpoint", str(checkpoints / "policy.pt"),
                 "--markdown", str(out / "results.md"),
                 "--chart", str(out / "images" / "results.png"), "--json", str(out / "results.json"),
                 "--palette-groups", "default", "--perception-scenes", "1", *generalisation_paths(out),
                 "--threads", "1", "--jobs", "2", "--no-progress"])
    assert code == 0
    records = json.loads((out / "results.json").read_text())
    # rows: a network method under a rules preset (--rules, default cell); the heuristic has no rules
    assert records["_meta"]["rows"] == ["ours@cell", "s_rgm", "vpg@cell"]
    assert records["vpg@cell"]["missing"] and records["_meta"]["seed_base"] == 900_000_000
    for row, method, rules in (("ours@cell", "ours", "cell"), ("s_rgm", "s_rgm", "")):
        (episode,) = records[row]["episodes"]
        assert (episode["row"], episode["method"], episode["rules"]) == (row, method, rules)
        assert episode["seed"] == 900_000_000 and episode["scenario"] == "random"
        assert episode["actions"] == episode["grasp_attempts"] + episode["pushes"] >= 1
        assert records[row]["scenarios"]["random"]["grasp_success"] == pytest.approx(
            100.0 * episode["grasp_success"])
    table = (out / "results.md").read_text()
    assert "| VPG [rules: cell] | not trained |" in table and "| S-RGM (heuristic) |" in table
    assert "--method vpg" in table  # how to train the missing one
    assert (out / "images" / "results.png").stat().st_size > 10_000
    updated = readme.read_text()
    assert "old table" not in updated and "| VPG [rules: cell] | not trained |" in updated
    assert updated.startswith("intro\n") and updated.endswith("rest\n")


def test_eval_cli_adds_the_generalisation_table_for_palette_groups(tmp_path):
    out = tmp_path / "docs"
    assert main(["--methods", "s_rgm", "--scenarios", "random", "--episodes", "1", "--palette-groups",
                 "default", "held_out", "--group-episodes", "1", "--group-palette-offset", "5",
                 "--perception-scenes", "1", "--markdown",
                 str(out / "r.md"), "--chart", str(out / "r.png"), "--json", str(out / "r.json"), "--readme",
                 str(out / "README.md"), *generalisation_paths(out), "--jobs", "1", "--no-progress"]) == 0
    records = json.loads((out / "r.json").read_text())
    # the held-out group ran its own episode, on a held-out palette (the sixth: offset 5), with the evaluation
    # seed
    default, held_out = records["s_rgm"]["episodes"]
    assert (default["group"], default["palette"]) == ("default", "")
    assert held_out["group"] == "held_out" and held_out["palette"] == splits.held_out_palettes()[5]
    assert held_out["seed"] == default["seed"] == 900_000_000
    assert records["s_rgm"]["groups"]["held_out"]["random"]["episodes"] == 1
    assert records["s_rgm"]["scenarios"]["random"]["episodes"] == 1  # the main table: default group only
    perception = records["_generalisation"]["perception"]
    assert set(perception) == {"default", "held_out"}
    assert perception["held_out"]["random"]["clean_scenes"] == 1
    generalisation = (out / "generalisation.md").read_text()
    assert "held-out palettes" in generalisation and "| S-RGM (heuristic) |" in generalisation
    assert splits.HELD_OUT_NAMED[0] in generalisation  # the group's palettes are listed
    assert (out / "images" / "generalisation.png").stat().st_size > 10_000
    assert (out / "images" / "generalisation_scenes.png").stat().st_size > 10_000


def test_eval_episodes_are_the_same_in_one_process_and_in_a_pool(tmp_path):
    def records(jobs: int) -> list:
        out = tmp_path / f"jobs{jobs}"
        assert main(["--methods", "s_rgm", "--scenarios", "random", "challenging", "--episodes", "2",
                     "--jobs", str(jobs), "--markdown", str(out / "r.md"), "--chart", str(out / "r.png"),
                     "--json", str(out / "r.json"), "--readme", str(out / "README.md"), "--no-progress",
                     "--palette-groups", "default", "--perception-scenes", "1",
                     *generalisation_paths(out)]) == 0
        return json.loads((out / "r.json").read_text())["s_rgm"]["episodes"]  # the heuristic's row

    single, pooled = records(1), records(2)
    assert [(e["scenario"], e["seed"]) for e in single] == [("random", 900_000_000), ("random", 900_000_001),
                                                             ("challenging", 900_000_000),
                                                             ("challenging", 900_000_001)]
    assert pooled == single  # seeded scenes and a deterministic heuristic: the same episodes


def test_the_generalisation_outputs_follow_the_markdown_unless_given():
    beside_default = pathlib.Path(eval_cli.MARKDOWN).parent
    default = eval_cli.parse_args([])
    assert default.generalisation == str(beside_default / "generalisation.md")
    assert default.generalisation_chart == str(beside_default / "images" / "generalisation.png")
    elsewhere = eval_cli.parse_args(["--markdown", "runs/check/results.md"])
    assert elsewhere.generalisation == str(pathlib.Path("runs/check/generalisation.md"))
    assert elsewhere.generalisation_scenes == str(pathlib.Path("runs/check/images/generalisation_scenes.png"))
    given = eval_cli.parse_args(["--markdown", "runs/check/results.md", "--generalisation", "x/g.md"])
    assert given.generalisation == "x/g.md"


def test_a_run_sent_elsewhere_leaves_the_readme_and_the_committed_chart_alone():
    # every output at its default: the repository's README block and the chart beside the default table
    beside_default = pathlib.Path(eval_cli.MARKDOWN).parent
    default = eval_cli.parse_args([])
    assert default.readme == eval_cli.README
    assert default.chart == str(beside_default / "images" / "results.png")
    assert default.json == str(beside_default / "results.json")
    # a run with its table elsewhere writes its chart and README block there (the README only if one is there)
    elsewhere = eval_cli.parse_args(["--markdown", "runs/check/results.md"])
    assert elsewhere.readme == str(pathlib.Path("runs/check") / eval_cli.README)
    assert elsewhere.chart == str(pathlib.Path("runs/check/images/results.png"))
    assert elsewhere.json == str(pathlib.Path("runs/check/results.json"))
    given = eval_cli.parse_args(["--markdown", "runs/check/results.md", "--readme", "mine.md"])
    assert given.readme == "mine.md"


def test_sigterm_stops_the_run_with_its_pool_workers_and_keeps_finished_episodes(tmp_path):
    import os
    import signal
    import subprocess
    import sys
    import time

    def children(pid):
        found = subprocess.run(["pgrep", "-P", str(pid)], capture_output=True, text=True).stdout.split()
        return {int(p) for p in found}

    def alive(pid):
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        return pathlib.Path(f"/proc/{pid}/status").read_text().find("State:\tZ") < 0

    def wait_for(condition, timeout):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if condition():
                return True
            time.sleep(0.2)
        return condition()

    Trainer(seed=0).save(tmp_path / "policy.pt")
    out = tmp_path / "docs"
    journal = tmp_path / "journal.jsonl"
    run = subprocess.Popen(
        [sys.executable, "-m", "impurity_learning.eval_cli", "--methods", "ours", "--scenarios", "random",
         "--episodes", "40", "--palette-groups", "default",
         "--policy-checkpoint", str(tmp_path / "policy.pt"),
         "--markdown", str(out / "r.md"), "--chart", str(out / "r.png"), "--json", str(out / "r.json"),
         "--journal", str(journal), *generalisation_paths(out), "--threads", "1", "--jobs", "2",
         "--no-progress"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        # the pool is up (two workers and the resource tracker) and an episode has finished
        assert wait_for(lambda: len(children(run.pid)) >= 3 and journal.is_file() and journal.stat().st_size,
                        timeout=300), "the run never started its pool or finished an episode"
        workers = children(run.pid)
        run.send_signal(signal.SIGTERM)
        run.wait(timeout=300)
    finally:
        if run.poll() is None:
            run.kill()
    assert run.returncode != 0  # interrupted, not a finished run
    assert wait_for(lambda: not any(alive(pid) for pid in workers), timeout=60), "workers outlived the run"
    assert not (out / "r.json").exists() and journal.read_text().count("\n") >= 1  # finished episodes kept
