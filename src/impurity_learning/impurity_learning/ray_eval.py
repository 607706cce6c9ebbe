"""Evaluation episodes on Ray: `eval_cli --ray` (a local runtime) or `--ray-address ADDR`
(a cluster).

Each episode is one call of eval_cli.run_task, the function the process pool and the one-process path
call: the same (row, checkpoint, scenario, seed, palette) gives the same record wherever it runs. One
Ray actor per worker keeps its simulator and agents between episodes (run_task's per-process cache, as
in a pool worker); episodes go to whichever actor is free, and each record is handed back as soon as
its episode ends, so that eval_cli writes it to the run's journal and an interrupted run resumes.

The checkpoints travel with the actors (through Ray's object store): a worker on another machine that
lacks the driver's file, or has another version of it, runs the driver's bytes.
"""

from __future__ import annotations

import collections
import hashlib
import os
import pathlib
import sys
import tempfile

from . import ray_runtime


class EpisodeWorker:
    """One Ray actor: a simulator and the agents, built on first use and kept (eval_cli.run_task)."""

    def __init__(self, checkpoints: dict, threads: int = 1):
        """checkpoints: {the driver's path: the file's bytes}; a path that is missing here or differs
        from those bytes is replaced by a copy of them in a temporary directory."""
        import torch

        torch.set_num_threads(threads)
        self.paths, self._copies = {}, None
        for path, data in checkpoints.items():
            local = pathlib.Path(path)
            if local.is_file() and local.read_bytes() == data:
                self.paths[path] = path
                continue
            if self._copies is None:
                self._copies = tempfile.TemporaryDirectory(prefix="impurity_eval_")
            copy = pathlib.Path(self._copies.name) / f"{hashlib.sha256(data).hexdigest()[:16]}.pt"
            copy.write_bytes(data)
            self.paths[path] = str(copy)

    def run(self, task: tuple) -> dict:
        from .eval_cli import run_task

        row, checkpoint, *rest = task
        return run_task((row, self.paths.get(checkpoint, checkpoint), *rest))

    def pid(self) -> int:
        return os.getpid()


def episodes(tasks: list, workers: int, address: str | None = None, threads: int = 1):
    """Run eval_cli tasks on Ray; yields (task, record) as each episode ends (in completion order).
    `workers` actors (<= 0: one per CPU of the runtime), one episode in flight on each. Starts a local
    runtime with `workers` CPUs when `address` is None and this process has none; joins `address`
    otherwise. Actors are ended, and a runtime started here is shut down, when the generator ends or is
    closed (an interrupted run)."""
    started = ray_runtime.connect(address, num_cpus=workers if address is None and workers > 0 else None)
    ray = ray_runtime.import_ray()
    actors = []
    try:
        cpus = ray_runtime.cluster_cpus()
        if 0 < cpus < workers:
            print(f"eval: the Ray cluster has {cpus} CPUs: {cpus} workers, not {workers}", file=sys.stderr)
        count = min(workers, cpus) if workers > 0 else cpus  # an actor takes one CPU for the whole run
        count = max(1, min(count, len(tasks)))
        paths = sorted({task[1] for task in tasks if task[1]})
        checkpoints = ray.put({path: pathlib.Path(path).read_bytes() for path in paths})
        worker_class = ray.remote(num_cpus=1)(EpisodeWorker)
        actors = [worker_class.remote(checkpoints, threads) for _ in range(count)]
        queue, pending = collections.deque(tasks), {}  # pending: reference -> (actor, task)

        def submit(actor):
            task = queue.popleft()
            pending[actor.run.remote(task)] = (actor, task)

        for actor in actors:
            if queue:
                submit(actor)
        while pending:
            (done,), _ = ray.wait(list(pending), num_returns=1)
            actor, task = pending.pop(done)
            record = ray.get(done)  # an episode that failed raises here and stops the run
            if queue:
                submit(actor)
            yield task, record
    finally:
        for actor in actors:
            ray.kill(actor)
        ray_runtime.disconnect(started)
