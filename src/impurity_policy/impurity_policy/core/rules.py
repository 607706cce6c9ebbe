"""Test-time rules: what the cell knows about its gripper and its job that the network, trained in
random scenes, does not. Each rule is a small named unit that keeps some actions and rules the others
out (sets their Q value to -inf); none ever adds an action. They are applied in one place
(`RulePipeline.apply`) in one order, `RULE_ORDER`:

  1. tried_actions                 mask  an executed action that changed nothing is not tried again (a
                                         greedy policy repeats itself; VPG's change test, change.py)
  2. finger_clearance              mask  grasps whose open finger pads or palm would land on something (the
                                         gripper's guarded descent stops there: cell.GRASP_OPENING, ...)
  3. grasp_on_target               mask  with a target in view, grasps on its mask only (the cell picks
                                         impurities; a grasp beside one lifts its neighbour)
  4. occluded_push_through_heap    mask  no target in view: pushes that pass near the heap's top (paper
                                         section 4: scatter the heap that can hide a target)
  5. push_end_inside               mask  pushes that end inside the workspace, with a margin (a target
                                         pushed out is lost to the cell)
  6. occluded_push_off_edge        pref  no target in view: pushes that do not head for a near edge and end
                                         near it (400 invisible tuning episodes: completion 90.8 -> 94.5 %)
  7. occluded_push_start_on_flank  pref  no target in view: pushes that start on the heap's flank (from its
                                         top a push only sweeps what lies on it)
  8. grasp_where_target_on_top     pref  grasps where the target is the local top (a grasp closes at the
                                         local top: under a slab it lifts the slab)
  9. target_push_start_near        pref  with a target in view, pushes that start next to it
 10. grasp_at_target_core          mask  grasps at the middle of the target (a little wider where no grasp is
                                         left at its very middle); after the preferences, so that when no
                                         grasp is left there the policy pushes (grasps 10 mm off a free 26 mm
                                         cube closed on nothing)
 11. grasp_before_push             mask  with a target in view and a grasp on it left whose Q is high, no
                                         push (the network values pushes above grasps that would pick the
                                         target: in packed scenes it pushed around graspable targets)
 12. grasp_square_to_faces         pose  with a target whose top is a flat rectangle, the chosen grasp turns
                                         its closing axis onto the nearer face normal (tuning seeds,
                                         invisible scenes: +1.6 points of pooled grasp success)

Each rule's place in the preset `cell` is re-checked, leaving one out at a time on tuning seeds and
palettes, by `python scripts/check_rules.py`.

A *mask* always applies. A *preference* applies only where it leaves at least one action of its
primitive (counting what the rules before it and -inf Q values already took away); otherwise it
gives way. A *pose* rule rules nothing out: it changes how the chosen action is executed
(`RulePipeline.adjust_pose`, after the decision), never which action is chosen.
The geometry of each rule is a pure function in `pose`; its thresholds are RuleParams.

Presets (`PRESETS`, node parameter `rules`, `--rules` in evaluation and training):
  none  the paper's method: the network's argmax over the valid actions, no rule at all;
  cell  every rule above (the cell's default).

Shapes: Q maps (R, 2, S, S) (R rotations, 0 = push, 1 = grasp, S x S crop); a rule keeps a bool
array that broadcasts to (R, S, S) for one primitive.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass

import numpy as np

from impurity_common import cell
from impurity_common.enums import AttentionMode
from impurity_common.grid import HeightmapGrid
from impurity_common.parameters import InvalidParameter, check_fields, increasing, param

from .change import CHANGE_PIXELS_TAU, changed_pixels
from .network import GRASP, PUSH, valid_action_mask
from .pose import (
    ActionPose,
    PoseRules,
    face_direction,
    grasp_clear_at,
    grasp_clearance,
    heap_top,
    heightmap_to_crop,
    pixels_near,
    pushes_ending_inside,
    pushes_not_toward_near_edge,
    pushes_passing,
    pushes_starting_on_flank,
    target_core,
    target_on_top,
    top_slope,
    turn_onto,
)

MODE_NONE, MODE_TARGET, MODE_OCCLUDED_REGION = (AttentionMode.NONE, AttentionMode.TARGET,
                                                AttentionMode.OCCLUDED_REGION)
MASK, PREFERENCE, POSE = "mask", "preference", "pose"


@dataclass(frozen=True)
class RuleParams:
    """Every rule's thresholds, in one place; the policy node's parameters of the same names."""

    tried_action_radius_px: int = param(10, "tried_actions: heightmap px around an executed action that are "
                                        "ruled out", low=0, high=224)
    changed_pixels: int = param(CHANGE_PIXELS_TAU, "tried_actions: a scene with at most this many changed "
                                "pixels (change.changed_pixels) counts as unchanged (VPG's change threshold)",
                                low=0)
    failed_grasps_before_push: int = param(2, "tried_actions: failed grasps in a row after which every grasp "
                                           "is ruled out until a push", low=1)
    heap_sigma_px: float = param(6.0, "Occluded rules: Gaussian sigma (px) of the height crop before the "
                                 "heap's top is taken", low=0.0, high=56.0)
    occluded_push_radius_px: int = param(10, "occluded_push_through_heap: pushes pass this close (px) to the "
                                         "crop's highest pile", low=1, high=224)
    push_end_margin: float = param(0.06, "push_end_inside: pushes end at least this far inside the "
                                   "workspace (m)", low=0.0, high=0.2)
    occluded_push_edge_margin: float = param(0.12, "occluded_push_off_edge: pushes that head for a workspace "
                                             "edge end at least this far from it (m; on 400 invisible tuning "
                                             "episodes, completion 90.8 -> 94.5 %)", low=0.0, high=0.3)
    occluded_push_start_band: tuple[float, ...] = param(
        (0.5, 0.7), "occluded_push_start_on_flank: [low, high] local top at the push start, as a fraction of "
        "the pile's top", length=2, low=0.0, high=1.0, check=increasing)
    target_on_top_tolerance: float = param(0.005, "grasp_where_target_on_top: the target is the local top "
                                           "give or take this (m)", low=0.0, high=0.1)
    target_push_radius_px: int = param(12, "target_push_start_near: pushes start this close (px) to the "
                                       "target's mask", low=0, high=224)
    grasp_core_depth_px: float = param(1.0, "grasp_at_target_core: grasps this close (px) to the depth of "
                                       "the target mask's deepest point", low=0.0, high=56.0)
    grasp_core_fallback_depth_px: float = param(
        2.0, "grasp_at_target_core: where the rules before it leave no grasp within grasp_core_depth_px, "
        "grasps this close (px) to the deepest point (measured by `python -m impurity_learning.eval_cli "
        "--scene-set paper --split tuning --methods ours --rules cell`, 20 episodes: challenging "
        "efficiency 44.4 -> 49.7 %, grasp success 95.8 -> 94.2 %; 3 px: 52.4 % and 88.3 %)",
        low=0.0, high=56.0)
    grasp_before_push_q: float = param(
        0.6, "grasp_before_push: with a target in view, no push while a grasp on it with at least this Q "
        "value is left (measured by `python -m impurity_learning.eval_cli --scene-set paper --split tuning "
        "--methods ours --rules cell`, 20 episodes: efficiency random / challenging / invisible 52.3 / "
        "28.7 / 15.2 -> 77.5 / 44.4 / 17.5 %, grasp success 98.3 / 95.0 / 98.3 -> 96.7 / 95.8 / 98.3 %; "
        "0.5 and 0.55: invisible grasp success 93.3 and 95.0 %)")
    face_min_fill: float = param(0.85, "grasp_square_to_faces: the share of its least-area rectangle the "
                                 "target's mask fills for its top to count as a rectangle "
                                 "(pose.face_direction; a cube or slab seen from above fills 0.9-1.0, a disc "
                                 "0.79)", low=0.0, high=1.0)
    corner_max_slope: float = param(0.3, "grasp_square_to_faces: the most root-mean-square slope (m/m) of a "
                                    "top that counts as flat (pose.top_slope: flat tops 0.05-0.12, a half "
                                    "cylinder lying down 0.6, an upright prism 1.3)", low=0.0)
    square_max_turn_deg: float = param(22.5, "grasp_square_to_faces: a grasp on a flat rectangular target "
                                       "top turns its closing axis at most this far (deg) onto a face normal "
                                       "(22.5: every axis nearer a face normal than a diagonal)",
                                       low=0.0, high=45.0)

    def __post_init__(self):
        check_fields(self)
        if self.grasp_core_fallback_depth_px < self.grasp_core_depth_px:
            raise InvalidParameter("grasp_core_fallback_depth_px",
                                   f"is below grasp_core_depth_px ({self.grasp_core_depth_px})")


class RuleContext:
    """What the rules of one decision look at; shared quantities are computed once, on first use.

    obs: policy.Observation; rotations: R of the Q maps; grid: the heightmap's geometry."""

    def __init__(self, obs, rotations: int, pose_rules: PoseRules, params: RuleParams, grid: HeightmapGrid,
                 q: np.ndarray | None = None, valid: np.ndarray | None = None):
        self.obs, self.rotations, self.pose_rules, self.params, self.grid = (
            obs, rotations, pose_rules, params, grid)
        self.size = obs.mask.shape[0]
        self.q, self.valid = q, valid  # the decision's Q maps (R, 2, S, S) and valid actions (2, S, S)
        self.ruled_out = None if q is None else np.zeros(q.shape, dtype=bool)  # by the rules applied so far

    def left(self, primitive: int) -> np.ndarray:
        """(R, S, S) bool: the valid actions of `primitive` with a finite Q value that the rules applied so
        far leave (none without Q maps)."""
        if self.q is None:
            return np.zeros((self.rotations, self.size, self.size), dtype=bool)
        return ~self.ruled_out[:, primitive] & self.valid[primitive][None] & np.isfinite(self.q[:, primitive])

    def best_left(self, primitive: int) -> float:
        """The highest Q value among `left(primitive)`; -inf when none is left."""
        left = self.left(primitive)
        return float(self.q[:, primitive][left].max()) if left.any() else -math.inf

    @functools.cached_property
    def target(self) -> np.ndarray:
        return self.obs.mask > 0

    @functools.cached_property
    def target_in_view(self) -> bool:
        return self.obs.mode == MODE_TARGET and bool(self.target.any())

    @functools.cached_property
    def flat_rectangle_face(self) -> float | None:
        """A face normal (rad, pose.face_direction) of the target in view when its top outline is a rectangle
        (`face_min_fill`) and its top is flat (pose.top_slope at most `corner_max_slope`); None otherwise."""
        if not self.target_in_view:
            return None
        face = face_direction(self.obs.mask, self.params.face_min_fill)
        if face is None:
            return None
        slope = top_slope(self.obs.height_crop, self.obs.mask, self.grid.resolution)
        return None if slope is None or slope > self.params.corner_max_slope else face

    @functools.cached_property
    def heap_top(self) -> tuple:
        return heap_top(self.obs.height_crop, valid_action_mask(self.size), self.params.heap_sigma_px)


@dataclass(frozen=True)
class Keep:
    """A rule's verdict for one primitive: the actions it keeps, bool, broadcastable to (R, S, S)."""

    primitive: int
    actions: np.ndarray


class Rule:
    """One named rule; `keeps` returns its verdicts, or () where it does not apply."""

    name = ""
    kind = MASK

    def keeps(self, ctx: RuleContext) -> tuple:
        raise NotImplementedError


class TriedActions(Rule):
    """A greedy policy repeats itself: after a grasp that closed on nothing or a push that moved
    nothing the state is about the same, so the argmax is too. Executed actions are ruled out within
    `tried_action_radius_px` (a push: its direction; a grasp: its rotation and the opposite one, one
    closing axis):
      - a failed grasp until a push rearranges the scene or a grasp lifts something;
      - a push while the scene is unchanged since it was decided (at most `changed_pixels` height
        pixels moved: the paper's change rule, change.changed_pixels);
      - every grasp once `failed_grasps_before_push` grasps in a row have failed: a wedged target needs
        a separating push, and the net under-values it in packings it rarely saw in training."""

    name = "tried_actions"

    def __init__(self, params: RuleParams):
        self.params = params
        self.tried: list = []  # (primitive, row, col, rotation, height map decided on) in heightmap pixels

    def clear(self) -> None:
        self.tried = []

    def record(self, primitive: int, heightmap_pixel, rotation: int, height: np.ndarray,
               success: bool) -> None:
        """An executed action, the full height map (H, W) it was decided on, and whether it succeeded (a
        grasp: lifted something)."""
        if primitive == GRASP and success:
            self.clear()
            return
        if primitive == PUSH:
            self.tried = [entry for entry in self.tried if entry[0] == PUSH]
        self.tried.append((int(primitive), int(heightmap_pixel[0]), int(heightmap_pixel[1]), int(rotation),
                           np.array(height, dtype=np.float32)))

    def _unchanged(self, before: np.ndarray, now: np.ndarray) -> bool:
        return before.shape == now.shape and changed_pixels(before, now) <= self.params.changed_pixels

    def keeps(self, ctx: RuleContext) -> tuple:
        self.tried = [entry for entry in self.tried
                      if entry[0] == GRASP or self._unchanged(entry[4], ctx.obs.height)]
        if not self.tried:
            return ()
        rotations, size = ctx.rotations, ctx.size
        keep = np.ones((2, rotations, size, size), dtype=bool)
        failed_grasps = sum(entry[0] == GRASP for entry in self.tried)
        if failed_grasps >= self.params.failed_grasps_before_push:
            keep[GRASP] = False
        rows, cols = np.ogrid[:size, :size]
        row0, col0 = ctx.obs.crop_origin
        radius = self.params.tried_action_radius_px
        for primitive, row, col, rotation, _ in self.tried:
            near = (rows - (row - row0)) ** 2 + (cols - (col - col0)) ** 2 <= radius ** 2
            same = (rotation,) if primitive == PUSH else (rotation, rotation + rotations // 2)
            for r in same:
                keep[primitive, r % rotations][near] = False
        return Keep(PUSH, keep[PUSH]), Keep(GRASP, keep[GRASP])


class FingerClearance(Rule):
    """A grasp whose open finger pads would land on something (pose.grasp_clearance): the guarded
    descent stops above the object, so only a push can help (wedged targets)."""

    name = "finger_clearance"

    def keeps(self, ctx: RuleContext) -> tuple:
        if ctx.obs.mode != MODE_TARGET:
            return ()
        clear = grasp_clearance(ctx.obs.height, ctx.obs.crop_origin, ctx.size, ctx.pose_rules, ctx.rotations,
                                ctx.grid.resolution)
        return (Keep(GRASP, clear),)


class GraspOnTarget(Rule):
    """A grasp off the attended target's mask: the cell picks impurities only, and a grasp beside a
    blocked target otherwise lifts its neighbour (a false reject)."""

    name = "grasp_on_target"

    def keeps(self, ctx: RuleContext) -> tuple:
        return (Keep(GRASP, ctx.target[None]),) if ctx.target_in_view else ()


class OccludedPushThroughHeap(Rule):
    """No target in view: a push that does not pass within `occluded_push_radius_px` of the crop's
    highest pile (pose.heap_top) only trims the heap's rim; scatter the heap that can hide a target
    (paper section 4)."""

    name = "occluded_push_through_heap"

    def keeps(self, ctx: RuleContext) -> tuple:
        if ctx.obs.mode != MODE_OCCLUDED_REGION:
            return ()
        return (Keep(PUSH, pushes_passing(ctx.heap_top, ctx.size, ctx.params.occluded_push_radius_px,
                                          ctx.rotations, ctx.grid.resolution)),)


class PushEndInside(Rule):
    """A push that ends less than `push_end_margin` inside the workspace: what the fingers shove ahead
    lands beyond the end, and a target pushed out of the workspace is lost to the cell."""

    name = "push_end_inside"

    def keeps(self, ctx: RuleContext) -> tuple:
        if ctx.obs.mode not in (MODE_TARGET, MODE_OCCLUDED_REGION):
            return ()
        inside = pushes_ending_inside(ctx.obs.crop_origin, ctx.size, ctx.params.push_end_margin,
                                      ctx.rotations, ctx.grid)
        return (Keep(PUSH, inside),)


class OccludedPushOffEdge(Rule):
    """No target in view: a push that heads for a workspace edge (pose.pushes_not_toward_near_edge) and
    ends less than `occluded_push_edge_margin` from it. A hidden target in the heap is shoved on beyond the
    push's end, and one pushed out of the workspace is lost to the cell; heaps by an edge are pushed along
    it or inwards instead. On 400 invisible tuning episodes it raised completion from 90.8 to 94.5 %."""

    name = "occluded_push_off_edge"
    kind = PREFERENCE

    def keeps(self, ctx: RuleContext) -> tuple:
        if ctx.obs.mode != MODE_OCCLUDED_REGION:
            return ()
        return (Keep(PUSH, pushes_not_toward_near_edge(ctx.obs.crop_origin, ctx.size,
                                                       ctx.params.occluded_push_edge_margin, ctx.rotations,
                                                       ctx.grid)),)


class OccludedPushStartOnFlank(Rule):
    """No target in view: a push that does not start on the heap's flank, where the local top is
    `occluded_push_start_band` times the heap top's height (pose.pushes_starting_on_flank): from the
    top a push only sweeps off what lies on the heap."""

    name = "occluded_push_start_on_flank"
    kind = PREFERENCE

    def keeps(self, ctx: RuleContext) -> tuple:
        if ctx.obs.mode != MODE_OCCLUDED_REGION:
            return ()
        return (Keep(PUSH, pushes_starting_on_flank(ctx.obs.height_crop, ctx.heap_top,
                                                    ctx.params.occluded_push_start_band,
                                                    ctx.pose_rules.local_radius_px)),)


class GraspWhereTargetOnTop(Rule):
    """A grasp where something other than the target is the local top (pose.target_on_top): the grasp
    closes at that height and lifts the object lying on the target."""

    name = "grasp_where_target_on_top"
    kind = PREFERENCE

    def keeps(self, ctx: RuleContext) -> tuple:
        if not ctx.target_in_view:
            return ()
        return (Keep(GRASP, target_on_top(ctx.obs.height_crop, ctx.obs.mask, ctx.pose_rules.local_radius_px,
                                          ctx.params.target_on_top_tolerance)),)


class TargetPushStartNear(Rule):
    """With a target in view, a push that starts farther than `target_push_radius_px` from its mask
    (pose.pixels_near): the pushes that free a target start at it."""

    name = "target_push_start_near"
    kind = PREFERENCE

    def keeps(self, ctx: RuleContext) -> tuple:
        if not ctx.target_in_view:
            return ()
        return (Keep(PUSH, pixels_near(ctx.obs.mask, ctx.params.target_push_radius_px)),)


class GraspAtTargetCore(Rule):
    """A grasp off the middle of the target, where its mask is less deep than `grasp_core_depth_px`
    below its deepest (pose.target_core); where the rules before it leave no grasp there (the fingers
    would land on a close neighbour, or it was tried), `grasp_core_fallback_depth_px` below it. A mask
    after the preferences: when no grasp is left there either, the policy pushes (grasps off the middle
    lifted the neighbour between the fingers and the target)."""

    name = "grasp_at_target_core"

    def keeps(self, ctx: RuleContext) -> tuple:
        if not ctx.target_in_view:
            return ()
        core = target_core(ctx.obs.mask, ctx.params.grasp_core_depth_px)
        if not (ctx.left(GRASP) & core[None]).any():
            core = target_core(ctx.obs.mask, ctx.params.grasp_core_fallback_depth_px)
        return (Keep(GRASP, core[None]),)


class GraspBeforePush(Rule):
    """With a target in view, a push while a grasp on the target is left (after every grasp rule before
    this one) whose Q value is at least `grasp_before_push_q`. With a target in view the network often
    values a push above a grasp that would pick the target (in packed scenes it pushed around targets it
    could have grasped). Where the grasp rules leave no grasp on the target (a wedged target, failed
    grasps) or only poor ones, the policy still pushes."""

    name = "grasp_before_push"

    def keeps(self, ctx: RuleContext) -> tuple:
        if not ctx.target_in_view or ctx.best_left(GRASP) < ctx.params.grasp_before_push_q:
            return ()
        return (Keep(PUSH, np.zeros((1, 1, 1), dtype=bool)),)


class GraspSquareToFaces(Rule):
    """A pose rule: it rules nothing out (`keeps` gives ()); after the decision the chosen grasp, on a target
    whose top outline is a rectangle (pose.face_direction) and whose top is flat (pose.top_slope at most
    `corner_max_slope`), its pixel on the target's mask, closes square on two faces: its closing axis turns
    onto the nearer face normal (pose.turn_onto, period pi/2) when the turn is non-zero and at most
    `square_max_turn_deg`, and the turned grasp is clear (pose.grasp_clear_at). The pixel, the rotation index
    and the decision stay the network's; only the executed yaw (ActionPose.yaw) changes, by less than the
    network's 22.5 deg rotation step. In the simulator upright cubes slipped from a sixth of the grasps
    closing 7.5-22.5 deg skewed to their faces and a twentieth of those closing within 7.5 deg."""

    name = "grasp_square_to_faces"
    kind = POSE
    period = math.pi / 2  # rad: a rectangle's two face normals turn a grasp alike

    def keeps(self, ctx: RuleContext) -> tuple:
        return ()

    def adjust(self, ctx: RuleContext, pose: ActionPose) -> ActionPose:
        """`pose` with its yaw turned, or `pose` itself where the rule does not apply. The cheap tests come
        first: the target's top is read only for a grasp on the target."""
        if pose.primitive != GRASP or not ctx.target_in_view:
            return pose
        row, col = heightmap_to_crop(pose.heightmap_pixel, ctx.obs.crop_origin)
        if not (0 <= row < ctx.size and 0 <= col < ctx.size) or not ctx.target[row, col]:
            return pose
        face = ctx.flat_rectangle_face
        if face is None:
            return pose
        turn = turn_onto(pose.yaw, face, self.period)
        if abs(turn) < 1e-6 or abs(turn) > math.radians(ctx.params.square_max_turn_deg) + 1e-9:
            return pose
        yaw = (pose.yaw + turn) % (2.0 * math.pi)
        if not grasp_clear_at(ctx.obs.height, pose.heightmap_pixel, yaw, ctx.pose_rules, ctx.grid.resolution):
            return pose
        return dataclasses.replace(pose, yaw=yaw)


RULES = {rule.name: rule for rule in (TriedActions, FingerClearance, GraspOnTarget, OccludedPushThroughHeap,
                                      PushEndInside, OccludedPushOffEdge, OccludedPushStartOnFlank,
                                      GraspWhereTargetOnTop, TargetPushStartNear, GraspAtTargetCore,
                                      GraspBeforePush, GraspSquareToFaces)}
RULE_ORDER = tuple(RULES)
PRESETS = {"none": (), "cell": RULE_ORDER}


class RulePipeline:
    """The rules of one policy, applied in RULE_ORDER. Stateful rules (tried_actions) remember the
    episode's executed actions: `record` after each, `clear` at an episode's start."""

    def __init__(self, names=(), params: RuleParams = RuleParams()):
        names = tuple(names)
        unknown = sorted(set(names) - set(RULES))
        if unknown:
            raise ValueError(f"unknown rule(s) {', '.join(unknown)} (known: {', '.join(RULE_ORDER)})")
        self.params = params
        self.rules = [RULES[name](params) if name == TriedActions.name else RULES[name]()
                      for name in RULE_ORDER if name in set(names)]

    @classmethod
    def preset(cls, name: str, params: RuleParams = RuleParams(), without=()) -> RulePipeline:
        """A named preset (PRESETS), optionally without some of its rules."""
        if name not in PRESETS:
            raise ValueError(f"unknown rules preset '{name}' (known: {', '.join(PRESETS)})")
        unknown = sorted(set(without) - set(RULES))
        if unknown:
            raise ValueError(f"unknown rule(s) {', '.join(unknown)} (known: {', '.join(RULE_ORDER)})")
        return cls([rule for rule in PRESETS[name] if rule not in set(without)], params)

    @property
    def names(self) -> tuple:
        return tuple(rule.name for rule in self.rules)

    def clear(self) -> None:
        for rule in self.rules:
            if hasattr(rule, "clear"):
                rule.clear()

    def record(self, primitive: int, heightmap_pixel, rotation: int, height: np.ndarray,
               success: bool) -> None:
        """An executed action (see TriedActions.record); a no-op without stateful rules."""
        for rule in self.rules:
            if hasattr(rule, "record"):
                rule.record(primitive, heightmap_pixel, rotation, height, success)

    def apply(self, q: np.ndarray, obs, valid: np.ndarray, pose_rules: PoseRules,
              grid: HeightmapGrid) -> np.ndarray:
        """The Q maps (R, 2, S, S) with every action the rules take away at -inf (a copy when any is;
        `q` itself otherwise). `valid` (2, S, S): where each primitive may act at all."""
        if not self.rules:
            return q
        ctx = RuleContext(obs, q.shape[0], pose_rules, self.params, grid, q, valid)
        ruled_out = ctx.ruled_out  # grows as the rules apply; rules read it through ctx.left
        for rule in self.rules:
            for verdict in rule.keeps(ctx):
                p = verdict.primitive
                if rule.kind == PREFERENCE and not (ctx.left(p) & verdict.actions).any():
                    continue  # it would leave nothing: it gives way
                ruled_out[:, p] |= ~verdict.actions
        return np.where(ruled_out, -np.inf, q).astype(q.dtype) if ruled_out.any() else q

    def adjust_pose(self, pose: ActionPose, obs, pose_rules: PoseRules, grid: HeightmapGrid) -> ActionPose:
        """The chosen action's pose after the pose rules (kind POSE, in RULE_ORDER); `pose` itself
        without them."""
        adjusting = [rule for rule in self.rules if rule.kind == POSE]
        if not adjusting:
            return pose
        ctx = RuleContext(obs, cell.NUM_ROTATIONS, pose_rules, self.params, grid)
        for rule in adjusting:
            pose = rule.adjust(ctx, pose)
        return pose
