#!/usr/bin/env python3
"""Ray against the process pool on this machine, side by side in one run: Ray's start-up
seconds and memory; evaluation episodes per minute with the process pool and with Ray at 1 and 2
workers (the same episodes, checked equal); training iterations per hour of the one-process loop and
of the actor-learner at 1 and 2 actors. Printed, never asserted.

    python benchmarks/bench_ray.py                                  # short (make bench): a few minutes
    python benchmarks/bench_ray.py --episodes 12 --iterations 120   # the README's figures

Every worker and the learner use one torch thread. Evaluation: Ours (the shipped network, cell rules)
on the random scenario's evaluation seeds; a configuration's time runs from submitting the first
episode to the last record, worker start-up included (the Ray runtime is started once before, and its
start-up is reported apart). Training: the same seed and method in fresh run directories; time is the
run's own (start-up apart).
"""

import argparse
import os
import pathlib
import tempfile
import time
from types import SimpleNamespace

from impurity_learning import eval_cli, ray_runtime
from impurity_learning.ray_train import ActorLearnerRun
from impurity_learning.train import TrainConfig, TrainingRun
from impurity_policy.core.checkpoint import SHIPPED_CHECKPOINT


def rss_mib(pid: int) -> float:
    try:
        for line in pathlib.Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    except (OSError, ValueError):
        pass
    return 0.0


def pool_workers_rss_mib() -> tuple:
    """(count, MiB) of this process's spawned multiprocessing children (the pool's workers; the local
    Ray runtime's processes are children too, and left out)."""
    me, count, total = str(os.getpid()), 0, 0.0
    for entry in pathlib.Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            status = (entry / "status").read_text()
            command = (entry / "cmdline").read_bytes()
            spawned = b"multiprocessing.spawn" in command and b"resource_tracker" not in command
        except OSError:
            continue
        parent = [line.split()[1] for line in status.splitlines() if line.startswith("PPid:")]
        if spawned and parent == [me]:
            count += 1
            total += rss_mib(int(entry.name))
    return count, total


def memory_line(kinds: dict) -> str:
    parts = [f"{kind} {v['processes']}× {v['rss_mib']:.0f} MiB" for kind, v in sorted(kinds.items())]
    total = sum(v["rss_mib"] for v in kinds.values())
    return f"{total:.0f} MiB ({', '.join(parts)})"


def evaluation(episodes: int) -> None:
    checkpoint = str(pathlib.Path(SHIPPED_CHECKPOINT).resolve())
    tasks = [("ours@cell", checkpoint, "random", eval_cli.EVAL_SEED_BASE + k, 1, "cpu", "default", "")
             for k in range(episodes)]
    configs = [("process pool", False, 1), ("process pool", False, 2), ("Ray", True, 1), ("Ray", True, 2)]
    figures, reference = [], None
    for name, on_ray, workers in configs:
        args = SimpleNamespace(ray=on_ray, ray_address=None, jobs=workers, threads=1)
        started, memory = time.perf_counter(), None
        records = []
        generator = (run_pool_of_one(tasks) if not on_ray and workers == 1 else
                     eval_cli.episode_records(tasks, args))
        for _task, record in generator:
            records.append(record)
            if memory is None and len(records) == min(workers, len(tasks)):
                count, mib = pool_workers_rss_mib()
                memory = (memory_line(ray_runtime.ray_processes()) if on_ray else
                          f"pool workers {count}× {mib:.0f} MiB")
        seconds = time.perf_counter() - started
        records.sort(key=lambda r: r["seed"])
        same = "reference" if reference is None else ("same" if records == reference else "DIFFERENT")
        reference = reference or records
        figures.append((f"{name}, {workers} worker{'s' if workers > 1 else ''}", len(tasks) / seconds * 60.0,
                        seconds, same, memory))
    base = figures[0][1]
    print(f"evaluation: {episodes} episodes of Ours [rules: cell], random scenario, 1 torch thread per "
          "worker")
    for label, per_minute, seconds, same, memory in figures:
        print(f"  {label:<24s} {per_minute:5.2f} episodes/min ({seconds:5.1f} s, x{per_minute / base:.2f}; "
              f"records {same}); memory while running: {memory}")
    pool2, ray2 = figures[1][1], figures[3][1]
    pool1, ray1 = figures[0][1], figures[2][1]
    print(f"  Ray against the pool: x{ray1 / pool1:.2f} at 1 worker, x{ray2 / pool2:.2f} at 2 workers "
          "(< 1: Ray is slower)")


def run_pool_of_one(tasks):
    """A process pool with one worker, as eval_cli's --jobs N>1 path but N = 1 (eval_cli runs --jobs 1
    in its own process)."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        futures = [(task, pool.submit(eval_cli.run_task, task)) for task in tasks]
        for task, future in futures:
            yield task, future.result()


def training(iterations: int, root: pathlib.Path) -> None:
    def config(name):
        return TrainConfig(run_dir=str(root / name), iterations=iterations, checkpoint_every=10 ** 6,
                           plot_every=10 ** 6, threads=1, progress=False, seed=0)

    figures = []
    for actors in (0, 1, 2):
        started = time.perf_counter()
        run = TrainingRun(config("local")) if actors == 0 else ActorLearnerRun(config(f"actors{actors}"),
                                                                               actors=actors)
        start_up = time.perf_counter() - started
        result = run.run()
        memory = memory_line(ray_runtime.ray_processes()) if actors else "-"
        run.close()
        name = "one process (today's loop)" if actors == 0 else f"Ray, {actors} actor(s)"
        figures.append((name, result["this_run"] / result["seconds"] * 3600.0, start_up,
                        result.get("rows_per_actor"), memory))
    base = figures[0][1]
    print(f"training: {iterations} iterations each (Ours, seed 0, 1 torch thread per process; the learner is "
          "this process)")
    for name, per_hour, start_up, rows, memory in figures:
        extra = f"; rows per actor {rows}; Ray memory at the end: {memory}" if rows else ""
        print(f"  {name:<26s} {per_hour:6.0f} iterations/h (x{per_hour / base:.2f}); "
              f"start-up {start_up:4.1f} s{extra}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--episodes", type=int, default=4, help="evaluation episodes per configuration")
    p.add_argument("--iterations", type=int, default=20, help="training iterations per configuration")
    args = p.parse_args()
    cost = ray_runtime.start_up_cost(num_cpus=2)
    print(f"Ray {ray_runtime.import_ray().__version__}: import {cost['import_s']:.1f} s, ray.init (local, "
          f"2 CPUs) {cost['init_s']:.1f} s, shutdown {cost['shutdown_s']:.1f} s; idle runtime memory "
          f"{memory_line(cost['memory'])}")
    ray_runtime.connect(None, num_cpus=2)
    evaluation(args.episodes)
    with tempfile.TemporaryDirectory(prefix="bench_ray_") as root:
        training(args.iterations, pathlib.Path(root))
    ray_runtime.disconnect(True)
    print(f"this machine: {os.cpu_count()} CPUs, shared with other work: figures are indicative")


if __name__ == "__main__":
    main()
