"""A target's crest (pose.ridge_direction) and the rule that grasps along it (rules.GraspAlongRidge)."""

import math

import numpy as np
import pytest
from height_scenes import (
    block_top,
    crop_observation,
    flat,
    half_cylinder,
    kept_by,
    leaning,
    lying_cylinder,
    prism,
    tilted,
)

from impurity_common import cell
from impurity_common.grid import HeightmapGrid
from impurity_policy.core.network import GRASP, PUSH
from impurity_policy.core.policy import MODE_OCCLUDED_REGION, MODE_TARGET
from impurity_policy.core.pose import closing_along, ridge_direction
from impurity_policy.core.rules import CANDIDATES, PRESETS, RuleParams

CROP, ROTATIONS = 112, cell.NUM_ROTATIONS
RESOLUTION = HeightmapGrid().resolution  # m per px


def _angle(a, b):
    return abs((a - b + math.pi / 2) % math.pi - math.pi / 2)


@pytest.mark.parametrize("crest_yaw", [0.0, 0.5, math.pi / 2, 2.5])
@pytest.mark.parametrize("profile", [prism, half_cylinder])
def test_the_crest_of_a_prism_or_half_cylinder_is_found_in_any_direction(profile, crest_yaw):
    height, mask = block_top(profile, crest_yaw)
    found = ridge_direction(height, mask, RESOLUTION, min_slope=0.4)
    assert found is not None and 0.0 <= found < math.pi
    assert _angle(found, crest_yaw) < math.radians(3)


@pytest.mark.parametrize("profile", [flat, tilted, leaning, lying_cylinder])
def test_a_flat_or_tilted_face_a_crest_off_the_middle_or_an_outline_standing_up_has_no_crest(profile):
    height, mask = block_top(profile, 0.7, height=0.045)  # a lying cylinder's outline 22.5 mm up
    assert ridge_direction(height, mask, RESOLUTION, min_slope=0.4) is None


def test_a_low_crest_or_a_mask_too_small_to_read_has_none():
    low, mask = block_top(prism, 0.7, height=0.004)  # rms slope about 0.3
    assert ridge_direction(low, mask, RESOLUTION, min_slope=0.4) is None
    assert ridge_direction(low, mask, RESOLUTION, min_slope=0.1) is not None
    height, _ = block_top(prism, 0.7)
    tiny = np.zeros((CROP, CROP), np.uint8)
    tiny[55:58, 55:58] = 255
    assert ridge_direction(height, tiny, RESOLUTION, min_slope=0.4) is None


def test_closing_along_keeps_the_axes_within_the_angle_of_the_crest_both_ways_round():
    kept = closing_along(math.pi / 2, math.radians(45), ROTATIONS)  # rotations 22.5 deg apart
    assert kept.shape == (ROTATIONS,)
    assert [r for r in range(ROTATIONS) if kept[r]] == [2, 3, 4, 5, 6, 10, 11, 12, 13, 14]
    assert closing_along(0.1, 0.0, ROTATIONS).sum() == 0  # no axis exactly on it
    assert closing_along(0.0, math.radians(90), ROTATIONS).all()


def _kept(obs, q=None):
    return kept_by("grasp_along_ridge", obs, q)


def test_grasp_along_ridge_keeps_grasps_closing_along_a_prisms_crest_and_every_push():
    obs = crop_observation(MODE_TARGET, *block_top(prism, crest_yaw=0.0))  # crest along +x (rotation 0)
    kept = _kept(obs)
    along = [r for r in range(ROTATIONS) if kept[r, GRASP].all()]
    assert along == [0, 1, 7, 8, 9, 15]  # within 35 deg of the crest, both ways round
    assert not kept[4, GRASP].any() and not kept[12, GRASP].any()  # closing across it
    assert kept[:, PUSH].all()


def test_grasp_along_ridge_gives_way_when_no_grasp_along_the_crest_is_left():
    obs = crop_observation(MODE_TARGET, *block_top(prism, crest_yaw=0.0))
    q = np.zeros((ROTATIONS, 2, CROP, CROP), np.float32)
    q[[0, 1, 7, 8, 9, 15], GRASP] = -np.inf  # nothing along the crest left by earlier rules
    assert _kept(obs, q)[4, GRASP].all()


def test_grasp_along_ridge_does_nothing_on_a_flat_target_or_without_a_target_in_view():
    assert _kept(crop_observation(MODE_TARGET, *block_top(flat))).all()
    height, mask = block_top(prism)
    assert _kept(crop_observation(MODE_OCCLUDED_REGION, height, np.full((CROP, CROP), 255, np.uint8))).all()
    assert _kept(crop_observation(MODE_TARGET, height, np.zeros((CROP, CROP), np.uint8))).all()


@pytest.mark.parametrize("field, value", [("ridge_max_angle_deg", 95.0), ("ridge_max_angle_deg", -1.0),
                                          ("ridge_min_slope", -0.1)])
def test_ridge_parameters_out_of_range_are_refused_by_name(field, value):
    with pytest.raises(ValueError, match=field):
        RuleParams(**{field: value})


def test_a_candidate_rule_is_in_no_preset_until_adopted():
    for name in CANDIDATES:
        assert all(name not in rules for rules in PRESETS.values())
