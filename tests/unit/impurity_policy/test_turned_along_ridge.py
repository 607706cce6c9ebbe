"""The candidate pose rule grasp_turned_along_ridge (rules.GraspTurnedAlongRidge): the chosen grasp on a
target whose top has a crest (a half cylinder lying flat, an upright prism) closes along the crest, its yaw
turned by up to 90 deg; the decision itself stays the network's. Also the turn's one shared code path with
grasp_square_to_faces (rules.PoseRule)."""

import dataclasses
import math

import numpy as np
import pytest
from height_scenes import CROP, block_top, crop_observation, flat, half_cylinder, lying_cylinder, prism

from impurity_common import cell
from impurity_policy.core.network import GRASP, PUSH, NetworkConfig, QNetwork
from impurity_policy.core.policy import MODE_OCCLUDED_REGION, MODE_TARGET, Policy
from impurity_policy.core.pose import PoseRules, action_pose, grasp_clear_at
from impurity_policy.core.rules import CANDIDATES, POSE, PRESETS, RULES, RuleParams, RulePipeline

RULE = "grasp_turned_along_ridge"
CENTRE = (CROP // 2, CROP // 2)  # crop pixel of the block's middle


def _axis_offset_deg(a: float, b: float) -> float:
    """Degrees between two closing axes (an axis: a and a + pi close alike)."""
    return math.degrees(abs((a - b + math.pi / 2) % math.pi - math.pi / 2))


def _observation(profile, crest_deg: float, mode=MODE_TARGET, height: float = 0.036):
    return crop_observation(mode, *block_top(profile, math.radians(crest_deg), height=height))


def _adjusted(obs, rotation: int, primitive: int = GRASP, pixel=CENTRE, params: RuleParams = RuleParams()):
    pose = action_pose(primitive, rotation, pixel, obs.crop_origin, obs.height, PoseRules(), obs.grid)
    return pose, RulePipeline([RULE], params).adjust_pose(pose, obs, PoseRules(), obs.grid)


@pytest.mark.parametrize("profile", [half_cylinder, prism])
@pytest.mark.parametrize("rotation, crest_deg", [(4, 0.0), (3, 0.0), (12, 0.0), (0, 70.0), (7, 10.0)])
def test_a_grasp_across_a_crest_turns_to_close_along_it(profile, rotation, crest_deg):
    obs = _observation(profile, crest_deg)
    before, after = _adjusted(obs, rotation)
    assert _axis_offset_deg(after.yaw, math.radians(crest_deg)) < 3.0  # ridge_direction reads it to ~3 deg
    assert _axis_offset_deg(before.yaw, math.radians(crest_deg)) > 5.0
    # only the executed yaw changes: the decision's rotation, pixel and height stay the network's
    assert dataclasses.replace(after, yaw=before.yaw) == before


def test_the_turn_is_the_shorter_way_round_onto_the_crest_axis():
    obs = _observation(half_cylinder, 0.0)
    before, after = _adjusted(obs, 3)  # 67.5 deg: 67.5 deg back onto 0, not 112.5 on to 180
    turn = (after.yaw - before.yaw + math.pi) % (2 * math.pi) - math.pi
    assert turn == pytest.approx(math.radians(-67.5), abs=math.radians(3.0))


@pytest.mark.parametrize("case", ["push", "occluded_region", "off_the_mask", "flat_top", "lying_cylinder"])
def test_it_leaves_pushes_heaps_grasps_off_the_target_flat_tops_and_full_cylinders_alone(case):
    profile = {"flat_top": flat, "lying_cylinder": lying_cylinder}.get(case, half_cylinder)
    height = 0.045 if case == "lying_cylinder" else 0.036  # a lying cylinder's outline stands 22.5 mm up
    mode = MODE_OCCLUDED_REGION if case == "occluded_region" else MODE_TARGET
    obs = _observation(profile, 0.0, mode, height)
    if case == "occluded_region":
        obs = crop_observation(mode, obs.height_crop, np.full((CROP, CROP), 255, np.uint8))
    primitive = PUSH if case == "push" else GRASP
    pixel = (CENTRE[0] + 30, CENTRE[1]) if case == "off_the_mask" else CENTRE
    before, after = _adjusted(obs, 4, primitive, pixel)
    assert after == before


def test_a_turn_that_would_land_a_finger_on_a_neighbour_is_not_made():
    obs = _observation(half_cylinder, 0.0)
    before = action_pose(GRASP, 4, CENTRE, obs.crop_origin, obs.height, PoseRules(), obs.grid)
    # a post 60 mm tall where the turned grasp's pad lands (along the crest, +x), clear of the pads at 90 deg
    reach = (cell.GRASP_OPENING / 2 + cell.FINGER_THICKNESS / 2) / obs.grid.resolution
    row, col = before.heightmap_pixel[0], before.heightmap_pixel[1] + round(reach)
    obs.height[row - 1:row + 2, col - 1:col + 2] = 0.06
    assert grasp_clear_at(obs.height, before.heightmap_pixel, before.yaw, PoseRules(), obs.grid.resolution)
    assert not grasp_clear_at(obs.height, before.heightmap_pixel, 0.0, PoseRules(), obs.grid.resolution)
    assert RulePipeline([RULE]).adjust_pose(before, obs, PoseRules(), obs.grid) == before


def test_the_two_pose_rules_never_turn_the_same_grasp():
    """grasp_square_to_faces reads flat tops (slope <= corner_max_slope 0.3), this rule crests (slope >=
    ridge_min_slope 0.4): on a half cylinder only this one turns, on a flat square only the other."""
    both = RulePipeline(["grasp_square_to_faces", RULE])
    for profile, expected in ((half_cylinder, RULE), (flat, "grasp_square_to_faces")):
        top = block_top(profile, math.radians(10.0), width_px=24, length_px=24)
        obs = crop_observation(MODE_TARGET, *top)
        pose = action_pose(GRASP, 1, CENTRE, obs.crop_origin, obs.height, PoseRules(), obs.grid)
        alone = RulePipeline([expected]).adjust_pose(pose, obs, PoseRules(), obs.grid)
        assert alone != pose
        assert both.adjust_pose(pose, obs, PoseRules(), obs.grid) == alone


def test_the_cell_preset_with_it_executes_the_turned_yaw_and_keeps_the_networks_decision():
    obs = _observation(half_cylinder, 0.0)
    q = np.zeros((cell.NUM_ROTATIONS, 2, CROP, CROP), np.float32)
    q[4, GRASP, CENTRE[0], CENTRE[1]] = 1.0
    small = NetworkConfig(stem_channels=8, growth=8, block_layers=(2, 2), head_channels=16)
    shipped = Policy(QNetwork(small), rules=RulePipeline.preset("cell")).decide(obs, q=q)
    rules = RulePipeline(RulePipeline.preset("cell").names + (RULE,))
    candidate = Policy(QNetwork(small), rules=rules).decide(obs, q=q)
    assert candidate.decision == shipped.decision
    assert _axis_offset_deg(shipped.pose.yaw, math.pi / 2) < 1e-6
    assert _axis_offset_deg(candidate.pose.yaw, 0.0) < 3.0


def test_it_is_a_pose_candidate_in_no_preset():
    assert RULES[RULE].kind == POSE and RULE in CANDIDATES
    assert all(RULE not in names for names in PRESETS.values())
