"""Attention output -> one primitive: the inference API shared by the policy node, the training loop
and the fast-sim evaluation.

    policy = Policy.from_checkpoint(path)
    choice = policy.decide(Observation(mode, color_crop, height_crop, mask, crop_origin, height))
    choice.pose  # ActionPose: primitive, rotation, heightmap pixel, x, y, z, yaw (base_link)

TARGET mode may push or grasp; OCCLUDED_REGION only pushes, at the cluster crop (paper section 4);
NONE has nothing to act on (NoActionError).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import torch

from impurity_common import cell

from .network import GRASP, PUSH, QNetwork, network_inputs, valid_action_mask
from .pose import (
    ActionPose,
    PoseRules,
    action_pose,
    grasp_clearance,
    heap_top,
    pixels_near,
    pushes_ending_inside,
    pushes_passing,
    pushes_starting_on_flank,
    target_core,
    target_on_top,
)
from .replay import State
from .tcdd import CHANGE_PIXELS_TAU, changed_pixels
from .trainer import Decision, action_masks, best_action, epsilon_greedy, load_network

MODE_NONE, MODE_TARGET, MODE_OCCLUDED_REGION = 0, 1, 2  # AttentionResult.MODE_*
FAILED_GRASPS_BEFORE_PUSH = 2  # TriedActionMemory: failed grasps in a row before a push is forced
OCCLUDED_PUSH_RADIUS_PX = 10  # ActionFilters: occluded-region pushes pass this close to the heap top
HEAP_SIGMA_PX = 6.0  # ActionFilters: smoothing (px) of the height crop before its top is taken
PUSH_END_MARGIN = 0.06  # m, ActionFilters: pushes end at least this far inside the workspace
OCCLUDED_PUSH_START_BAND = (0.5, 0.7)  # ActionFilters: occluded-region pushes start at this fraction of the
# heap top's height (pose.pushes_starting_on_flank)
TARGET_PUSH_RADIUS_PX = 12  # ActionFilters: with a target in view, pushes start this close to its mask
TARGET_ON_TOP_TOLERANCE = 0.005  # m, ActionFilters: grasps where the target is the local top
GRASP_CORE_DEPTH_PX = 1.0  # ActionFilters: grasps this close (px) to the target mask's deepest inside


class NoActionError(ValueError):
    """The attention module found nothing to act on, or the input cannot be used."""


def allowed_primitives(mode: int) -> tuple:
    if mode == MODE_TARGET:
        return (PUSH, GRASP)
    if mode == MODE_OCCLUDED_REGION:
        return (PUSH,)
    raise NoActionError(f"attention mode {mode} has nothing to act on (no target, no occluded region)")


@dataclass
class Observation:
    mode: int
    color_crop: np.ndarray  # (S, S, 3) uint8
    height_crop: np.ndarray  # (S, S) float32 m
    mask: np.ndarray  # (S, S) uint8
    crop_origin: tuple  # heightmap (row0, col0) of crop pixel (0, 0)
    height: np.ndarray  # (H, W) full height map, m

    @property
    def state(self) -> State:
        return State(self.color_crop, self.height_crop, self.mask)

    @classmethod
    def from_attention(cls, output, height: np.ndarray) -> Observation:
        """From impurity_attention.core.attention.AttentionOutput and the full height map."""
        return cls(int(output.mode), output.color_crop, output.height_crop, output.mask,
                   tuple(output.crop_origin), height)


@dataclass
class Choice:
    decision: Decision
    pose: ActionPose
    q_maps: np.ndarray  # (R, 2, S, S)
    masks: np.ndarray  # (2, S, S)


def validate_observation(obs: Observation) -> None:
    size = obs.mask.shape[0] if obs.mask.ndim == 2 else -1
    if size < 8 or obs.mask.shape != (size, size):
        raise NoActionError(f"mask must be square (S, S), got {obs.mask.shape}")
    if obs.color_crop.shape != (size, size, 3) or obs.color_crop.dtype != np.uint8:
        raise NoActionError(f"colour crop must be ({size}, {size}, 3) uint8, got "
                            f"{obs.color_crop.shape} {obs.color_crop.dtype}")
    if obs.height_crop.shape != (size, size):
        raise NoActionError(f"height crop must be ({size}, {size}), got {obs.height_crop.shape}")
    if obs.height.ndim != 2:
        raise NoActionError(f"height map must be 2-D, got {obs.height.shape}")
    if not np.all(np.isfinite(obs.height_crop)):
        raise NoActionError("height crop has NaN or inf values")


@dataclass(frozen=True)
class ActionFilters:
    """Geometric rules applied to the Q maps at test time; each rules actions out, none adds one. The
    network, trained on random scenes only, values some actions the cell can tell are hopeless:
      - finger_clearance: a grasp whose open finger pads would land on something (pose.grasp_clearance):
        the guarded descent stops above the object, so only a push can help (wedged targets);
      - grasp_on_target: a grasp off the attended target's mask: the cell picks impurities only, and a
        grasp beside a blocked target otherwise lifts its neighbour (a false reject);
      - occluded_push_radius_px: with no target in view, a push whose path does not pass within this
        many pixels of the crop's highest pile (pose.heap_top): scatter the heap that can hide a target
        (paper section 4) instead of trimming its rim. 0 turns it off;
      - occluded_push_start_band: with no target in view, a push that does not start on the heap's
        flank, where the local top is (low, high) times the heap top's height
        (pose.pushes_starting_on_flank): from the top a push only sweeps off what lies on the heap.
        Kept only where it leaves a push; None turns it off;
      - target_push_radius_px: with a target in view, a push that starts farther than this from its
        mask (pose.pixels_near): the pushes that free a target start at it; the net, trained on random
        scenes only, also values pushes across the rest of the crop. Kept only where it leaves a push;
        None turns it off;
      - target_on_top_tolerance: a grasp where something other than the target is the local top
        (pose.target_on_top): the grasp closes at that height and lifts the object lying on the target.
        Kept only where it leaves a grasp; None turns it off;
      - grasp_core_depth_px: a grasp off the middle of the target, where its mask is less deep (distance
        to the mask's edge) than this many pixels below its deepest (pose.target_core). A rule, not a
        preference: when no grasp is left there, the policy pushes (grasps off the middle lifted the
        neighbour between the fingers and the target). Applied after the preferences. None turns it off.
      - push_end_margin: a push that ends less than this (m) inside the workspace: what the fingers
        shove ahead lands beyond the end, and a target pushed out of the workspace is lost to the
        cell (invisible scenes lost 11 of 40 targets that way). None turns it off.
    """

    finger_clearance: bool = True
    grasp_on_target: bool = True
    occluded_push_radius_px: int = OCCLUDED_PUSH_RADIUS_PX
    heap_sigma_px: float = HEAP_SIGMA_PX
    push_end_margin: float | None = PUSH_END_MARGIN
    occluded_push_start_band: tuple | None = OCCLUDED_PUSH_START_BAND
    target_push_radius_px: int | None = TARGET_PUSH_RADIUS_PX
    target_on_top_tolerance: float | None = TARGET_ON_TOP_TOLERANCE
    grasp_core_depth_px: float | None = GRASP_CORE_DEPTH_PX


NO_FILTERS = ActionFilters(finger_clearance=False, grasp_on_target=False, occluded_push_radius_px=0,
                           push_end_margin=None, occluded_push_start_band=None, target_push_radius_px=None,
                           target_on_top_tolerance=None, grasp_core_depth_px=None)


class Policy:
    def __init__(self, network: QNetwork, rules: PoseRules = PoseRules(), grasp_needs_object: bool = True,
                 filters: ActionFilters = ActionFilters()):
        self.network = network.eval()
        self.rules, self.grasp_needs_object, self.filters = rules, grasp_needs_object, filters

    @classmethod
    def from_checkpoint(cls, path, **kwargs) -> Policy:
        return cls(load_network(path), **kwargs)

    @torch.no_grad()
    def q_maps(self, obs: Observation) -> np.ndarray:
        return self.network.q_maps(network_inputs(obs.color_crop, obs.height_crop, obs.mask)).numpy()

    def masks(self, obs: Observation) -> np.ndarray:
        return action_masks(obs.state, obs.crop_origin, obs.height.shape, allowed_primitives(obs.mode),
                            self.grasp_needs_object)

    def decide(self, obs: Observation, q: np.ndarray | None = None, epsilon: float = 0.0,
               rng: np.random.Generator | None = None, grid: dict | None = None,
               restrict: np.ndarray | None = None) -> Choice:
        """Best (or epsilon-greedy) action for `obs`; `grid` overrides the heightmap geometry passed
        to pose.action_pose (resolution, x_min, y_min, table_z) when a message carries its own;
        `restrict` ((S, S) bool) keeps actions inside it where it leaves any (the S-VPG baseline)."""
        validate_observation(obs)
        allowed = allowed_primitives(obs.mode)
        size = obs.mask.shape[0]
        if size != self.network.config.crop_size:
            raise NoActionError(f"crops are {size} px, the network takes {self.network.config.crop_size}")
        q = self.q_maps(obs) if q is None else q
        masks = self.masks(obs)
        q = self.filtered(q, obs, grid)
        if restrict is not None:
            masks = np.stack([m & restrict if (m & restrict).any() else m for m in masks])
        if epsilon > 0.0 and rng is not None:
            decision = epsilon_greedy(q, masks, allowed, epsilon, rng)
        else:
            decision = best_action(q, masks, allowed)
        pose = action_pose(decision.primitive, decision.rotation, decision.pixel, obs.crop_origin,
                           obs.height, self.rules, **(grid or {}))
        return Choice(decision, pose, q, masks)

    def filtered(self, q: np.ndarray, obs: Observation, grid: dict | None = None) -> np.ndarray:
        """The Q maps with the actions that `self.filters` rules out at -inf (a copy when any is);
        `grid` as in `decide`."""
        filters, size, rotations = self.filters, obs.mask.shape[0], q.shape[0]
        grid = grid or {}
        resolution = grid.get("resolution", cell.HEIGHTMAP_RESOLUTION)
        ruled_out = np.zeros(q.shape, dtype=bool)
        target = obs.mask > 0
        target_in_view = obs.mode == MODE_TARGET and target.any()
        if obs.mode == MODE_TARGET:
            if filters.finger_clearance:
                clear = grasp_clearance(obs.height, obs.crop_origin, size, self.rules, rotations, resolution)
                ruled_out[:, GRASP] |= ~clear
            if filters.grasp_on_target and target_in_view:
                ruled_out[:, GRASP] |= ~target[None]
        elif obs.mode == MODE_OCCLUDED_REGION:
            top = heap_top(obs.height_crop, valid_action_mask(size), filters.heap_sigma_px)
            if filters.occluded_push_radius_px > 0:
                ruled_out[:, PUSH] |= ~pushes_passing(top, size, filters.occluded_push_radius_px, rotations,
                                                      resolution)
        if filters.push_end_margin is not None and PUSH in allowed_primitives(obs.mode):
            origin = {k: v for k, v in grid.items() if k in ("x_min", "y_min")}
            inside = pushes_ending_inside(obs.crop_origin, size, filters.push_end_margin, rotations,
                                          resolution, **origin)
            ruled_out[:, PUSH] |= ~inside
        # Preferences: each narrows a primitive's actions only where it leaves one (counting those
        # already at -inf in `q`, e.g. by TriedActionMemory).
        preferred = []
        if obs.mode == MODE_OCCLUDED_REGION and filters.occluded_push_start_band is not None:
            band = filters.occluded_push_start_band
            preferred.append((PUSH, pushes_starting_on_flank(obs.height_crop, top, band,
                                                             self.rules.local_radius_px)))
        if target_in_view:
            if filters.target_on_top_tolerance is not None:
                preferred.append((GRASP, target_on_top(obs.height_crop, obs.mask, self.rules.local_radius_px,
                                                       filters.target_on_top_tolerance)))
            if filters.target_push_radius_px is not None:
                preferred.append((PUSH, pixels_near(obs.mask, filters.target_push_radius_px)))
        valid = self.masks(obs) if preferred else None
        for primitive, pixels in preferred:
            left = ~ruled_out[:, primitive] & np.isfinite(q[:, primitive])
            if (left & (pixels & valid[primitive])[None]).any():
                ruled_out[:, primitive] |= ~pixels[None]
        if target_in_view and filters.grasp_core_depth_px is not None:
            ruled_out[:, GRASP] |= ~target_core(obs.mask, filters.grasp_core_depth_px)[None]
        return np.where(ruled_out, -np.inf, q).astype(q.dtype) if ruled_out.any() else q


class TriedActionMemory:
    """A greedy policy repeats itself: after a grasp that closed on nothing or a push that moved
    nothing the state is about the same, so the argmax is too (invisible scenes showed the same push
    ten times over). Executed actions are ruled out within `radius_px` (a push: its direction; a grasp:
    its rotation and the opposite one, one closing axis):
      - a failed grasp until a push rearranges the scene or a grasp lifts something;
      - a push while the scene is unchanged since it was decided (at most `changed_pixels` height
        pixels moved: the paper's change rule, tcdd.changed_pixels);
      - every grasp once `failed_grasps_before_push` grasps in a row have failed: a wedged target
        needs a separating push, and the net under-values it in packings it rarely saw in training
        (challenging scenes ended in five failed grasps with no push between them).
    Test time only (training explores with epsilon instead), every network method alike."""

    def __init__(self, radius_px: int = 10, changed_pixels: int = CHANGE_PIXELS_TAU,
                 failed_grasps_before_push: int = FAILED_GRASPS_BEFORE_PUSH):
        self.radius_px, self.changed_pixels = radius_px, changed_pixels
        self.failed_grasps_before_push = failed_grasps_before_push  # 0: never force a push
        self.tried: list = []  # (primitive, row, col, rotation, height map decided on) in heightmap pixels

    def clear(self) -> None:
        self.tried = []

    def record(self, primitive: int, heightmap_pixel, rotation: int, height: np.ndarray,
               success: bool) -> None:
        """An executed action, the full height map it was decided on and whether it succeeded (a grasp:
        lifted something)."""
        if primitive == GRASP and success:
            self.clear()
            return
        if primitive == PUSH:
            self.tried = [entry for entry in self.tried if entry[0] == PUSH]
        self.tried.append((int(primitive), int(heightmap_pixel[0]), int(heightmap_pixel[1]), int(rotation),
                           np.array(height, dtype=np.float32)))

    def _unchanged(self, before: np.ndarray, now: np.ndarray) -> bool:
        return before.shape == now.shape and changed_pixels(before, now) <= self.changed_pixels

    def suppress(self, q: np.ndarray, obs: Observation) -> np.ndarray:
        """A copy of the Q maps (R, 2, S, S) with the remembered actions at -inf."""
        self.tried = [entry for entry in self.tried
                      if entry[0] == GRASP or self._unchanged(entry[4], obs.height)]
        if not self.tried:
            return q
        q = q.copy()
        failed_grasps = sum(entry[0] == GRASP for entry in self.tried)
        if 0 < self.failed_grasps_before_push <= failed_grasps:
            q[:, GRASP] = -np.inf
        rotations, _, size, _ = q.shape
        rows, cols = np.ogrid[:size, :size]
        row0, col0 = obs.crop_origin
        for primitive, row, col, rotation, _ in self.tried:
            near = (rows - (row - row0)) ** 2 + (cols - (col - col0)) ** 2 <= self.radius_px ** 2
            same = (rotation,) if primitive == PUSH else (rotation, rotation + rotations // 2)
            for r in same:
                q[r % rotations, primitive][near] = -np.inf
        return q


def q_maps_picture(q: np.ndarray, masks: np.ndarray, decision: Decision | None = None,
                   tile: int = 56) -> np.ndarray:
    """RGB debug picture: 2 rows (push, grasp) x R columns of Q maps (masked pixels dark), one
    colour scale for all, the chosen action circled."""
    rotations, _, size, _ = q.shape
    finite = q[np.broadcast_to(masks[None], q.shape)]
    finite = finite[np.isfinite(finite)]  # TriedActionMemory rules actions out with -inf
    low, high = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    scale = max(high - low, 1e-6)
    picture = np.zeros((2 * tile, rotations * tile, 3), dtype=np.uint8)
    for primitive in (PUSH, GRASP):
        for rotation in range(rotations):
            values = np.clip((q[rotation, primitive] - low) / scale, 0, 1)
            heat = cv2.applyColorMap((values * 255).astype(np.uint8), cv2.COLORMAP_JET)[..., ::-1]
            heat = np.where(masks[primitive][..., None], heat, heat // 4)
            if decision is not None and decision.primitive == primitive and decision.rotation == rotation:
                cv2.circle(heat, (decision.pixel[1], decision.pixel[0]), 6, (255, 255, 255), 2)
            picture[primitive * tile:(primitive + 1) * tile, rotation * tile:(rotation + 1) * tile] = \
                cv2.resize(heat, (tile, tile), interpolation=cv2.INTER_AREA)
    return picture
