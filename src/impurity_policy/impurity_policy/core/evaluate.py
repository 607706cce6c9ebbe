"""Fast-sim evaluation episodes (paper 6.1 metrics), no ROS: the same sensing as training, greedy
decisions, and the episode core's EpisodeTracker so the numbers count exactly as the episode node's.

    world = CellWorld(mode="floating")
    metrics = run_episode(world, Policy.from_checkpoint(path), EpisodeRequest("challenging", seed=7))

Held-out seeds: training scenes use seed * 1_000_003 + scene index (train.SCENE_SEED_STRIDE) with
small run seeds; evaluation should use seeds outside that pattern (e.g. EVAL_SEED_BASE + k).
"""

from __future__ import annotations

from .episode import (
    DEFAULT_ACTIONS_PER_TARGET,
    DEFAULT_MAX_CONSECUTIVE_FAILURES,
    TERMINATION_NOTHING_LEFT,
    EpisodeRequest,
    EpisodeTracker,
    StepRecord,
    action_limit,
)
from .network import GRASP
from .policy import MODE_NONE, Policy

EVAL_SEED_BASE = 900_000_000
MODE_NAMES = {0: "NONE", 1: "TARGET", 2: "OCCLUDED_REGION"}


def run_episode(world, policy: Policy, request: EpisodeRequest, method: str = "ours",
                actions_per_target: int = DEFAULT_ACTIONS_PER_TARGET,
                max_consecutive_failures: int = DEFAULT_MAX_CONSECUTIVE_FAILURES) -> dict:
    """One episode on `world` (a ur5_driver_sim CellWorld); returns the tracker's metrics plus
    termination_reason."""
    from impurity_attention.core.attention import AttentionParams
    from impurity_attention.core.heightmap import HeightmapGrid

    from .train import sense

    world.reset_scene(request.scenario, seed=request.seed, num_targets=request.num_targets,
                      num_objects=request.num_objects, scene_file=request.scene_file or None)
    projectors, params, grid = {}, AttentionParams(), HeightmapGrid()
    obs, truth, _ = sense(world, projectors, method, params, grid)
    total = truth.targets_remaining
    tracker = EpisodeTracker(f"{request.scenario}-{request.seed}", request, total,
                             action_limit(request, total, actions_per_target), max_consecutive_failures)
    reason = tracker.termination()
    while reason is None:
        if obs.mode == MODE_NONE:
            reason = TERMINATION_NOTHING_LEFT
            break
        choice = policy.decide(obs)
        pose, decision = choice.pose, choice.decision
        kind = "grasp" if decision.primitive == GRASP else "push"
        outcome = world.execute(kind, pose.x, pose.y, pose.z, pose.yaw)
        next_obs, next_truth, _ = sense(world, projectors, method, params, grid)
        tracker.record(StepRecord(
            step=tracker.actions + 1, attention_mode=MODE_NAMES.get(obs.mode, "NONE"), kind=kind,
            position=(pose.x, pose.y, pose.z), yaw=pose.yaw, q_value=decision.q_value,
            rotation_index=pose.rotation, pixel=pose.heightmap_pixel, decision_stamp_ns=0,
            motion_finished_ns=0, success=bool(outcome.success), target_grasped=bool(outcome.target_grasped),
            object_grasped=bool(outcome.success and kind == "grasp"),
            targets_remaining=next_truth.targets_remaining, message=outcome.message))
        obs = next_obs
        reason = tracker.termination()
    return {**tracker.metrics(), "termination_reason": reason}
