"""The pose rule grasp_square_to_faces (rules.GraspSquareToFaces): the chosen grasp on a flat
rectangular target top closes square on two of its faces, its yaw turned by less than a rotation step; the
decision itself stays the network's. Also the one-pixel clearance check it relies on (pose.grasp_clear_at)."""

import dataclasses
import math

import numpy as np
import pytest
from height_scenes import CROP, crop_observation

from impurity_common import cell
from impurity_policy.core.network import GRASP, PUSH, NetworkConfig, QNetwork
from impurity_policy.core.policy import MODE_OCCLUDED_REGION, MODE_TARGET, Policy
from impurity_policy.core.pose import (
    PoseRules,
    action_pose,
    grasp_clear_at,
    grasp_clearance,
    turn_onto,
)
from impurity_policy.core.rules import POSE, PRESETS, RuleParams, RulePipeline

RULE = "grasp_square_to_faces"
CENTRE = (CROP // 2, CROP // 2)  # crop pixel of the target's middle


def _top(yaw_deg: float, width_px: int = 20, disc: bool = False) -> np.ndarray:
    """(S, S) uint8 mask of a square top (or a disc) at the crop's centre, its first face normal at yaw."""
    rows, cols = np.mgrid[:CROP, :CROP].astype(np.float64) - CROP / 2
    if disc:
        return ((np.hypot(rows, cols) <= width_px / 2) * 255).astype(np.uint8)
    yaw = math.radians(yaw_deg)
    along = cols * math.cos(yaw) + rows * math.sin(yaw)
    across = -cols * math.sin(yaw) + rows * math.cos(yaw)
    return (((np.abs(along) <= width_px / 2) & (np.abs(across) <= width_px / 2)) * 255).astype(np.uint8)


def _observation(mask, mode=MODE_TARGET, height_crop=None):
    """A block 40 mm tall under the mask, flat on top unless `height_crop` (m) says otherwise."""
    if height_crop is None:
        height_crop = np.where(mask > 0, 0.04, 0.0).astype(np.float32)
    return crop_observation(mode, height_crop, mask)


def _adjusted(obs, rotation: int, primitive: int = GRASP, pixel=CENTRE, params: RuleParams = RuleParams()):
    pose = action_pose(primitive, rotation, pixel, obs.crop_origin, obs.height, PoseRules(), obs.grid)
    return pose, RulePipeline([RULE], params).adjust_pose(pose, obs, PoseRules(), obs.grid)


def _axis_offset_deg(a: float, b: float) -> float:
    """Degrees between two closing axes (an axis: a and a + pi close alike)."""
    return math.degrees(abs((a - b + math.pi / 2) % math.pi - math.pi / 2))


@pytest.mark.parametrize("rotation, face_deg", [(0, 10.0), (1, 10.0), (8, 10.0), (9, 10.0), (3, 70.0)])
def test_a_grasp_a_little_skewed_to_a_cubes_faces_turns_onto_the_nearer_face_normal(rotation, face_deg):
    obs = _observation(_top(face_deg))
    before, after = _adjusted(obs, rotation)
    normals = (math.radians(face_deg), math.radians(face_deg + 90.0))
    nearer = min(normals, key=lambda n: _axis_offset_deg(before.yaw, n))
    assert _axis_offset_deg(after.yaw, nearer) < 4.0  # face_direction reads the outline to a few degrees
    assert 0.0 < _axis_offset_deg(after.yaw, before.yaw) <= 22.5
    assert abs(math.cos(after.yaw - before.yaw) - 1.0) < 0.1  # a small turn, not a half turn
    # only the executed yaw changes: the decision's rotation, pixel and height stay the network's
    assert dataclasses.replace(after, yaw=before.yaw) == before


def test_a_grasp_nearer_a_diagonal_than_a_face_normal_is_left_as_chosen():
    obs = _observation(_top(10.0))
    before, after = _adjusted(obs, 2)  # 45 deg: 35 deg off one normal, 55 off the other
    assert after == before


def test_square_max_turn_deg_bounds_the_turn():
    obs = _observation(_top(10.0))
    before, after = _adjusted(obs, 1, params=RuleParams(square_max_turn_deg=10.0))  # 12.5 deg away
    assert after == before
    _, turned = _adjusted(obs, 1, params=RuleParams(square_max_turn_deg=15.0))
    assert turned != before


@pytest.mark.parametrize("case", ["push", "occluded_region", "off_the_mask", "disc", "half_cylinder"])
def test_it_leaves_pushes_heaps_grasps_off_the_target_and_round_or_curved_tops_alone(case):
    mask = _top(10.0, disc=case == "disc", width_px=24 if case == "disc" else 20)
    height_crop = None
    if case == "half_cylinder":  # a square outline whose top falls across its rows, radius 10 px
        rows = np.mgrid[:CROP, :CROP][0].astype(np.float64) - CROP / 2
        radius = 10 * 0.002
        across = np.clip(np.abs(rows), 0, 10) * 0.002
        height_crop = np.where(mask > 0, np.sqrt(np.maximum(radius ** 2 - across ** 2, 0.0)) + 0.002, 0.0)
        height_crop = height_crop.astype(np.float32)
    obs = _observation(mask, MODE_OCCLUDED_REGION if case == "occluded_region" else MODE_TARGET, height_crop)
    primitive = PUSH if case == "push" else GRASP
    pixel = (CENTRE[0] + 30, CENTRE[1]) if case == "off_the_mask" else CENTRE
    before, after = _adjusted(obs, 1, primitive, pixel)
    assert after == before


def test_a_turn_that_would_land_a_finger_on_a_neighbour_is_not_made():
    obs = _observation(_top(20.0))
    before = action_pose(GRASP, 0, CENTRE, obs.crop_origin, obs.height, PoseRules(), obs.grid)
    turned = math.radians(20.0)
    # a post 60 mm tall where the turned grasp's far pad lands, clear of the pad at yaw 0
    reach = (cell.GRASP_OPENING / 2 + cell.FINGER_THICKNESS / 2) / obs.grid.resolution
    row = before.heightmap_pixel[0] + round(reach * math.sin(turned))
    col = before.heightmap_pixel[1] + round(reach * math.cos(turned))
    obs.height[row - 1:row + 2, col - 1:col + 2] = 0.06
    assert grasp_clear_at(obs.height, before.heightmap_pixel, before.yaw, PoseRules(), obs.grid.resolution)
    assert not grasp_clear_at(obs.height, before.heightmap_pixel, turned, PoseRules(), obs.grid.resolution)
    assert RulePipeline([RULE]).adjust_pose(before, obs, PoseRules(), obs.grid) == before


def test_grasp_clear_at_agrees_with_grasp_clearance_at_the_rotation_yaws():
    obs = _observation(_top(20.0))
    obs.height[100:104, 150:160] = 0.07  # a neighbour beside the target
    clear = grasp_clearance(obs.height, obs.crop_origin, CROP)
    for rotation in range(cell.NUM_ROTATIONS):
        for crop_pixel in ((56, 56), (50, 62), (40, 90)):  # even and odd offsets from the crop origin
            heightmap_pixel = (crop_pixel[0] + 56, crop_pixel[1] + 56)
            assert grasp_clear_at(obs.height, heightmap_pixel, cell.rotation_yaw(rotation)) == \
                clear[rotation, crop_pixel[0], crop_pixel[1]], (rotation, crop_pixel)


def test_turn_onto_a_quarter_period_is_the_signed_turn_onto_the_nearer_face_normal():
    quarter = math.pi / 2  # a rectangle's two face normals count alike
    assert turn_onto(math.radians(30.0), math.radians(10.0), quarter) == pytest.approx(math.radians(-20.0))
    assert turn_onto(math.radians(80.0), math.radians(10.0), quarter) == pytest.approx(math.radians(20.0))
    assert turn_onto(math.radians(190.0), math.radians(10.0), quarter) == pytest.approx(0.0, abs=1e-9)
    for yaw in np.linspace(0.0, 2 * math.pi, 37):
        assert -math.pi / 4 <= turn_onto(yaw, 0.3, quarter) < math.pi / 4


def test_the_cell_executes_the_turned_yaw_and_keeps_the_networks_decision():
    obs = _observation(_top(10.0))
    q = np.zeros((cell.NUM_ROTATIONS, 2, CROP, CROP), np.float32)
    q[1, GRASP, CENTRE[0], CENTRE[1]] = 1.0
    small = NetworkConfig(stem_channels=8, growth=8, block_layers=(2, 2), head_channels=16)
    without = Policy(QNetwork(small), rules=RulePipeline.preset("cell", without=(RULE,))).decide(obs, q=q)
    shipped = Policy(QNetwork(small), rules=RulePipeline.preset("cell")).decide(obs, q=q)
    assert shipped.decision == without.decision
    assert shipped.pose.rotation == without.pose.rotation == 1
    assert without.pose.yaw == pytest.approx(cell.rotation_yaw(1))
    assert _axis_offset_deg(shipped.pose.yaw, math.radians(10.0)) < 4.0


def test_it_is_a_pose_rule_of_the_cell_preset_and_its_bound_is_checked_by_name():
    assert RULE in PRESETS["cell"] and RULE not in PRESETS["none"]
    assert RulePipeline([RULE]).rules[0].kind == POSE
    for value in (-1.0, 46.0):
        with pytest.raises(ValueError, match="square_max_turn_deg"):
            RuleParams(square_max_turn_deg=value)
