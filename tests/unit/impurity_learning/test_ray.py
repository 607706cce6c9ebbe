"""Evaluation and training on a Ray cluster, on a local cluster made with Ray's own test
utilities: a head without CPUs and two worker nodes of one CPU each, shared by every test here."""

import json

import pytest
import torch

from impurity_learning import eval_cli
from impurity_learning.ray_runtime import RayUnavailable, check_reachable
from impurity_learning.ray_train import ActorLearnerRun
from impurity_learning.train import TrainConfig, TrainingRun, read_log
from impurity_learning.train_cli import export_network
from impurity_policy.core.checkpoint import load_network
from impurity_policy.core.network import NetworkConfig

ray = pytest.importorskip("ray")
pytest.importorskip("ur5_driver_sim.core.world")
torch.set_num_threads(1)

TIMING = ("seconds", "t_decide", "t_act", "t_sense", "t_learn")


@pytest.fixture(scope="module")
def cluster():
    from ray.cluster_utils import Cluster

    local = Cluster(initialize_head=True, head_node_args={"num_cpus": 0, "include_dashboard": False})
    for _ in range(2):
        local.add_node(num_cpus=1)
    ray.init(address=local.address, log_to_driver=False)
    local.wait_for_nodes()
    yield local
    ray.shutdown()
    local.shutdown()


def test_an_unreachable_or_malformed_cluster_address_is_refused_at_once():
    with pytest.raises(RayUnavailable, match="does not answer"):
        check_reachable("127.0.0.1:1")  # nothing listens on port 1
    with pytest.raises(RayUnavailable, match="not host:port"):
        check_reachable("head-node")


def evaluate(out, *options) -> dict:
    assert eval_cli.main(["--methods", "s_rgm", "--scenarios", "random", "challenging", "--episodes", "2",
                          "--markdown", str(out / "r.md"), "--chart", str(out / "r.png"), "--json",
                          str(out / "r.json"), "--readme", str(out / "README.md"), "--no-progress",
                          "--palette-groups", "default", "--perception-scenes", "1",
                          "--generalisation", str(out / "g.md"), "--generalisation-chart", str(out / "g.png"),
                          "--generalisation-scenes", str(out / "gs.png"), "--threads", "1", *options]) == 0
    return json.loads((out / "r.json").read_text())["s_rgm"]["episodes"]


@pytest.mark.acceptance
def test_episodes_on_a_two_node_cluster_are_the_in_process_episodes_and_resume_from_the_journal(
        cluster, tmp_path):
    in_process = evaluate(tmp_path / "one", "--jobs", "1")
    assert len(in_process) == 4
    # an interrupted Ray run had written the first episode: it is kept, the other three run on the cluster
    journal = tmp_path / "ray" / "r.partial.jsonl"
    journal.parent.mkdir()
    first = dict(in_process[0], from_the_journal=True)
    task = ("s_rgm", "", first["scenario"], first["seed"], 1, "cpu", "default", "", "truth")
    key = eval_cli.task_key(task, {})
    journal.write_text(json.dumps({"key": key, "record": first}) + "\n")
    on_ray = evaluate(tmp_path / "ray", "--ray-address", cluster.address, "--jobs", "2")
    assert [e.pop("from_the_journal", False) for e in on_ray] == [True, False, False, False]
    assert on_ray == in_process  # the same seeds, the same decisions, the same records
    assert not journal.exists()  # the run completed: the results hold every record


def short_run(run_dir, iterations: int) -> TrainConfig:
    return TrainConfig(run_dir=str(run_dir), iterations=iterations, checkpoint_every=3, plot_every=3,
                       threads=1, progress=False, seed=3)


# A hang guard, not a time limit: on a loaded machine (a make eval and a pytest sharing 2 cores) Ray's workers
# start slowly and the run can pass the suite's 300 s guard, while it takes well under that on a quiet one.
@pytest.mark.acceptance
@pytest.mark.timeout(900)
def test_two_actors_feed_one_learner_and_the_run_resumes_from_its_checkpoint(cluster, tmp_path):
    run = ActorLearnerRun(short_run(tmp_path / "run", 6), actors=2, broadcast_every=2,
                          address=cluster.address)
    result = run.run()
    run.close()
    assert result["iterations"] == 6 and set(result["rows_per_actor"]) == {"0", "1"}
    rows = read_log(tmp_path / "run" / "log.csv")
    assert [int(r["iteration"]) for r in rows] == [1, 2, 3, 4, 5, 6]
    assert {r["actor"] for r in rows} == {"0", "1"}
    # actor a plays scene indices a, a + 2, ...: the two actors never share a scene
    assert all(int(r["scene"]) % 2 == int(r["actor"]) for r in rows)
    assert (tmp_path / "run" / "success.png").stat().st_size > 0

    resumed = ActorLearnerRun(short_run(tmp_path / "run", 7), actors=2, address=cluster.address)
    assert resumed.resumed and resumed.iteration == 6 and len(resumed.replay) == 6
    assert resumed.run()["this_run"] == 1
    resumed.close()
    assert [int(r["iteration"]) for r in read_log(tmp_path / "run" / "log.csv")] == list(range(1, 8))
    shipped = export_network(tmp_path / "run" / "checkpoint.pt", tmp_path / "policy.pt")
    assert load_network(shipped).config == NetworkConfig()


@pytest.mark.acceptance
def test_one_actor_in_lockstep_is_the_one_process_loop_row_for_row(cluster, tmp_path):
    local = TrainingRun(short_run(tmp_path / "local", 5))
    local.run()
    local.close()
    remote = ActorLearnerRun(short_run(tmp_path / "ray", 5), actors=1, broadcast_every=1, lockstep=True,
                             address=cluster.address)
    remote.run()
    remote.close()

    def without_timing(path) -> list:
        return [{k: v for k, v in row.items() if k not in TIMING} for row in read_log(path)]

    expected = without_timing(tmp_path / "local" / "log.csv")
    assert len(expected) == 5 and without_timing(tmp_path / "ray" / "log.csv") == expected
