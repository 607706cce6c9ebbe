"""Fast-sim evaluation episodes (paper 6.1 metrics), no ROS: the simulator as a cell of the one picking
loop (impurity_policy.core.picking), with the same sensing as training and greedy decisions, so the
numbers count exactly as the episode node's.

    world = CellWorld(mode="floating")
    metrics = run_episode(world, make_agent("ours", checkpoint), EpisodeRequest("challenging", seed=7))
    # As a real cell counts: no target count; attention's NONE ends it, grasps are judged by
    # perception (impurity_policy.core.verdict), the truth is recorded beside the verdicts.
    metrics = run_episode(world, agent, request, by_perception=True)

Held-out seeds: training scenes use seed * 1_000_003 + scene index (train.SCENE_SEED_STRIDE) with
small run seeds; evaluation uses EVAL_SEED_BASE + k, outside that pattern.
"""

from __future__ import annotations

from impurity_attention.core.attention import AttentionParams
from impurity_attention.core.product_memory import known_product
from impurity_common.enums import AttentionMode
from impurity_common.grid import HeightmapGrid
from impurity_policy.core import picking
from impurity_policy.core.episode import EpisodeRequest
from impurity_policy.core.verdict import full_mask

from .perception_figures import product_lifted
from .splits import EVAL_SEED_BASE  # noqa: F401 (re-exported: the split lives in splits.py)
from .train import sense, sensed_from


class SimCell:
    """The fast simulator (a ur5_driver_sim CellWorld) and an evaluation agent (agents.py) behind the
    picking loop's cell interface. Ground truth counts the targets (CellWorld.ground_truth: in the
    workspace, and outside it apart, as sim_cell's services count them): this is the simulator's
    privilege, and the only place where truth meets the loop."""

    def __init__(self, world, agent, attention_params: AttentionParams = AttentionParams(),
                 grid: HeightmapGrid = HeightmapGrid(), piece_heights: tuple | None = None):
        self.world, self.agent, self.attention_params, self.grid = world, agent, attention_params, grid
        self.piece_heights = piece_heights  # m, the scenes' piece heights (CellWorld.reset_scene); None: ours
        self._projectors: dict = {}
        self._sensed = None
        self.known_product = None  # product_memory.known_product of a view the loop handed over, or None

    def _sense(self):
        self._sensed = sense(self.world, self._projectors, self.agent.method, self.attention_params,
                             self.grid, known_product=self.known_product)

    def reset(self, request: EpisodeRequest) -> picking.Targets:
        self.world.reset_scene(request.scenario, seed=request.seed, num_targets=request.num_targets,
                               num_objects=request.num_objects, scene_file=request.scene_file or None,
                               palette=request.palette, piece_heights=self.piece_heights)
        self.agent.reset(request.seed)
        self.known_product = None
        self._sense()
        return self._targets()

    def know_product(self, view: picking.View | None) -> None:
        """The loop's word that `view` (one of this cell's) shows product only: the following views are
        attended with its colours as the known product (picking's module docstring), until the next reset;
        None forgets it."""
        if view is None:
            self.known_product = None
            return
        maps = view.source.maps
        self.known_product = known_product(maps.color, maps.height, self.attention_params, self.grid)

    def look_closer(self) -> picking.View:
        """The loop's stall look: the current view attended again with closer=True (the scene has not moved
        since it was rendered), with the known product; it replaces the current view."""
        self._sensed = sensed_from(self._sensed.maps, self._sensed.truth, self.agent.method,
                                   self.attention_params, self.grid, self.known_product, closer=True)
        return self.observe()

    def observe(self) -> picking.View:
        return picking.View(self._sensed.obs.mode, self._sensed.maps.color, self._sensed)

    def decide(self, view: picking.View) -> picking.Action | None:
        action = self.agent.act(view.source)
        if action is None:
            return None
        pose = action.pose
        return picking.Action(action.kind, (pose.x, pose.y, pose.z), pose.yaw, action.q_value, pose.rotation,
                              pose.heightmap_pixel, action.mode, source=action)

    def execute(self, action: picking.Action) -> picking.Outcome:
        x, y, z = action.position
        outcome = self.world.execute(action.kind, x, y, z, action.yaw)
        self.agent.observe_outcome(action.source, outcome)
        self._sense()
        return picking.Outcome(bool(outcome.success), bool(outcome.target_grasped), outcome.message)

    def targets_remaining(self, outcome: picking.Outcome, before: int) -> picking.Targets:
        return self._targets()

    def _targets(self) -> picking.Targets:
        truth = self._sensed.truth
        return picking.Targets(truth.targets_remaining, truth.targets_out_of_workspace)


class PerceptionSimCell(SimCell):
    """SimCell counted as a real cell counts (picking.run_episode's perception loop): reset
    gives no target count, each view carries the height map and, for TARGET, the attended target's mask
    (the crop mask placed in the full map, as ros_cell places AttentionResult.mask) and its saliency
    contrast; a motion reports what a real arm knows (gripper opening, holding). The simulator's truth
    reaches the loop only through truth(), which it records beside the verdicts and never steers by."""

    def reset(self, request: EpisodeRequest) -> None:
        super().reset(request)
        return None

    def observe(self) -> picking.View:
        sensed = self._sensed
        attention, height = sensed.attention, sensed.maps.height
        mask, score = None, float("inf")
        if int(attention.mode) == AttentionMode.TARGET:
            placed = full_mask(attention.mask > 0, attention.crop_origin, height.shape)
            mask, score = (placed if placed.any() else None), float(attention.score)
        heap = float(attention.score) if int(attention.mode) == AttentionMode.OCCLUDED_REGION else 0.0
        return picking.View(sensed.obs.mode, sensed.maps.color, sensed, height, mask, score,
                            bool(attention.last_look), heap_height=heap)

    def execute(self, action: picking.Action) -> picking.Outcome:
        x, y, z = action.position
        outcome = self.world.execute(action.kind, x, y, z, action.yaw)
        self.agent.observe_outcome(action.source, outcome)
        self._sense()
        return picking.Outcome(bool(outcome.success), False, outcome.message,
                               motion_completed=bool(outcome.motion_completed),
                               gripper_opening=float(outcome.gripper_opening), holding=bool(outcome.holding))

    def truth(self) -> picking.Truth:
        truth = self._sensed.truth
        return picking.Truth(truth.targets_remaining, truth.targets_out_of_workspace, truth.targets_removed)


def _reraise(error: Exception) -> None:
    raise error  # an evaluation episode that fails stops the run instead of counting as an episode


def run_episode(world, agent, request: EpisodeRequest,
                limits: picking.EpisodeLimits = picking.EpisodeLimits(), recorder=None,
                by_perception: bool = False, piece_heights: tuple | None = None) -> dict:
    """One episode on `world` (a ur5_driver_sim CellWorld) decided by `agent` (agents.py); returns the
    loop's summary: the metrics (targets_outside among them) plus termination_reason and completed
    (every target picked). by_perception: counted as a real cell counts (PerceptionSimCell); the summary
    then holds counted_by "perception", the truth audit (picking.truth_audit) and truth_product_lifted
    (perception_figures.product_lifted: grasps that lifted something but no target). piece_heights (m,
    lowest and highest): the scene's pieces stand upright with heights in that range (a scene set's,
    ur5_driver_sim.core.scenes.SCENE_SETS)."""
    cell = (PerceptionSimCell if by_perception else SimCell)(world, agent, piece_heights=piece_heights)
    steps: list = []
    summary = picking.run_episode(cell, request, f"{request.scenario}-{request.seed}", limits,
                                  recorder=recorder, on_error=_reraise,
                                  on_step=steps.append if by_perception else None)
    if by_perception:
        summary["truth_product_lifted"] = product_lifted(steps)
    return summary
