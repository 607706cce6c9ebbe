"""Fast-sim evaluation episodes (paper 6.1 metrics), no ROS: the same sensing as training, greedy
decisions, and the episode core's EpisodeTracker so the numbers count exactly as the episode node's.

    world = CellWorld(mode="floating")
    metrics = run_episode(world, make_agent("ours", checkpoint), EpisodeRequest("challenging", seed=7))

Held-out seeds: training scenes use seed * 1_000_003 + scene index (train.SCENE_SEED_STRIDE) with
small run seeds; evaluation uses EVAL_SEED_BASE + k, outside that pattern.
"""

from __future__ import annotations

from .agents import Action
from .episode import (
    DEFAULT_ACTIONS_PER_TARGET,
    DEFAULT_MAX_CONSECUTIVE_FAILURES,
    TERMINATION_NOTHING_LEFT,
    EpisodeRequest,
    EpisodeTracker,
    StepRecord,
    action_limit,
)

EVAL_SEED_BASE = 900_000_000
MODE_NAMES = {0: "NONE", 1: "TARGET", 2: "OCCLUDED_REGION"}


def run_episode(world, agent, request: EpisodeRequest,
                actions_per_target: int = DEFAULT_ACTIONS_PER_TARGET,
                max_consecutive_failures: int = DEFAULT_MAX_CONSECUTIVE_FAILURES) -> dict:
    """One episode on `world` (a ur5_driver_sim CellWorld) decided by `agent` (core.agents); returns
    the tracker's metrics plus termination_reason and completed (every target picked)."""
    from impurity_attention.core.attention import AttentionParams
    from impurity_attention.core.heightmap import HeightmapGrid

    from .train import sense

    world.reset_scene(request.scenario, seed=request.seed, num_targets=request.num_targets,
                      num_objects=request.num_objects, scene_file=request.scene_file or None)
    agent.reset(request.seed)
    projectors, params, grid = {}, AttentionParams(), HeightmapGrid()
    sensed = sense(world, projectors, agent.method, params, grid)
    total = sensed.truth.targets_remaining
    tracker = EpisodeTracker(f"{request.scenario}-{request.seed}", request, total,
                             action_limit(request, total, actions_per_target), max_consecutive_failures)
    reason = tracker.termination()
    while reason is None:
        action: Action | None = agent.act(sensed)
        if action is None:
            reason = TERMINATION_NOTHING_LEFT
            break
        pose = action.pose
        outcome = world.execute(action.kind, pose.x, pose.y, pose.z, pose.yaw)
        agent.observe_outcome(action, outcome)
        sensed = sense(world, projectors, agent.method, params, grid)
        tracker.record(StepRecord(
            step=tracker.actions + 1, attention_mode=MODE_NAMES.get(action.mode, "NONE"), kind=action.kind,
            position=(pose.x, pose.y, pose.z), yaw=pose.yaw, q_value=action.q_value,
            rotation_index=pose.rotation, pixel=pose.heightmap_pixel, decision_stamp_ns=0,
            motion_finished_ns=0, success=bool(outcome.success), target_grasped=bool(outcome.target_grasped),
            object_grasped=bool(outcome.success and action.kind == "grasp"),
            targets_remaining=sensed.truth.targets_remaining, message=outcome.message))
        reason = tracker.termination()
    metrics = tracker.metrics()
    return {**metrics, "termination_reason": reason,
            "completed": total > 0 and metrics["targets_picked"] == total}
