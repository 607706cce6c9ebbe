"""Actor-learner training on Ray: `train_cli --actors N` (a local runtime; `--ray-address
ADDR` joins a cluster).

N rollout actors (Ray actors, one CPU each) each hold a simulated cell and a copy of the network: a
train.Rollout, the environment code of the one-process loop. The learner is this process: the
TrainingRun of train.py (online and target networks, optimiser, prioritised replay, the CSV log,
checkpoints, the Fig. 9 plot, resume), with its rollout replaced by the actors. Each actor has one
action in flight; when its experience arrives, the actor is sent its next action at once (with the
newest weights it has not seen yet), then the learner learns from the experience. The learner
broadcasts its weights (one ray.put) after every `broadcast_every` updates (one update per transition
plus `replay_per_step` replays); an actor acts with weights at most one action plus `broadcast_every`
updates old.

`lockstep`: an actor is sent its next action only after the learner has learnt from its last one (and
broadcast). With one actor and `broadcast_every` 1 this is the one-process loop exactly: the same scenes,
palettes, decisions, rewards and updates, row for row (tests/unit/impurity_learning/test_ray.py). Without
lockstep, one actor acts while the learner learns; decisions then use weights one action older, so a
run matches the one-process loop in its statistics (the same scenes and epsilon schedule, the same
updates per transition), not row for row.

Actor a of N plays the scene indices a, a + N, ... (train.Rollout); the log's `actor` column says which
actor acted. On resume the actors restart from the checkpoint: each its last scene index and generator
state (all past every scene played when N changed). Actions in flight when the run stops are dropped.
"""

from __future__ import annotations

import collections

import torch

from . import ray_runtime
from .train import TrainConfig, TrainingRun, read_log, rollout_start

DEFAULT_BROADCAST_EVERY = 10  # learner updates between weight broadcasts


class RolloutWorker:
    """One Ray actor: a train.Rollout with its own copy of the network (CPU)."""

    def __init__(self, config: TrainConfig, network_config, weights: dict, actor: int, actors: int,
                 start: dict | None):
        from impurity_policy.core.network import QNetwork

        from .train import Rollout

        torch.set_num_threads(config.threads)
        network = QNetwork(network_config)
        network.load_state_dict(weights)
        self.rollout = Rollout(config, network, actor, actors, start)

    def act(self, iteration: int, weights: dict | None = None):
        """Load newer weights when given, then one action (train.Rollout.act) -> its Experience."""
        if weights is not None:
            self.rollout.network.load_state_dict(weights)
        return self.rollout.act(iteration)

    def state(self) -> dict:
        return self.rollout.state()


class ActorLearnerRun(TrainingRun):
    """TrainingRun whose experiences come from `actors` Ray actors (see the module docstring)."""

    def __init__(self, config: TrainConfig, actors: int = 2, broadcast_every: int = DEFAULT_BROADCAST_EVERY,
                 lockstep: bool = False, address: str | None = None):
        if actors < 1 or broadcast_every < 1:
            raise ValueError(f"need actors >= 1 and broadcast_every >= 1, got {actors} and {broadcast_every}")
        self.actors, self.broadcast_every, self.lockstep = actors, broadcast_every, lockstep
        self.started_ray = ray_runtime.connect(address, num_cpus=actors if address is None else None)
        self.workers = []
        try:
            super().__init__(config)
        except BaseException:
            self.close()
            raise

    # -- the environment side: actors
    def start_rollouts(self) -> None:
        ray = ray_runtime.import_ray()
        cpus = ray_runtime.cluster_cpus()
        if cpus < self.actors:  # an actor holds one CPU for the whole run: the others would never start
            raise ray_runtime.RayUnavailable(f"the Ray cluster has {cpus} CPUs, --actors {self.actors} needs "
                                             f"{self.actors}: add nodes or ask for fewer actors")
        worker_class = ray.remote(num_cpus=1)(RolloutWorker)
        weights = self._weights()
        network = self.trainer.network_config
        self.workers = [worker_class.remote(self.config, network, weights, actor, self.actors,
                                            rollout_start(self.rollout_states, actor, self.actors))
                        for actor in range(self.actors)]
        ray.get([worker.state.remote() for worker in self.workers])  # every actor has its cell: all start
        self.weights, self.version, self.broadcast_at = weights, 0, self.trainer.updates
        self.seen = [0] * self.actors  # the weights version each actor has
        self.pending = {}  # reference of an action in flight -> its actor

    def _weights(self):
        """The online network's weights in the object store (one copy for every actor)."""
        ray = ray_runtime.import_ray()
        return ray.put({k: v.detach().cpu() for k, v in self.trainer.online.state_dict().items()})

    def _submit(self, actor: int, iteration: int) -> None:
        """Send `actor` its next action, at `iteration` (its epsilon), with the weights it lacks."""
        newer = self.weights if self.seen[actor] < self.version else None
        self.seen[actor] = self.version
        self.pending[self.workers[actor].act.remote(iteration, newer)] = actor

    def _broadcast_if_due(self) -> None:
        if self.trainer.updates - self.broadcast_at >= self.broadcast_every:
            self.weights, self.broadcast_at = self._weights(), self.trainer.updates
            self.version += 1

    @property
    def world(self):
        raise AttributeError("an actor-learner run has no simulator in this process: the actors hold them")

    @property
    def policy(self):
        raise AttributeError("an actor-learner run's policies are in its actors")

    def describe(self) -> str:
        return f"train {self.config.method} ({self.actors} actor{'s' if self.actors > 1 else ''})"

    def step(self) -> dict:
        """One iteration: the next experience from whichever actor delivers first, learnt from."""
        ray = ray_runtime.import_ray()
        for actor in range(self.actors):
            if actor not in self.pending.values():
                self._submit(actor, self.iteration)
        (done,), _ = ray.wait(list(self.pending), num_returns=1)
        actor = self.pending.pop(done)
        experience = ray.get(done)
        if not self.lockstep:
            self._submit(actor, self.iteration + 1)  # it acts while we learn
        row = self.learn(experience)
        self._broadcast_if_due()
        if self.lockstep:
            self._submit(actor, self.iteration + 1)
        return row

    def current_rollout_states(self) -> list:
        ray = ray_runtime.import_ray()
        return ray.get([worker.state.remote() for worker in self.workers])

    def run(self) -> dict:
        result = super().run()
        result["actors"] = self.actors
        result["rows_per_actor"] = {str(a): n for a, n in sorted(rows_per_actor(self.log_path).items())}
        return result

    def close(self) -> None:
        """End the actors (their simulators with them) and a Ray runtime this run started."""
        ray = ray_runtime.import_ray()
        if not ray.is_initialized():
            return
        for worker in self.workers:
            ray.kill(worker)
        self.workers = []
        ray_runtime.disconnect(self.started_ray)


def rows_per_actor(log_path) -> collections.Counter:
    """How many log rows each actor's actions made (rows without an actor: the one-process loop's, 0)."""
    return collections.Counter(int(row.get("actor") or 0) for row in read_log(log_path))
