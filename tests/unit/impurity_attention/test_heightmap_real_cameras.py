"""Heightmaps from cameras unlike the simulated one: depth in other units than assumed, a
camera pose that does not fit the depth, pixels coarser than the map's cells. No ROS, no simulator."""

import cv2
import numpy as np
import pytest

from impurity_attention.core import heightmap as hm
from impurity_attention.core.attention import attend
from impurity_attention.core.synthetic import (
    TABLE_COLOR,
    Box,
    footprint_labels,
    overhead_camera,
    random_boxes,
    render_boxes,
)
from impurity_common.enums import AttentionMode

GRID = hm.HeightmapGrid()
MOST = hm.MOST


def projector_of(frame) -> hm.HeightmapProjector:
    return hm.HeightmapProjector(frame.intrinsics, frame.camera_pose, frame.depth.shape, GRID)


# ---------------------------------------------------------------- depth units and the sanity check

def d405_frame():
    """The cell's camera 0.75 m above the table, publishing 16UC1 in 0.1 mm (a D405): table = 7500."""
    frame = render_boxes(random_boxes(7, num_product=20, num_impurities=1))
    return frame, np.round(frame.depth * 10000.0).astype(np.uint16)


def test_d405_depth_with_its_depth_scale_gives_the_right_map():
    frame, raw = d405_frame()
    assert raw[0, 0] == 7500
    projector = projector_of(frame)
    depth = hm.depth_to_meters(raw, "16UC1", depth_scale=0.0001)
    maps = projector.project(frame.color, depth)
    truth = projector.project(frame.color, frame.depth)
    assert np.allclose(maps.height, truth.height, atol=2e-4)
    assert np.count_nonzero(maps.seen) == np.count_nonzero(truth.seen) and maps.seen.mean() > 0.95
    assert hm.depth_problem(projector.check_depth(depth), "16UC1", 0.0001) is None


def test_d405_depth_read_as_millimetres_is_flagged_naming_depth_scale():
    """Read as mm the table is 7.5 m away, 2.6 % of the cells are seen and nothing said."""
    frame, raw = d405_frame()
    projector = projector_of(frame)
    depth = hm.depth_to_meters(raw, "16UC1")  # the default, 0.001 m per unit
    assert projector.project(frame.color, depth).seen.mean() < 0.05
    check = projector.check_depth(depth)
    assert check.below > 0.99 and check.depth_ratio == pytest.approx(10.0, rel=1e-3)
    problem = hm.depth_problem(check, "16UC1", 0.001)
    assert problem is not None
    assert "Likely cause: the depth units" in problem  # a factor of ten points at the units first
    assert "depth_scale=0.001" in problem and "these depths fit depth_scale=0.0001" in problem
    assert "camera_position" in problem and "camera_orientation" in problem


def test_depth_too_short_is_flagged_as_well():
    frame, raw = d405_frame()
    projector = projector_of(frame)
    depth = hm.depth_to_meters(raw, "16UC1", depth_scale=0.00001)  # points 7.5 cm from the camera
    check = projector.check_depth(depth)
    assert check.above > 0.99
    assert "these depths fit depth_scale=0.0001" in hm.depth_problem(check, "16UC1", 0.00001)


def test_32fc1_in_millimetres_is_flagged():
    frame = render_boxes(random_boxes(8))
    problem = hm.depth_problem(projector_of(frame).check_depth(frame.depth * 1000.0), "32FC1")
    assert problem is not None and "32FC1 depth must be metres" in problem


def test_mono16_depth_is_integer_depth_with_the_same_scale():
    frame, raw = d405_frame()
    from_mono16 = hm.depth_to_meters(raw, "mono16", depth_scale=0.0001)
    assert np.array_equal(from_mono16, hm.depth_to_meters(raw, "16UC1", depth_scale=0.0001))
    with pytest.raises(hm.DepthFormatError, match="depth_scale"):
        hm.depth_to_meters(raw, "16UC1", depth_scale=0.0)


def test_a_camera_pose_that_does_not_fit_the_depth_is_flagged_naming_the_pose():
    frame = render_boxes(random_boxes(9))
    # configured 30 cm lower than the camera is: the table appears 30 cm below table_z
    lower = hm.pose_matrix((0.5, 0.0, 0.45), (1.0, 0.0, 0.0, 0.0))
    problem = hm.depth_problem(hm.HeightmapProjector(frame.intrinsics, lower, frame.depth.shape, GRID)
                               .check_depth(frame.depth), "16UC1")
    assert problem is not None
    assert "Likely cause: the camera pose (camera_position, camera_orientation" in problem
    # configured looking up: no pixel can see the workspace
    upward = hm.HeightmapProjector(frame.intrinsics, hm.pose_matrix((0.5, 0.0, 0.75), (0, 0, 0, 1)),
                                   frame.depth.shape, GRID)
    assert "no camera pixel looks at the workspace" in hm.depth_problem(upward.check_depth(frame.depth))


def test_a_blind_camera_is_flagged_and_good_frames_are_not():
    frame = render_boxes(random_boxes(10, num_product=30, num_impurities=1, heap=True))
    projector = projector_of(frame)
    blind = hm.depth_problem(projector.check_depth(np.full_like(frame.depth, np.nan)))
    assert blind is not None and "have a depth" in blind and "camera_position" in blind
    assert hm.depth_problem(projector.check_depth(frame.depth)) is None
    noisy = frame.depth + np.random.default_rng(0).normal(0.0, 0.004, frame.depth.shape).astype(np.float32)
    assert hm.depth_problem(projector.check_depth(noisy)) is None
    # an arm 40 cm above the table across the view: above max_height, but not most of the view
    arm = render_boxes([Box(0.5, 0.0, 0.6, 0.06, 0.4, (90, 90, 90), 1)])
    check = projector.check_depth(arm.depth)
    assert 0.1 < check.above < MOST and hm.depth_problem(check) is None


# ---------------------------------------------------------------- pixels coarser than the cells

# (camera height above the table m, width, height, fx): the cell's 640x480 RealSense colour stream, a
# 1280x720 one (D435-like field of view), and a 424x240 low-resolution mode.
CAMERAS = [(0.75, 640, 480, 618.62), (1.5, 640, 480, 618.62), (0.75, 1280, 720, 920.0),
           (1.5, 1280, 720, 920.0), (1.5, 424, 240, 308.0)]


def camera_id(camera):
    return f"{camera[1]}x{camera[2]}@{camera[0]}m"


def interior(labels: np.ndarray) -> np.ndarray:
    """Object cells one cell or more inside their object's edge."""
    return cv2.erode((labels > 0).astype(np.uint8), np.ones((3, 3), np.uint8)) > 0


@pytest.mark.parametrize("camera", CAMERAS, ids=camera_id)
def test_gaps_inside_objects_are_filled_and_the_visible_impurity_found(camera):
    distance, width, height, fx = camera
    intrinsics, pose = overhead_camera(distance, width, height, fx)
    for seed in (0, 4, 5):
        boxes = random_boxes(seed, num_product=20, num_impurities=1)
        frame = render_boxes(boxes, width, height, intrinsics, pose)
        projector = projector_of(frame)
        assert projector.footprint == pytest.approx(distance / fx, rel=0.02)
        truth = footprint_labels(boxes, GRID)
        maps = projector.project(frame.color, frame.depth)
        inside = interior(truth)
        assert np.mean(~maps.known[inside]) <= 0.02, f"seed {seed}: unseen cells inside objects"
        # nothing invented over the table: cells two or more cells from every object stay table
        far_from_objects = cv2.dilate((truth > 0).astype(np.uint8), np.ones((5, 5), np.uint8)) == 0
        assert maps.height[far_from_objects].max() < 1e-3
        result = attend(maps.color, maps.height)
        assert result.mode == AttentionMode.TARGET, f"seed {seed}: {result.reason}"
        assert truth[result.center] == boxes[-1].label, f"seed {seed}: target at {result.center_xy}"


def test_the_coarse_camera_of_the_field_report_left_a_third_of_the_map_unseen():
    """640x480 at 1.5 m, 2.4 mm per pixel on 2 mm cells."""
    intrinsics, pose = overhead_camera(1.5)
    boxes = random_boxes(4, num_product=20, num_impurities=1)
    frame = render_boxes(boxes, intrinsics=intrinsics, camera_pose=pose)
    projector = projector_of(frame)
    assert projector.footprint == pytest.approx(0.00242, abs=1e-5) and projector.gap_reach == 1
    raw = projector.project(frame.color, frame.depth, fill_gaps=False)
    assert np.mean(~raw.seen) > 0.3 and np.mean(~raw.seen[interior(footprint_labels(boxes))]) > 0.2
    assert attend(raw.color, raw.height).mode == AttentionMode.NONE  # unfilled, the impurity is lost
    filled = projector.project(frame.color, frame.depth)
    assert np.mean(~filled.known) < 0.05 and not (filled.seen & filled.filled).any()
    assert np.array_equal(filled.seen, raw.seen)  # seen stays what was measured


@pytest.mark.parametrize("yaw_deg", [0.0, 30.0, 45.0])
def test_pixels_finer_than_cells_see_every_cell_and_nothing_is_filled(yaw_deg):
    """The footprint bound: when it is at most a cell, every cell the camera looks at holds a sample
    (so the default camera's maps are exactly the projection) - whatever the camera's yaw."""
    half = np.radians(yaw_deg) / 2
    # optical z down, then a yaw about the vertical: q = yaw(z) * flip(x)
    orientation = (np.cos(half), np.sin(half), 0.0, 0.0)
    intrinsics, _ = overhead_camera()
    fx = intrinsics[0, 0]
    limit = 0.002 * fx / (abs(np.cos(2 * half)) + abs(np.sin(2 * half)))  # distance at a 2 mm footprint
    pose = hm.pose_matrix((0.5, 0.0, limit * 0.99), orientation)
    table = render_boxes([], intrinsics=intrinsics, camera_pose=pose)
    projector = projector_of(table)
    assert projector.footprint <= GRID.resolution and projector.gap_reach == 0
    maps = projector.project(table.color, table.depth)
    assert maps.seen.all() and not maps.filled.any()
    coarser = hm.HeightmapProjector(intrinsics, hm.pose_matrix((0.5, 0.0, limit * 1.05), orientation),
                                    table.depth.shape, GRID)
    assert coarser.footprint > GRID.resolution and coarser.gap_reach == 1


def test_the_default_camera_maps_are_unchanged_by_gap_filling():
    frame = render_boxes(random_boxes(3, num_product=30, num_impurities=2, heap=True))
    projector = projector_of(frame)
    assert projector.footprint == pytest.approx(0.75 / 618.62, rel=1e-3) and projector.gap_reach == 0
    plain = projector.project(frame.color, frame.depth, frame.labels, fill_gaps=False)
    filled = projector.project(frame.color, frame.depth, frame.labels)
    for name in ("color", "height", "seen", "labels"):
        assert np.array_equal(getattr(plain, name), getattr(filled, name)), name
    assert not filled.filled.any()


def maps_of(height: np.ndarray, seen: np.ndarray) -> hm.Heightmaps:
    """Heightmaps whose colour encodes the height (table grey, objects red)."""
    color = np.where((height > 0.005)[..., None], np.uint8([200, 30, 30]), np.uint8(TABLE_COLOR))
    color[~seen] = 0
    return hm.Heightmaps(color=color.astype(np.uint8), height=np.where(seen, height, 0).astype(np.float32),
                         seen=seen.copy(), labels=np.where(seen, (height > 0.005).astype(np.int32), -1))


def test_a_gap_inside_an_object_takes_the_object_and_a_gap_bordered_by_table_stays_table():
    height = np.zeros((20, 20), np.float32)
    height[5:15, 5:15] = 0.03  # an object
    seen = np.ones((20, 20), bool)
    seen[:, 9] = False  # an unsampled column, through the object and the table
    seen[12, :] = False  # an unsampled row
    seen[2:5, 15:18] = False  # a 3 x 3 hole in the table, wider than the reach
    maps = hm.fill_sampling_gaps(maps_of(height, seen), reach=1)
    assert np.all(maps.height[5:15, 5:15] == np.float32(0.03))  # the object is whole again
    assert maps.labels[12, 9] == 1 and tuple(maps.color[7, 9]) == (200, 30, 30)
    outside = np.ones((20, 20), bool)
    outside[5:15, 5:15] = False
    assert np.all(maps.height[outside] == 0.0)  # no object grew over the table
    assert tuple(maps.color[0, 9]) == TABLE_COLOR and maps.filled[0, 9]
    assert not maps.known[2:5, 15:18].any()  # a hole wider than the reach stays unseen
    assert np.array_equal(maps.filled, ~seen & maps.known)


def test_a_gap_between_an_object_and_the_table_stays_table():
    height = np.zeros((12, 12), np.float32)
    height[:, :6] = 0.03  # object on the left half, table on the right
    seen = np.ones((12, 12), bool)
    seen[:, 6] = False  # the first table column unsampled
    seen[3, 5] = False  # one gap on the object's edge column, between object cells above and below
    maps = hm.fill_sampling_gaps(maps_of(height, seen), reach=1)
    assert np.all(maps.height[:, 6] == 0.0) and np.all(maps.labels[:, 6] == 0)
    assert maps.height[3, 5] == np.float32(0.03)


def test_the_inner_corner_between_two_objects_is_not_made_object():
    height = np.zeros((12, 12), np.float32)
    height[0:2, :] = 0.03  # one object along the top
    height[:, 10:12] = 0.03  # one along the right
    seen = np.ones((12, 12), bool)
    seen[2:4, 8:10] = False  # unseen cells in the inner corner, diagonal to both
    maps = hm.fill_sampling_gaps(maps_of(height, seen), reach=2)
    assert np.all(maps.height[2:4, 8:10] == 0.0)
