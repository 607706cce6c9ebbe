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

from impurity_common.grid import HeightmapGrid

from .checkpoint import load_network
from .decision import Decision, State, action_masks, best_action, epsilon_greedy
from .network import GRASP, PUSH, QNetwork, network_inputs
from .pose import ActionPose, PoseRules, action_pose
from .rules import MODE_NONE, MODE_OCCLUDED_REGION, MODE_TARGET, RulePipeline

__all__ = ["MODE_NONE", "MODE_OCCLUDED_REGION", "MODE_TARGET", "Choice", "NoActionError", "Observation",
           "Policy", "allowed_primitives", "q_maps_picture", "validate_observation"]


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
    grid: HeightmapGrid = HeightmapGrid()  # where the height map lies (from the Heightmap message)

    @property
    def state(self) -> State:
        return State(self.color_crop, self.height_crop, self.mask)

    @classmethod
    def from_attention(cls, output, height: np.ndarray, grid: HeightmapGrid = HeightmapGrid()) -> Observation:
        """From impurity_attention.core.attention.AttentionOutput and the full height map on `grid`."""
        return cls(int(output.mode), output.color_crop, output.height_crop, output.mask,
                   tuple(output.crop_origin), height, grid)


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


class Policy:
    """The push-grasp network and the test-time rules: one decision per observation.

    network: QNetwork (eval mode); pose_rules: pose.PoseRules (heights of pushes and grasps);
    grasp_needs_object: grasps only where the height crop shows something (as in training);
    rules: rules.RulePipeline (default: none, the paper's method: the network's argmax over the valid
    actions)."""

    def __init__(self, network: QNetwork, pose_rules: PoseRules = PoseRules(),
                 grasp_needs_object: bool = True, rules: RulePipeline | None = None):
        self.network = network.eval()
        self.device = next(network.parameters()).device  # the network's: load_network(device=...)
        self.pose_rules, self.grasp_needs_object = pose_rules, grasp_needs_object
        self.rules = rules if rules is not None else RulePipeline()

    @classmethod
    def from_checkpoint(cls, path, device: str = "cpu", **kwargs) -> Policy:
        """The checkpoint's network on `device` (network.resolve_device). CheckpointError when the file
        is missing or made for another network."""
        return cls(load_network(path, device=device), **kwargs)

    @torch.no_grad()
    def q_maps(self, obs: Observation) -> np.ndarray:
        """(R, 2, S, S) Q maps of the observation's crops."""
        inputs = network_inputs(obs.color_crop, obs.height_crop, obs.mask).to(self.device)
        return self.network.q_maps(inputs).cpu().numpy()

    def masks(self, obs: Observation) -> np.ndarray:
        """(2, S, S) bool: where each primitive may act at all (decision.action_masks)."""
        return action_masks(obs.state, obs.crop_origin, obs.height.shape, allowed_primitives(obs.mode),
                            self.grasp_needs_object)

    def decide(self, obs: Observation, q: np.ndarray | None = None, epsilon: float = 0.0,
               rng: np.random.Generator | None = None, restrict: np.ndarray | None = None) -> Choice:
        """Best (or epsilon-greedy) action for `obs` after the rules; `q` overrides the network's Q
        maps; `restrict` ((S, S) bool) keeps actions inside it where it leaves any (the S-VPG
        baseline). NoActionError when the observation cannot be acted on."""
        validate_observation(obs)
        allowed = allowed_primitives(obs.mode)
        size = obs.mask.shape[0]
        if size != self.network.config.crop_size:
            raise NoActionError(f"crops are {size} px, the network takes {self.network.config.crop_size}")
        q = self.q_maps(obs) if q is None else q
        masks = self.masks(obs)
        q = self.rules.apply(q, obs, masks, self.pose_rules, obs.grid)
        if restrict is not None:
            masks = np.stack([m & restrict if (m & restrict).any() else m for m in masks])
        if epsilon > 0.0 and rng is not None:
            decision = epsilon_greedy(q, masks, allowed, epsilon, rng)
        else:
            decision = best_action(q, masks, allowed)
        pose = action_pose(decision.primitive, decision.rotation, decision.pixel, obs.crop_origin,
                           obs.height, self.pose_rules, obs.grid)
        pose = self.rules.adjust_pose(pose, obs, self.pose_rules, obs.grid)
        return Choice(decision, pose, q, masks)

    def remember(self, choice_pose: ActionPose, height: np.ndarray, success: bool) -> None:
        """An executed action (its pose), the full height map it was decided on, and whether it
        succeeded (a grasp: lifted something), for the stateful rules (rules.TriedActions)."""
        self.rules.record(choice_pose.primitive, choice_pose.heightmap_pixel, choice_pose.rotation, height,
                          success)


def q_maps_picture(q: np.ndarray, masks: np.ndarray, decision: Decision | None = None,
                   tile: int = 56) -> np.ndarray:
    """RGB debug picture: 2 rows (push, grasp) x R columns of Q maps (masked pixels dark), one
    colour scale for all, the chosen action circled."""
    rotations, _, size, _ = q.shape
    finite = q[np.broadcast_to(masks[None], q.shape)]
    finite = finite[np.isfinite(finite)]  # rules.TriedActions rules actions out with -inf
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
