"""Self-supervised training in the fast sim (paper 6.2): sim + heightmap + attention cores called
directly, no ROS.

One iteration: render -> heightmaps -> attention -> 32 Q maps -> epsilon-greedy action -> sim push or
grasp -> reward (grasp: a target lifted; push: TCDD of the attended target rose by > delta) -> one DQN
update on the new transition and `replay_per_step` rank-based replays.

Scenes: random scenario only, each from a seeded scene index, under an appearance: with
`palettes = "training"` each scene draws a palette from splits.py's training set (the default palette,
the tuning palettes or a random palette of the training seed range) and an exposure, so that the
network learns to key on the target mask and the geometry, not on one colour; `"default"` keeps the
blue/red palette of the first releases. `init_from` starts from a network checkpoint (fine-tuning).
A scene is replaced when every target
is picked, when attention finds nothing to act on, when the same primitive failed 3 times in a row
(paper 6.3), or after `max_scene_actions` (a guard against endless shuffling).

Two sides: a Rollout (the simulated cell and a policy acting in it: scenes, sensing, the
epsilon-greedy decision, the action, the reward) and the learner (TrainingRun: the DQN updates, the
prioritised replay, the log, checkpoints). TrainingRun drives one Rollout in its own process with the
learner's network, exactly as one loop; ray_train.ActorLearnerRun drives N of them as Ray actors. Random
draws: palettes and exploration from the run seed's generator (actor 0's; actor a's from (seed, a)),
replay sampling from a generator of its own, so that one actor in lockstep with the learner makes the
same decisions as this process. (A checkpoint holding one generator and no replay generator resumes with
that one for the decisions and a fresh one for the replay.)

Files in run_dir: checkpoint.pt (trainer + loop state, every `checkpoint_every` iterations and at the
end), replay.pkl (the replay buffer; never committed), log.csv (one row per action, with the actor that
acted), success.png (grasp and push success over the last 300 attempts, paper Fig. 9). Restarting with
the same run_dir resumes from the checkpoint; the interrupted scene is replaced by the next seeded one.

Methods (ablations and baselines; only "ours" is trained by default):
  ours    attention crops; pushes only at the cluster crop when no target is visible; TCDD push reward
  no_t    as ours, push reward from scene change (> 300 px changed -> 1, paper 6.3.2)
  no_oi   no occluded-region inference: without a visible target, the crop centred on the saliency
          peak, treated as a target crop (push and grasp)
  no_tsd  no target saliency: the whole 224^2 heightmap is the state (all-one mask)
  vpg     whole heightmap, change push reward 0.5, any lifted object rewards a grasp (target-agnostic)
"""

from __future__ import annotations

import csv
import math
import pathlib
import signal
import threading
import time
from dataclasses import asdict, dataclass, field

import numpy as np
import torch

from impurity_common import cell
from impurity_common.grid import HeightmapGrid
from impurity_policy.core.network import GRASP, PUSH, NetworkConfig
from impurity_policy.core.policy import (
    MODE_NONE,
    MODE_OCCLUDED_REGION,
    MODE_TARGET,
    Observation,
    Policy,
    allowed_primitives,
)
from impurity_policy.core.pose import PoseRules
from impurity_policy.core.rules import PRESETS, RulePipeline

from . import splits, tcdd
from .replay import RankedReplay, Transition
from .trainer import Trainer, TrainerConfig, q_maps

TRAIN_FORMAT_VERSION = 1
PALETTE_SETS = ("training", "default")
# Appearance draw per training scene ("training" set): default palette, a named tuning palette, or a
# random palette of the training seed range; then an exposure drawn log-uniformly (splits.py).
PALETTE_MIX = (0.2, 0.3, 0.5)
METHODS = ("ours", "no_t", "no_oi", "no_tsd", "vpg")
SCENE_SEED_STRIDE = 1_000_003  # scene index i of run seed s uses sim seed s * stride + i
CSV_FIELDS = ("iteration", "scene", "scene_step", "mode", "primitive", "rotation", "crop_row", "crop_col",
              "x", "y", "z", "yaw", "q_value", "explored", "epsilon", "reward", "label", "loss", "td_error",
              "replay_loss", "alpha_before", "alpha_after", "grasp_lifted", "target_grasped",
              "targets_remaining", "scene_reset", "seconds", "t_decide", "t_act", "t_sense", "t_learn",
              "message", "palette", "actor")


@dataclass
class TrainConfig:
    run_dir: str = "runs/train"
    method: str = "ours"
    iterations: int = 10000  # total (a resumed run continues up to this)
    seed: int = 0
    scenario: str = "random"
    num_targets: int = -1  # -1: the scenario's default
    num_objects: int = -1
    replay_per_step: int = 1
    max_same_failures: int = 3  # paper 6.3: change the scene when the same action fails 3 times
    max_scene_actions: int = 40
    checkpoint_every: int = 100
    plot_every: int = 100
    plot_window: int = 300
    replay_capacity: int = 20000
    threads: int = 2
    device: str = "cpu"  # network.resolve_device: cpu, cuda, cuda:N, auto
    max_hours: float = 0.0  # > 0: stop (and save) after this much wall time in this invocation
    # Test-time rules preset while training (rules.PRESETS). "none" by default: the shipped checkpoint
    # was trained without rules; evaluation and the policy node apply them at test time.
    rules: str = "none"
    palettes: str = "training"  # PALETTE_SETS: "training" (random appearances) or "default"
    init_from: str = ""  # a network checkpoint to start from (weights only); "" = from scratch
    progress: bool = True
    trainer: TrainerConfig = field(default_factory=TrainerConfig)

    def __post_init__(self):
        if self.method not in METHODS:
            raise ValueError(f"unknown method '{self.method}' (expected one of {', '.join(METHODS)})")
        if self.rules not in PRESETS:
            raise ValueError(f"unknown rules preset '{self.rules}' (expected one of {', '.join(PRESETS)})")
        if self.scenario != "random":
            raise ValueError("training uses the random scenario only (paper 6.2)")
        if self.palettes not in PALETTE_SETS:
            raise ValueError(f"unknown palette set '{self.palettes}' "
                             f"(expected one of {', '.join(PALETTE_SETS)})")


def network_config_for(method: str) -> NetworkConfig:
    """Full-heightmap methods run the same towers on 224^2 inputs."""
    return NetworkConfig(crop_size=cell.HEIGHTMAP_SIZE) if method in ("no_tsd", "vpg") else NetworkConfig()


# ---- observations per method -----------------------------------------------------------------------
def observe(method: str, attention, height: np.ndarray, color: np.ndarray,
            grid: HeightmapGrid = HeightmapGrid()) -> Observation:
    """Attention output -> the policy's input for `method` (see the module docstring); `height` and
    `color` are the full maps on `grid`."""
    if method in ("no_tsd", "vpg"):
        mode = MODE_NONE if attention.mode == MODE_NONE and not np.any(height > 0.01) else MODE_TARGET
        return Observation(mode, color, height.astype(np.float32),
                           np.full(height.shape, 255, np.uint8), (0, 0), height, grid)
    obs = Observation.from_attention(attention, height, grid)
    if method == "no_oi" and attention.mode == MODE_OCCLUDED_REGION:
        from impurity_attention.core.attention import crop_centered

        size = attention.mask.shape[0]
        peak = np.unravel_index(int(np.argmax(attention.saliency)), attention.saliency.shape)
        color_crop, origin = crop_centered(color, peak[0], peak[1], size)
        height_crop, _ = crop_centered(height, peak[0], peak[1], size)
        obs = Observation(MODE_TARGET, color_crop, height_crop.astype(np.float32),
                          np.full((size, size), 255, np.uint8), origin, height, grid)
    return obs


def attended_target(obs: Observation, truth, resolution: float = cell.HEIGHTMAP_RESOLUTION) -> int | None:
    """The target the crop is about: the one nearest the crop centre (sim ground truth)."""
    targets = [t for t in truth.target_ids if t in truth.poses]
    if not targets:
        return None
    size = obs.mask.shape[0]
    centre = cell.pixel_to_base(obs.crop_origin[0] + size / 2.0 - 0.5, obs.crop_origin[1] + size / 2.0 - 0.5,
                                resolution)
    return min(targets, key=lambda t: math.dist(truth.poses[t][0][:2], centre))


def positions(truth) -> dict:
    return {body: pose[0] for body, pose in truth.poses.items()}


@dataclass
class Sensed:
    """One look at the sim cell: what the policy sees and what the sim knows."""

    obs: Observation  # the method's network input
    truth: object  # ur5_driver_sim GroundTruth
    maps: object  # impurity_attention Heightmaps (full colour and height maps)
    attention: object  # impurity_attention AttentionOutput (saliency, target mask, clusters)


def sense(world, projectors: dict, method: str, attention_params, grid, known_product=None) -> Sensed:
    """Render the sim camera -> heightmaps -> attention -> the method's observation; `projectors`
    caches the camera projection; known_product: attend's (product_memory.known_product, or None)."""
    from impurity_attention.core.heightmap import HeightmapProjector

    frame = world.render()
    if "camera" not in projectors:
        projectors["camera"] = HeightmapProjector(frame.intrinsics, frame.camera_pose, frame.depth.shape,
                                                  grid)
    maps = projectors["camera"].project(frame.color, frame.depth)
    return sensed_from(maps, world.ground_truth(frame), method, attention_params, grid, known_product)


def sensed_from(maps, truth, method: str, attention_params, grid, known_product=None,
                closer: bool = False) -> Sensed:
    """Heightmaps `maps` (and the sim's `truth` of the same frame) -> attention -> the method's observation;
    known_product and closer: attend's (a stall look re-attends the maps of the current view)."""
    from impurity_attention.core.attention import attend

    attention = attend(maps.color, maps.height, attention_params, grid, known_product=known_product,
                       closer=closer)
    return Sensed(observe(method, attention, maps.height, maps.color, grid), truth, maps, attention)


# ---- the environment side: a rollout -----------------------------------------------------------------
LEARNER_STREAM = 2 ** 32  # the learner's replay draws: generator (seed, LEARNER_STREAM), apart from actors'


def rollout_rng(seed: int, actor: int) -> np.random.Generator:
    """Actor 0's palettes and epsilon-greedy draws come from the run seed's generator, actor a > 0's
    from (seed, a); the learner's replay draws from (seed, LEARNER_STREAM)."""
    return np.random.default_rng(seed if actor == 0 else (seed, actor))


@dataclass
class Experience:
    """One iteration's environment side, as a rollout hands it to the learner: the transition and the
    log row's fields the environment knows (the learner adds iteration, loss, label, td_error,
    replay_loss and t_learn; `seconds` is the rollout's share until then)."""

    transition: Transition
    row: dict


class Rollout:
    """One simulated cell and the policy acting in it: the environment side of training iterations
    (scenes, sensing, the epsilon-greedy decision, the sim action and its reward). TrainingRun drives
    one in its own process with the learner's network; ray_train's actors each drive one with a copy
    of it, refreshed when the learner broadcasts weights.

    Actor `actor` of `actors` plays the scene indices actor, actor + actors, actor + 2 actors, ... of the
    run seed (sim seed = seed * SCENE_SEED_STRIDE + index), so one actor plays the in-process loop's
    scenes. `start` (from a checkpoint, state()): the last scene index played and the generator state;
    the interrupted scene is replaced by the next one."""

    def __init__(self, config: TrainConfig, network, actor: int = 0, actors: int = 1,
                 start: dict | None = None):
        from impurity_attention.core.attention import AttentionParams
        from ur5_driver_sim.core.world import CellWorld

        self.config, self.network, self.actor, self.actors = config, network, actor, actors
        self.device = next(network.parameters()).device
        self.policy = Policy(network, PoseRules(), config.trainer.grasp_needs_object,
                             RulePipeline.preset(config.rules))
        self.rng = rollout_rng(config.seed, actor)
        self.scene_index = -1  # the last scene index played
        if start:
            self.scene_index = int(start["scene_index"])
            if start.get("rng_state") is not None:
                self.rng.bit_generator.state = start["rng_state"]
        self.grid = HeightmapGrid()
        self.attention_params = AttentionParams()
        self.world = CellWorld(mode="floating")
        self._projectors = {}
        self.palette = ""
        self.current = None  # (obs, truth, maps) of the scene in play; None before the first
        self.scene_step, self.failures = 0, {PUSH: 0, GRASP: 0}

    def state(self) -> dict:
        return {"scene_index": self.scene_index, "rng_state": self.rng.bit_generator.state}

    def close(self) -> None:
        self.world.close()

    # -- sensing
    def sense(self):
        sensed = sense(self.world, self._projectors, self.config.method, self.attention_params, self.grid)
        return sensed.obs, sensed.truth, sensed.maps

    def new_scene(self):
        self.scene_index += 1 + (self.actor - self.scene_index - 1) % self.actors  # the next of this actor's
        seed = self.config.seed * SCENE_SEED_STRIDE + self.scene_index
        self.palette = self.draw_palette()
        self.world.reset_scene(self.config.scenario, seed=seed, num_targets=self.config.num_targets,
                               num_objects=self.config.num_objects, palette=self.palette)
        self.scene_step, self.failures = 0, {PUSH: 0, GRASP: 0}
        self.policy.rules.clear()
        return self.sense()

    def draw_palette(self) -> str:
        """The next scene's palette name (with an exposure suffix), drawn from self.rng."""
        if self.config.palettes == "default":
            return ""
        pick = self.rng.choice(len(PALETTE_MIX), p=PALETTE_MIX)
        if pick == 0:
            name = splits.DEFAULT_PALETTE
        elif pick == 1:
            name = str(self.rng.choice(splits.TUNING_NAMED))
        else:
            seeds = splits.TRAINING_RANDOM_SEEDS
            name = f"random-{int(self.rng.integers(seeds.start, seeds.stop))}"
        low, high = splits.TRAINING_EXPOSURE
        exposure = float(np.exp(self.rng.uniform(np.log(low), np.log(high))))
        return f"{name}@x{exposure:.3f}"

    # -- one action
    def playable(self) -> bool:
        """The scene in play has something to act on: attention found a target or a cluster, and a
        target is left."""
        return self.current is not None and self.current[0].mode != MODE_NONE and \
            self.current[1].targets_remaining > 0

    def push_reward(self, obs, truth_before, truth_after, maps_before, maps_after) -> tuple:
        method = self.config.method
        if method in ("no_t", "vpg"):
            reward = tcdd.push_reward_change(maps_before.height, maps_after.height)
            reward = 0.5 if method == "vpg" and reward > 0 else reward
            return reward, float("nan"), float("nan")
        outcome = tcdd.tcdd_push_outcome(attended_target(obs, truth_before), positions(truth_before),
                                         positions(truth_after), cell.in_workspace)
        return outcome.reward, outcome.alpha_before, outcome.alpha_after

    def act(self, iteration: int) -> Experience:
        """One action at training iteration `iteration` (its epsilon): a new scene first when the one in
        play has nothing to act on (a scene where attention finds nothing is skipped), then decide, act,
        sense, reward; the scene is replaced after its last action (all targets picked, nothing left to
        attend to, `max_same_failures` failures of one primitive in a row, or `max_scene_actions`)."""
        config = self.config
        while not self.playable():
            self.current = self.new_scene()
        obs, truth, maps = self.current
        t0 = time.perf_counter()
        epsilon = config.trainer.epsilon(iteration)
        q = q_maps(self.network, obs.state, self.device)
        choice = self.policy.decide(obs, q=q, epsilon=epsilon, rng=self.rng)
        decision, pose = choice.decision, choice.pose
        kind = "grasp" if decision.primitive == GRASP else "push"
        t1 = time.perf_counter()
        outcome = self.world.execute(kind, pose.x, pose.y, pose.z, pose.yaw)
        self.policy.remember(pose, obs.height, bool(outcome.success))  # for stateful rules (--rules cell)
        t2 = time.perf_counter()
        next_obs, next_truth, next_maps = self.sense()
        t3 = time.perf_counter()
        alpha_before = alpha_after = float("nan")
        if decision.primitive == GRASP:
            lifted = bool(outcome.success)
            reward = tcdd.grasp_reward(lifted if config.method == "vpg" else bool(outcome.target_grasped))
        else:
            lifted = False
            reward, alpha_before, alpha_after = self.push_reward(obs, truth, next_truth, maps, next_maps)
        self.scene_step += 1
        failed = reward <= 0.0
        self.failures[decision.primitive] = self.failures[decision.primitive] + 1 if failed else 0
        terminal = next_truth.targets_remaining == 0 or next_obs.mode == MODE_NONE
        transition = Transition(obs.state, decision.primitive, decision.rotation, decision.pixel, reward,
                                None if terminal else next_obs.state,
                                () if terminal else allowed_primitives(next_obs.mode))
        scene_reset = (terminal or max(self.failures.values()) >= config.max_same_failures
                       or self.scene_step >= config.max_scene_actions)
        row = {"actor": self.actor, "scene": self.scene_index, "scene_step": self.scene_step,
               "mode": {MODE_TARGET: "TARGET", MODE_OCCLUDED_REGION: "OCCLUDED_REGION"}.get(obs.mode, "NONE"),
               "primitive": kind, "rotation": decision.rotation, "crop_row": decision.pixel[0],
               "crop_col": decision.pixel[1], "x": round(pose.x, 4), "y": round(pose.y, 4),
               "z": round(pose.z, 4), "yaw": round(pose.yaw, 4), "q_value": round(decision.q_value, 5),
               "explored": int(decision.explored), "epsilon": round(epsilon, 4), "reward": reward,
               "alpha_before": _round(alpha_before), "alpha_after": _round(alpha_after),
               "grasp_lifted": int(lifted), "target_grasped": int(bool(outcome.target_grasped)),
               "targets_remaining": next_truth.targets_remaining, "scene_reset": int(scene_reset),
               "seconds": t3 - t0, "t_decide": round(t1 - t0, 3), "t_act": round(t2 - t1, 3),
               "t_sense": round(t3 - t2, 3), "message": outcome.message, "palette": self.palette}
        self.current = self.new_scene() if scene_reset else (next_obs, next_truth, next_maps)
        return Experience(transition, row)


# ---- the learner and the loop --------------------------------------------------------------------------
class TrainingRun:
    """The training loop: the learner (online and target networks, optimiser, prioritised replay, the
    log, checkpoints, the Fig. 9 plot) and, in this process, one Rollout acting with the learner's own
    network; `run()` trains up to config.iterations, resuming when possible. ray_train.ActorLearnerRun
    replaces the rollout with Ray actors and keeps everything else."""

    def __init__(self, config: TrainConfig):
        torch.set_num_threads(config.threads)
        self.config = config
        self.dir = pathlib.Path(config.run_dir)
        self.dir.mkdir(parents=True, exist_ok=True)
        self.checkpoint_path = self.dir / "checkpoint.pt"
        self.replay_path = self.dir / "replay.pkl"
        self.log_path = self.dir / "log.csv"
        self.plot_path = self.dir / "success.png"
        self.trainer = Trainer(network_config_for(config.method), config.trainer, seed=config.seed,
                               device=config.device)
        self.replay = RankedReplay(config.replay_capacity)
        self.rng = np.random.default_rng((config.seed, LEARNER_STREAM))  # replay draws
        self.iteration = 0
        self.rollout_states: list = []  # from the checkpoint: each actor's Rollout.state()
        self.resumed = self._resume()
        if not self.resumed and config.init_from:
            self.trainer.load(config.init_from, weights_only_network=True)
        self.start_rollouts()

    def start_rollouts(self) -> None:
        """The environment side: one Rollout here, acting with self.trainer.online."""
        self.rollout = Rollout(self.config, self.trainer.online, 0, 1,
                               rollout_start(self.rollout_states, 0, 1))

    @property
    def world(self):
        return self.rollout.world

    @property
    def policy(self):
        return self.rollout.policy

    def close(self) -> None:
        self.rollout.close()

    # -- persistence
    def _resume(self) -> bool:
        if not self.checkpoint_path.is_file():
            return False
        extra = self.trainer.load(self.checkpoint_path)
        setup = (extra.get("method"), extra.get("train_format_version"))
        if setup != (self.config.method, TRAIN_FORMAT_VERSION):
            raise RuntimeError(f"{self.checkpoint_path} is from another training setup (method, format) = "
                               f"{setup}; use a new --run-dir")
        self.iteration = int(extra["iteration"])
        # a checkpoint without `rollouts` holds one generator and one scene count: actor 0's
        self.rollout_states = extra.get("rollouts") or [{"scene_index": int(extra["scene_index"]),
                                                         "rng_state": extra["rng_state"]}]
        if extra.get("replay_rng_state") is not None:
            self.rng.bit_generator.state = extra["replay_rng_state"]
        torch.set_rng_state(extra["torch_rng_state"])
        if self.replay_path.is_file():
            self.replay = RankedReplay.load(self.replay_path)
        return True

    def current_rollout_states(self) -> list:
        return [self.rollout.state()]

    def save(self) -> None:
        self.replay.save(self.replay_path)  # first: a checkpoint never points at a missing replay
        rollouts = self.current_rollout_states()
        self.trainer.save(self.checkpoint_path, extra={
            "train_format_version": TRAIN_FORMAT_VERSION, "method": self.config.method,
            "iteration": self.iteration, "scene_index": max(r["scene_index"] for r in rollouts),
            "rng_state": rollouts[0]["rng_state"], "rollouts": rollouts,
            "replay_rng_state": self.rng.bit_generator.state, "torch_rng_state": torch.get_rng_state(),
            "config": {k: v for k, v in asdict(self.config).items() if k != "trainer"}})

    def describe(self) -> str:
        return f"train {self.config.method}"

    def run(self) -> dict:
        config = self.config
        migrate_log(self.log_path, self.iteration)
        write_header = not self.log_path.is_file() or self.log_path.stat().st_size == 0
        log_file = open(self.log_path, "a", newline="")
        writer = csv.DictWriter(log_file, CSV_FIELDS)
        if write_header:
            writer.writeheader()
        bar = None
        if config.progress:
            from tqdm import tqdm

            bar = tqdm(total=config.iterations, initial=self.iteration, desc=self.describe(), unit="it",
                       dynamic_ncols=True)
        started, first_iteration = time.perf_counter(), self.iteration
        interrupted = []

        def finish_iteration_then_stop(_signum, _frame):  # Ctrl-C: finish the step, save, stop
            interrupted.append(True)
            print(f"\ntrain: interrupted; saving after iteration {self.iteration + 1}", flush=True)

        in_main_thread = threading.current_thread() is threading.main_thread()
        previous_handler = None
        if in_main_thread:
            previous_handler = signal.signal(signal.SIGINT, finish_iteration_then_stop)
        try:
            while self.iteration < config.iterations and not interrupted:
                if config.max_hours > 0 and time.perf_counter() - started > 3600.0 * config.max_hours:
                    break
                row = self.step()
                writer.writerow(row)
                self.iteration += 1
                if bar is not None:
                    bar.update(1)
                    bar.set_postfix_str(recent_rates(row, self._recent))
                if self.iteration % config.checkpoint_every == 0:
                    log_file.flush()
                    self.save()
                if self.iteration % config.plot_every == 0:
                    log_file.flush()
                    plot_success(self.log_path, self.plot_path, config.plot_window)
        finally:
            if in_main_thread:
                signal.signal(signal.SIGINT, previous_handler)
            log_file.close()
            if bar is not None:
                bar.close()
        self.save()
        plot_success(self.log_path, self.plot_path, config.plot_window)
        elapsed = time.perf_counter() - started
        done = self.iteration - first_iteration
        return {"iterations": self.iteration, "this_run": done, "seconds": elapsed,
                "iterations_per_second": done / elapsed if elapsed > 0 else 0.0,
                **summary(self.log_path, config.plot_window)}

    _recent: list = []

    def step(self) -> dict:
        """One iteration: the rollout acts with the current network, the learner learns; the log row."""
        return self.learn(self.rollout.act(self.iteration))

    def learn(self, experience: Experience) -> dict:
        """One DQN update on the new transition, then `replay_per_step` replays; the complete log row."""
        t0 = time.perf_counter()
        transition = experience.transition
        loss, td_error, label = self.trainer.update(transition)
        index = self.replay.add(transition)
        self.replay.update_priority(index, td_error)
        replay_loss = self.replay_updates(index, transition.primitive, transition.reward > 0)
        t_learn = time.perf_counter() - t0
        row = dict(experience.row)
        row.update({"iteration": self.iteration + 1, "label": round(label, 5), "loss": round(loss, 6),
                    "td_error": round(td_error, 5),
                    "replay_loss": "" if replay_loss is None else round(replay_loss, 6),
                    "seconds": round(row["seconds"] + t_learn, 3), "t_learn": round(t_learn, 3)})
        return row

    def replay_updates(self, newest: int, primitive: int, positive: bool):
        """VPG-style: replay the same primitive with the opposite outcome when there is one (else any
        of that primitive), drawn by rank; the label is recomputed with the current target network."""
        losses = []
        for _ in range(self.config.replay_per_step):
            index = self.replay.sample(self.rng, primitive=primitive, positive=not positive, exclude=newest)
            if index is None:
                index = self.replay.sample(self.rng, primitive=primitive, exclude=newest)
            if index is None:
                break
            loss, td_error, _ = self.trainer.update(self.replay.get(index))
            self.replay.update_priority(index, td_error)
            losses.append(loss)
        return float(np.mean(losses)) if losses else None


def rollout_start(saved: list, actor: int, actors: int) -> dict | None:
    """Where actor `actor` of `actors` resumes from the checkpoint's rollout states: its own when the
    number of actors is unchanged; otherwise past every scene any actor played (its generator state
    when it had one)."""
    if not saved:
        return None
    if len(saved) == actors:
        return saved[actor]
    return {"scene_index": max(int(s["scene_index"]) for s in saved),
            "rng_state": saved[actor]["rng_state"] if actor < len(saved) else None}


def _round(value: float):
    return "" if not math.isfinite(value) else round(value, 5)


def recent_rates(row: dict, recent: list, window: int = 300) -> str:
    recent.append((row["primitive"], float(row["reward"]) > 0))
    del recent[:-window]
    grasps = [ok for kind, ok in recent if kind == "grasp"]
    pushes = [ok for kind, ok in recent if kind == "push"]
    g = f"{100 * np.mean(grasps):.0f}%" if grasps else "-"
    p = f"{100 * np.mean(pushes):.0f}%" if pushes else "-"
    return f"grasp {g} push {p} (last {len(recent)})"


# ---- log analysis --------------------------------------------------------------------------------------
def migrate_log(path, last_iteration: int | None = None) -> None:
    """Before a resumed run appends: a log written with other columns (an older version of this file)
    is rewritten with today's columns (missing values empty), and rows after `last_iteration` (the
    checkpoint's; a run killed between checkpoints logged them) are dropped, since they are redone."""
    path = pathlib.Path(path)
    if not path.is_file() or path.stat().st_size == 0:
        return
    with open(path, newline="") as f:
        header = next(csv.reader(f), [])
    rows = read_log(path)
    beyond = last_iteration is not None and any(int(r["iteration"]) > last_iteration for r in rows)
    if tuple(header) == CSV_FIELDS and not beyond:
        return
    if last_iteration is not None:
        rows = [r for r in rows if int(r["iteration"]) <= last_iteration]
    tmp = path.with_suffix(".csv.tmp")
    with open(tmp, "w", newline="") as f:
        writer = csv.DictWriter(f, CSV_FIELDS, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    tmp.replace(path)


def read_log(path) -> list:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def rolling_success(rows: list, primitive: str, window: int) -> tuple:
    """(iterations, success rate over the last `window` attempts of `primitive`) after each attempt."""
    outcomes, its, rates = [], [], []
    for row in rows:
        if row["primitive"] != primitive:
            continue
        outcomes.append(float(row["reward"]) > 0)
        its.append(int(row["iteration"]))
        rates.append(float(np.mean(outcomes[-window:])))
    return its, rates


def summary(path, window: int = 300) -> dict:
    rows = read_log(path) if pathlib.Path(path).is_file() else []
    out = {}
    for primitive in ("grasp", "push"):
        its, rates = rolling_success(rows, primitive, window)
        out[f"{primitive}_attempts"] = len(its)
        out[f"{primitive}_success_last_{window}"] = rates[-1] if rates else None
    return out


def plot_success(log_path, png_path, window: int = 300) -> None:
    """Paper Fig. 9: grasp (blue) and push (pink) success over the last `window` attempts."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = read_log(log_path)
    fig, ax = plt.subplots(figsize=(7, 4))
    for primitive, colour in (("grasp", "tab:blue"), ("push", "hotpink")):
        its, rates = rolling_success(rows, primitive, window)
        if its:
            ax.plot(its, rates, color=colour, label=f"{primitive} success")
    ax.set_xlabel("training iteration")
    ax.set_ylabel(f"success rate (last {window} attempts)")
    ax.set_ylim(0, 1)
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right")
    fig.tight_layout()
    tmp = pathlib.Path(png_path).with_suffix(".tmp.png")
    fig.savefig(tmp, dpi=100)
    plt.close(fig)
    tmp.replace(png_path)
