"""How the pose rule grasp_square_to_faces reads a target's top: the face normals of a rectangular outline
(pose.face_direction) and how steeply the top slopes (pose.top_slope)."""

import math

import numpy as np
import pytest

from impurity_common.grid import HeightmapGrid
from impurity_policy.core.pose import face_direction, top_slope
from impurity_policy.core.rules import RuleParams

CROP = 112


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


def test_a_flat_top_level_or_a_little_tilted_reads_flat_and_a_curved_or_ridged_one_does_not():
    mask = _top(math.radians(10.0))
    res = HeightmapGrid().resolution
    slopes = {profile: top_slope(_curved(mask, profile), mask, res)
              for profile in ("flat", "tilted", "half_cylinder", "prism")}
    flat_most = RuleParams().corner_max_slope
    assert slopes["flat"] < flat_most and slopes["tilted"] < flat_most  # tan(10 deg) = 0.18, plus the edges
    assert slopes["half_cylinder"] > 2 * flat_most and slopes["prism"] > 3 * flat_most


def test_a_mask_without_inner_cells_has_no_slope():
    mask = _top(math.radians(10.0))
    assert top_slope(_curved(mask, "flat"), np.zeros_like(mask), HeightmapGrid().resolution) is None


@pytest.mark.parametrize("field, value", [("face_min_fill", 1.5), ("face_min_fill", -0.1),
                                          ("corner_max_slope", -0.1)])
def test_top_reading_parameters_out_of_range_are_refused_by_name(field, value):
    with pytest.raises(ValueError, match=field):
        RuleParams(**{field: value})
