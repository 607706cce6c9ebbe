"""Who decides in an evaluation episode (paper section 6.3): our policy and its ablations, each a
trained network, and the baselines VPG, S-VPG and an S-RGM-like heuristic. Pure: no ROS.

    agent = make_agent("s_rgm")                     # no network
    agent = make_agent("ours", checkpoint_path)     # any trained method's checkpoint
    action = agent.act(sensed)                      # train.Sensed -> Action, or None (nothing to act on)
    agent.observe_outcome(action, outcome)          # the sim's PrimitiveOutcome

S-VPG: VPG's Q maps with every action restricted to the saliency target mask (grown by a few pixels so
pushes may start beside the target); without a visible target it is plain VPG.

S-RGM (the paper uses BASNet saliency and a learned 5-D grasp rectangle; we have neither network):
the same saliency as ours, a grasp rectangle fitted to the salient target (its centre, closing across
its short side), a heuristic push that moves the target away from its neighbours after a grasp there
failed, and pushes through the densest cluster when no target is visible (paper: "a similar heuristic
mechanism as our proposed method to guide the robot to push the area with higher cluster density").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from impurity_common import cell
from impurity_common.grid import HeightmapGrid
from impurity_policy.core.decision import OBJECT_HEIGHT
from impurity_policy.core.network import GRASP, PUSH
from impurity_policy.core.policy import MODE_NONE, MODE_OCCLUDED_REGION, MODE_TARGET, Policy
from impurity_policy.core.pose import ActionPose, PoseRules, action_pose, yaw_to_rotation
from impurity_policy.core.rules import RulePipeline

NETWORK_METHODS = ("ours", "no_tsd", "no_oi", "no_t", "vpg", "s_vpg")
HEURISTIC_METHODS = ("s_rgm",)
EVAL_METHODS = ("ours", "vpg", "s_vpg", "s_rgm", "no_tsd", "no_oi", "no_t")
# The network each evaluation method runs (S-VPG is VPG's network with masked Q maps).
TRAINED_METHOD = {"ours": "ours", "no_tsd": "no_tsd", "no_oi": "no_oi", "no_t": "no_t", "vpg": "vpg",
                  "s_vpg": "vpg"}
SALIENCY_GROWTH_PX = 6  # S-VPG: the target mask grown by this much (pushes start next to the target)
RETRY_RADIUS_PX = 10  # S-RGM: a grasp this close to one that failed pushes instead


@dataclass
class Action:
    kind: str  # "push" | "grasp" (ur5_driver_sim primitive names)
    pose: ActionPose
    q_value: float  # NaN for the heuristic
    mode: int  # the attention mode the action answered


def primitive_name(primitive: int) -> str:
    return "grasp" if primitive == GRASP else "push"


class NetworkAgent:
    """A trained push-grasp network: ours, an ablation, or VPG."""

    def __init__(self, method: str, policy: Policy):
        if method not in NETWORK_METHODS:
            raise ValueError(f"'{method}' is not a network method ({', '.join(NETWORK_METHODS)})")
        self.name, self.policy = method, policy
        self.method = TRAINED_METHOD[method]  # how train.sense builds the observation
        self._decided_on = None  # the observation of the action under way

    def reset(self, seed: int) -> None:
        self.policy.rules.clear()

    def restriction(self, sensed) -> np.ndarray | None:
        attention = sensed.attention
        if self.name != "s_vpg" or attention.mode != MODE_TARGET or attention.target_mask is None:
            return None
        kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * SALIENCY_GROWTH_PX + 1,) * 2)
        grown = cv2.dilate(attention.target_mask.astype(np.uint8), kernel) > 0
        row0, col0 = sensed.obs.crop_origin
        size = sensed.obs.mask.shape[0]
        return grown[row0:row0 + size, col0:col0 + size]  # full-heightmap methods: origin (0, 0)

    def act(self, sensed) -> Action | None:
        if sensed.obs.mode == MODE_NONE:
            return None
        self._decided_on = sensed.obs
        choice = self.policy.decide(sensed.obs, restrict=self.restriction(sensed))
        return Action(primitive_name(choice.decision.primitive), choice.pose, choice.decision.q_value,
                      sensed.obs.mode)

    def observe_outcome(self, action: Action, outcome) -> None:
        """No learning during evaluation; the action is remembered for the stateful rules."""
        self.policy.remember(action.pose, self._decided_on.height, bool(outcome.success))


def grasp_rectangle(mask: np.ndarray) -> tuple | None:
    """The largest connected region of `mask` -> ((row, col) centre, closing yaw in base_link): the
    minimum-area rectangle's centre, closing across its short side. None for an empty mask."""
    count, labels, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    if count < 2:
        return None
    largest = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    points = np.argwhere(labels == largest)[:, ::-1].astype(np.float32)  # (col, row): x, y of the image
    (centre_col, centre_row), (width, height), angle = cv2.minAreaRect(points)
    # The rectangle's width side runs along `angle`; columns and rows map to base x and y without
    # mirroring (cell.pixel_to_base), so an image angle is a base_link yaw.
    closing = math.radians(angle) if width <= height else math.radians(angle) + math.pi / 2
    return (int(round(centre_row)), int(round(centre_col))), closing % math.pi


def _clip_pixel(row: float, col: float, shape) -> tuple:
    return (int(min(max(round(row), 0), shape[0] - 1)), int(min(max(round(col), 0), shape[1] - 1)))


def _disk(shape, centre, radius_px: float) -> np.ndarray:
    rows, cols = np.ogrid[:shape[0], :shape[1]]
    return (rows - centre[0]) ** 2 + (cols - centre[1]) ** 2 <= radius_px ** 2


class SalientGraspHeuristic:
    """The S-RGM-like baseline (module docstring)."""

    name = "s_rgm"
    method = "ours"  # sensing as ours: the same saliency and clusters

    def __init__(self, rules: PoseRules = PoseRules(), grid: HeightmapGrid = HeightmapGrid()):
        self.rules, self.grid, self.resolution = rules, grid, grid.resolution
        self.failed_grasps: list = []
        self.region_pushes = 0

    def reset(self, seed: int) -> None:
        self.failed_grasps, self.region_pushes = [], 0

    def _pose(self, primitive: int, pixel: tuple, yaw: float, height: np.ndarray) -> ActionPose:
        return action_pose(primitive, yaw_to_rotation(yaw), pixel, (0, 0), height, self.rules, self.grid)

    def _push_through(self, height: np.ndarray, centre: tuple, yaw: float, lead_px: float) -> ActionPose:
        """A push whose start lies `lead_px` behind `centre` along yaw, so it runs through it."""
        row = centre[0] - lead_px * math.sin(yaw)
        col = centre[1] - lead_px * math.cos(yaw)
        return self._pose(PUSH, _clip_pixel(row, col, height.shape), yaw, height)

    def _separating_push(self, target_mask: np.ndarray, height: np.ndarray) -> ActionPose:
        """Push the target away from the mass of its neighbours (towards the workspace centre when it
        has none)."""
        rows, cols = np.nonzero(target_mask)
        centre = (rows.mean(), cols.mean())
        radius_px = math.sqrt(rows.size / math.pi)
        reach = radius_px + cell.GRASP_OPENING / self.resolution
        neighbours = (height > OBJECT_HEIGHT) & ~target_mask & _disk(height.shape, centre, reach)
        if neighbours.any():
            n_rows, n_cols = np.nonzero(neighbours)
            away = (centre[0] - n_rows.mean(), centre[1] - n_cols.mean())
        else:
            away = ((height.shape[0] - 1) / 2 - centre[0], (height.shape[1] - 1) / 2 - centre[1])
        yaw = math.atan2(away[0], away[1]) if any(abs(v) > 1e-6 for v in away) else 0.0
        return self._push_through(height, centre, yaw, radius_px + 0.01 / self.resolution)

    def act(self, sensed) -> Action | None:
        attention, height = sensed.attention, np.nan_to_num(sensed.maps.height)
        target_mask = attention.target_mask
        if attention.mode == MODE_TARGET and target_mask is not None and target_mask.any():
            (row, col), yaw = grasp_rectangle(target_mask)
            tried = any(math.dist((row, col), failed) <= RETRY_RADIUS_PX for failed in self.failed_grasps)
            if not tried:
                return Action("grasp", self._pose(GRASP, (row, col), yaw, height), math.nan, MODE_TARGET)
            return Action("push", self._separating_push(target_mask, height), math.nan, MODE_TARGET)
        if attention.mode == MODE_OCCLUDED_REGION and attention.cluster is not None:
            yaw = (self.region_pushes * 5 % cell.NUM_ROTATIONS) * 2 * math.pi / cell.NUM_ROTATIONS
            self.region_pushes += 1
            lead_px = cell.PUSH_LENGTH / 2 / self.resolution
            pose = self._push_through(height, attention.cluster.centroid, yaw, lead_px)
            return Action("push", pose, math.nan, MODE_OCCLUDED_REGION)
        return None

    def observe_outcome(self, action: Action, outcome) -> None:
        if action.kind == "grasp" and not outcome.success:
            self.failed_grasps.append(action.pose.heightmap_pixel)
        elif action.kind == "push":
            self.failed_grasps = []  # the scene changed: grasp again


def make_agent(method: str, checkpoint=None, rules: str = "cell", device: str = "cpu"):
    """The agent for an evaluation method; network methods need their checkpoint's path and run with
    the rules preset `rules` (rules.PRESETS: "none" is the paper's argmax, "cell" our test-time rules)."""
    if method in HEURISTIC_METHODS:
        return SalientGraspHeuristic()
    if method not in NETWORK_METHODS:
        raise ValueError(f"unknown method '{method}' (expected one of {', '.join(EVAL_METHODS)})")
    if checkpoint is None:
        raise ValueError(f"method '{method}' needs a trained checkpoint")
    return NetworkAgent(method, Policy.from_checkpoint(checkpoint, device, rules=RulePipeline.preset(rules)))
