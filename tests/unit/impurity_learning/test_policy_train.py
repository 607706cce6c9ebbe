"""Training loop end to end in the fast sim: a few iterations, a checkpoint, a resume, the log and plot."""

import csv

import pytest
import torch

from impurity_learning.train import CSV_FIELDS, TrainConfig, TrainingRun, migrate_log, network_config_for
from impurity_learning.train_cli import export_network
from impurity_policy.core.checkpoint import load_network
from impurity_policy.core.network import NetworkConfig

pytest.importorskip("ur5_driver_sim.core.world")
torch.set_num_threads(1)


def _rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_training_runs_checkpoints_and_resumes(tmp_path):
    config = TrainConfig(run_dir=str(tmp_path / "run"), iterations=4, checkpoint_every=2, plot_every=2,
                         threads=1, progress=False, seed=3)
    first = TrainingRun(config)
    assert not first.resumed
    result = first.run()
    first.world.close()
    assert result["iterations"] == 4
    rows = _rows(tmp_path / "run" / "log.csv")
    assert [int(r["iteration"]) for r in rows] == [1, 2, 3, 4]
    assert all(r["primitive"] in ("push", "grasp") and float(r["reward"]) in (0.0, 0.5, 1.0) for r in rows)
    assert all(r["primitive"] == "push" for r in rows if r["mode"] == "OCCLUDED_REGION")
    assert (tmp_path / "run" / "success.png").stat().st_size > 0

    config.iterations = 6
    second = TrainingRun(config)
    assert second.resumed and second.iteration == 4 and len(second.replay) == 4
    assert second.run()["this_run"] == 2
    second.world.close()
    assert [int(r["iteration"]) for r in _rows(tmp_path / "run" / "log.csv")] == list(range(1, 7))

    shipped = export_network(tmp_path / "run" / "checkpoint.pt", tmp_path / "policy.pt")
    assert load_network(shipped).config == NetworkConfig()
    assert shipped.stat().st_size < (tmp_path / "run" / "checkpoint.pt").stat().st_size


def test_ctrl_c_finishes_the_iteration_saves_and_stops(tmp_path):
    import signal

    config = TrainConfig(run_dir=str(tmp_path / "run"), iterations=50, threads=1, progress=False, seed=4)
    run = TrainingRun(config)
    step = run.step
    before = signal.getsignal(signal.SIGINT)  # pytest's, or SIG_IGN when started in the background

    def step_then_ctrl_c(*args):
        result = step(*args)
        signal.raise_signal(signal.SIGINT)  # as if pressed during the first iteration
        return result

    run.step = step_then_ctrl_c
    result = run.run()
    run.world.close()
    assert result["iterations"] == 1
    assert [int(r["iteration"]) for r in _rows(tmp_path / "run" / "log.csv")] == [1]
    resumed = TrainingRun(config)
    assert resumed.resumed and resumed.iteration == 1 and len(resumed.replay) == 1
    resumed.world.close()
    assert signal.getsignal(signal.SIGINT) is before  # the caller's handler is back


def test_old_log_columns_are_migrated_before_appending(tmp_path):
    log = tmp_path / "log.csv"
    log.write_text("iteration,primitive,reward\n1,push,0.5\n2,grasp,1.0\n")
    migrate_log(log)
    rows = _rows(log)
    assert list(rows[0]) == list(CSV_FIELDS) and rows[1]["primitive"] == "grasp" and rows[1]["message"] == ""
    migrate_log(log, last_iteration=1)  # a run killed after logging iteration 2, checkpointed at 1
    assert [r["iteration"] for r in _rows(log)] == ["1"]


def test_resume_refuses_another_method(tmp_path):
    run = TrainingRun(TrainConfig(run_dir=str(tmp_path), iterations=1, threads=1, progress=False))
    run.save()
    run.world.close()
    with pytest.raises(RuntimeError, match="another training setup"):
        TrainingRun(TrainConfig(run_dir=str(tmp_path), method="no_t", iterations=1, progress=False))


def test_train_config_rules_default_to_none_and_unknown_presets_are_refused():
    assert TrainConfig().rules == "none"  # the paper's method: the network's argmax while training
    assert TrainConfig(rules="cell").rules == "cell"
    with pytest.raises(ValueError, match="unknown rules preset 'telepathy'"):
        TrainConfig(rules="telepathy")


def test_full_heightmap_methods_use_224_inputs():
    assert network_config_for("vpg").crop_size == 224 and network_config_for("ours").crop_size == 112
    with pytest.raises(ValueError, match="random scenario only"):
        TrainConfig(scenario="challenging")


def test_fast_sim_episode_counts_like_the_episode_core():
    from impurity_learning.agents import NetworkAgent
    from impurity_learning.evaluate import EVAL_SEED_BASE, run_episode
    from impurity_policy.core.episode import EpisodeRequest
    from impurity_policy.core.network import QNetwork
    from impurity_policy.core.policy import Policy
    from impurity_policy.core.rules import RulePipeline
    from ur5_driver_sim.core.world import CellWorld

    world = CellWorld(mode="floating")
    torch.manual_seed(0)
    try:
        agent = NetworkAgent("ours", Policy(QNetwork(), rules=RulePipeline.preset("cell")))
        metrics = run_episode(world, agent, EpisodeRequest("random", seed=EVAL_SEED_BASE, max_actions=3))
    finally:
        world.close()
    assert 1 <= metrics["actions"] <= 3 and metrics["termination_reason"]
    assert metrics["actions"] == metrics["grasp_attempts"] + metrics["pushes"]
