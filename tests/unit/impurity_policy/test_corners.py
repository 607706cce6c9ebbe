"""A rectangular target top's faces (pose.face_direction) and the candidate rule that grasps across its
corners rather than a little skewed to its faces (rules.GraspAcrossCorners)."""

import math

import numpy as np
import pytest
from height_scenes import crop_observation, kept_by

from impurity_common import cell
from impurity_common.grid import HeightmapGrid
from impurity_policy.core.network import GRASP, PUSH
from impurity_policy.core.policy import MODE_OCCLUDED_REGION, MODE_TARGET
from impurity_policy.core.pose import closing_off_faces, face_direction, top_slope
from impurity_policy.core.rules import CANDIDATES, PRESETS, RuleParams

CROP, ROTATIONS = 112, cell.NUM_ROTATIONS


def _top(yaw, width_px=20, length_px=20, shape="rectangle"):
    """(S, S) uint8 mask of a target's top at the crop's centre: a rectangle whose first side runs along
    `yaw` (rad, +col = +x, +row = +y), or a disc of diameter width_px."""
    rows, cols = np.mgrid[:CROP, :CROP].astype(np.float64) - CROP / 2
    if shape == "disc":
        inside = np.hypot(rows, cols) <= width_px / 2
    else:
        along = cols * math.cos(yaw) + rows * math.sin(yaw)
        across = -cols * math.sin(yaw) + rows * math.cos(yaw)
        inside = (np.abs(along) <= length_px / 2) & (np.abs(across) <= width_px / 2)
    return (inside * 255).astype(np.uint8)


def _folded(a, b):
    quarter = math.pi / 2
    return abs((a - b + quarter / 2) % quarter - quarter / 2)


@pytest.mark.parametrize("yaw_deg", [0.0, 10.0, 30.0, 44.0, 67.0, 81.0])
def test_the_faces_of_a_square_or_rectangular_top_are_found_at_any_yaw(yaw_deg):
    for width, length in ((20, 20), (16, 28)):
        face = face_direction(_top(math.radians(yaw_deg), width, length), min_fill=0.85)
        assert face is not None and 0.0 <= face < math.pi / 2
        assert _folded(face, math.radians(yaw_deg)) < math.radians(4.0)  # a face normal, to a few degrees


def test_a_round_top_a_sliver_or_no_mask_has_no_faces():
    assert face_direction(_top(0.0, 24, shape="disc"), min_fill=0.85) is None  # a disc fills pi/4 of it
    assert face_direction(_top(0.3, 3, 5), min_fill=0.85) is None  # fewer cells than FACE_MIN_CELLS
    assert face_direction(np.zeros((CROP, CROP), np.uint8), min_fill=0.85) is None


def test_closing_off_faces_keeps_the_axes_at_least_the_skew_from_both_normals():
    kept = closing_off_faces(0.0, math.radians(20.0), ROTATIONS)  # faces square to the rotation grid
    assert kept.shape == (ROTATIONS,)
    assert [r for r in range(ROTATIONS) if kept[r]] == [1, 2, 3, 5, 6, 7, 9, 10, 11, 13, 14, 15]
    for yaw in np.linspace(0.0, math.pi / 2, 19):  # at any yaw, two closing axes in four are kept
        assert closing_off_faces(yaw, math.radians(20.0), ROTATIONS).sum() >= ROTATIONS // 2
    assert closing_off_faces(0.3, 0.0, ROTATIONS).all()


def _observation(mode, mask):
    """A flat-topped block 40 mm tall under the mask."""
    return crop_observation(mode, np.where(mask > 0, 0.04, 0.0).astype(np.float32), mask)


def _kept(obs, q=None):
    return kept_by("grasp_across_corners", obs, q)


def test_grasps_closing_a_little_skewed_to_a_cubes_faces_are_ruled_out_and_every_push_kept():
    mask = _top(math.radians(10.0))
    kept = _kept(_observation(MODE_TARGET, mask))
    skewed = closing_off_faces(face_direction(mask, 0.85), math.radians(20.0), ROTATIONS)
    assert [bool(kept[r, GRASP].all()) for r in range(ROTATIONS)] == list(skewed)
    assert not kept[0, GRASP].any() and not kept[1, GRASP].any()  # 10 and 12.5 deg off a face: ruled out
    assert kept[2, GRASP].all()  # 35 deg off: kept
    assert kept[:, PUSH].all()


def test_it_gives_way_when_no_grasp_across_the_corners_is_left():
    obs = _observation(MODE_TARGET, _top(0.0))
    q = np.zeros((ROTATIONS, 2, CROP, CROP), np.float32)
    q[[1, 2, 3, 5, 6, 7, 9, 10, 11, 13, 14, 15], GRASP] = -np.inf
    assert _kept(obs, q)[0, GRASP].all()


def test_it_does_nothing_on_a_round_target_or_without_a_target_in_view():
    assert _kept(_observation(MODE_TARGET, _top(0.0, 24, shape="disc"))).all()
    assert _kept(_observation(MODE_OCCLUDED_REGION, _top(0.2))).all()
    assert _kept(_observation(MODE_TARGET, np.zeros((CROP, CROP), np.uint8))).all()


def _curved(mask, profile):
    """Heights (m) under a 20 px square mask whose top falls across its rows: 'half_cylinder' a half
    cylinder of radius 10 px lying along the cols, 'prism' a ridge of two faces at 50 deg, 'tilted' a flat
    face tilted by 10 deg, 'flat' 40 mm everywhere."""
    rows = np.mgrid[:CROP, :CROP][0].astype(np.float64) - CROP / 2
    res = HeightmapGrid().resolution
    across = np.clip(np.abs(rows), 0, 10) * res
    top = {"half_cylinder": np.sqrt(np.maximum((10 * res) ** 2 - across ** 2, 0.0)),
           "prism": 0.03 - across * math.tan(math.radians(50.0)),
           "tilted": 0.02 + rows * res * math.tan(math.radians(10.0)),
           "flat": np.full_like(rows, 0.04)}[profile]
    return np.where(mask > 0, np.maximum(top, 0.002), 0.0).astype(np.float32)


def test_a_square_outline_with_a_curved_or_ridged_top_is_not_read_as_a_cube():
    mask = _top(math.radians(10.0))
    res = HeightmapGrid().resolution
    slopes = {profile: top_slope(_curved(mask, profile), mask, res)
              for profile in ("flat", "tilted", "half_cylinder", "prism")}
    flat_most = RuleParams().corner_max_slope
    assert slopes["flat"] < flat_most and slopes["tilted"] < flat_most  # tan(10 deg) = 0.18, plus the edges
    assert slopes["half_cylinder"] > 2 * flat_most and slopes["prism"] > 3 * flat_most
    for profile in ("half_cylinder", "prism"):  # the rule leaves every grasp
        obs = crop_observation(MODE_TARGET, _curved(mask, profile), mask)
        assert _kept(obs).all(), profile
    for profile in ("flat", "tilted"):  # a flat top, level or a little tilted, is still a cube's
        obs = crop_observation(MODE_TARGET, _curved(mask, profile), mask)
        assert not _kept(obs)[0, GRASP].any(), profile
    assert top_slope(_curved(mask, "flat"), np.zeros_like(mask), res) is None  # no inner cells


@pytest.mark.parametrize("field, value", [("face_min_fill", 1.5), ("corner_min_skew_deg", 50.0),
                                          ("corner_min_skew_deg", -1.0), ("corner_max_slope", -0.1)])
def test_corner_parameters_out_of_range_are_refused_by_name(field, value):
    with pytest.raises(ValueError, match=field):
        RuleParams(**{field: value})


def test_it_is_a_candidate_in_no_preset():
    assert "grasp_across_corners" in CANDIDATES
    assert all("grasp_across_corners" not in rules for rules in PRESETS.values())
