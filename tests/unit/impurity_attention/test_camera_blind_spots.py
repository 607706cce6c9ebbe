"""What a real depth camera does not measure, and frames that cannot make a heightmap: black or glossy
pieces with no depth on their pixels (0 in 16UC1, NaN in 32FC1) reach the heightmap as height unknown and
attention takes them as candidates; a camera tilted against its calibration shows a sloped table and its
frames are unusable; the colour's brightness jumping between frames is named. No ROS, no simulator."""

import math

import cv2
import numpy as np
import pytest

from impurity_attention.core import heightmap as hm
from impurity_attention.core.attention import attend
from impurity_attention.core.sync import StampPairer, unpaired_warning
from impurity_attention.core.synthetic import Box, footprint_labels, random_boxes, render_boxes
from impurity_attention.core.unknown_height import UNKNOWN_HEIGHT, unknown_height_warning, unknown_regions
from impurity_common.enums import AttentionMode

GRID = hm.HeightmapGrid()
BLACK = (25, 25, 28)


def frame_with_a_black_piece(seed: int, encoding: str, product_color=None):
    """Product blocks and one black impurity whose pixels have no depth, as the camera driver publishes it;
    (boxes, frame, depth in metres as the heightmap node reads it)."""
    kwargs = {} if product_color is None else {"product_color": product_color}
    boxes = random_boxes(seed, num_product=12, num_impurities=1, impurity_color=BLACK, **kwargs)
    frame = render_boxes(boxes)
    hole = frame.labels == boxes[-1].label
    if encoding == "16UC1":
        raw = np.round(frame.depth * 1000.0).astype(np.uint16)
        raw[hole] = 0
    else:
        raw = frame.depth.copy()
        raw[hole] = np.nan
    return boxes, frame, hm.depth_to_meters(raw, encoding)


def projector_of(frame, pose=None) -> hm.HeightmapProjector:
    return hm.HeightmapProjector(frame.intrinsics, frame.camera_pose if pose is None else pose,
                                 frame.depth.shape, GRID)


def on_the_piece(mask: np.ndarray, box: Box) -> bool:
    """`mask` lies on `box`'s footprint, give or take the parallax of pixels placed on the table plane (a
    3 cm top 0.3 m off the optical axis of a camera 0.75 m up: 13 mm, 7 cells)."""
    piece = (footprint_labels([box], GRID) > 0).astype(np.uint8)
    near = cv2.dilate(piece, np.ones((15, 15), np.uint8)) > 0
    return bool(mask.any()) and np.count_nonzero(mask & near) == np.count_nonzero(mask)


# ---------------------------------------------------------------- colour without depth: height unknown

@pytest.mark.parametrize("encoding", ["16UC1", "32FC1"])
def test_colour_without_depth_reaches_the_heightmap_as_height_unknown_with_its_colour(encoding):
    boxes, frame, depth = frame_with_a_black_piece(3, encoding)
    maps = projector_of(frame).project(frame.color, depth)
    full = projector_of(frame).project(frame.color, frame.depth)
    piece = footprint_labels(boxes[-1:], GRID) > 0
    inner = piece.copy()  # the piece but its edge: where parallax may put its pixels
    for axis in (0, 1):
        for shift in (-3, 3):
            inner &= np.roll(piece, shift, axis=axis)
    assert maps.unknown[inner].all() and not maps.seen[inner].any()  # not table, not unseen
    assert (maps.color[inner] == BLACK).all()  # with its colour
    message_height = maps.height_or_unknown()
    assert np.isnan(message_height[inner]).all()
    near = piece.copy()
    for axis in (0, 1):
        for shift in (-4, 4):
            near |= np.roll(piece, shift, axis=axis)
    elsewhere = ~maps.unknown & ~near
    assert np.allclose(message_height[elsewhere], full.height[elsewhere], atol=1e-3)  # (16UC1: mm)
    assert np.count_nonzero(maps.unknown) < 1.3 * np.count_nonzero(piece)  # the piece, not more


def test_full_depth_leaves_no_cell_of_unknown_height():
    frame = render_boxes(random_boxes(4, num_product=20, num_impurities=2, heap=True))
    maps = projector_of(frame).project(frame.color, frame.depth)
    assert not maps.unknown.any() and maps.height_or_unknown() is maps.height


@pytest.mark.parametrize("encoding", ["16UC1", "32FC1"])
@pytest.mark.parametrize("seed", range(5))
def test_a_black_piece_without_depth_is_a_target(seed, encoding):
    """Without the unknown cells attention answers NONE here (the piece is table to it)."""
    boxes, frame, depth = frame_with_a_black_piece(seed, encoding)
    maps = projector_of(frame).project(frame.color, depth)
    height = maps.height_or_unknown()
    output = attend(maps.color, height, grid=GRID, unknown=np.isnan(height))
    assert output.mode == AttentionMode.TARGET, output.reason
    assert on_the_piece(output.target_mask, boxes[-1])
    assert not np.isnan(output.height).any()
    piece = footprint_labels(boxes[-1:], GRID) > 0
    assert float(output.height[piece].max()) == pytest.approx(UNKNOWN_HEIGHT)


def test_an_unknown_region_the_verifier_does_not_take_is_still_looked_at():
    """The piece without depth is coloured like the dark product around it: no salient region is an
    impurity and no heap could hide one - NONE, but for the region whose height nobody knows."""
    boxes, frame, depth = frame_with_a_black_piece(2, "32FC1", product_color=BLACK)
    maps = projector_of(frame).project(frame.color, depth)
    height = maps.height_or_unknown()
    output = attend(maps.color, height, grid=GRID, unknown=np.isnan(height))
    assert output.mode == AttentionMode.TARGET and output.last_look, output.reason
    assert "unknown height" in output.reason
    assert on_the_piece(output.target_mask, boxes[-1])


def test_holes_that_are_no_piece_are_no_candidates():
    """A stereo shadow (a line of cells beside a block), specks, and a hole on the bare table (glare)."""
    frame = render_boxes([Box(0.45, 0.0, 0.03, 0.03, 0.03, (40, 120, 200), 1)])
    depth = frame.depth.copy()
    depth[200:260, 300:302] = np.nan  # shadow: 2 px (2.4 mm) wide
    depth[100:102, 100:102] = np.nan  # a speck
    depth[330:370, 420:460] = np.nan  # bare table, 5 cm x 5 cm
    maps = projector_of(frame).project(frame.color, depth)
    assert maps.unknown.sum() > 500
    assert unknown_regions(maps.color, maps.height, maps.unknown) == []
    assert unknown_height_warning([], GRID.resolution) is None


def test_the_warning_names_the_cause_and_the_camera_settings():
    _, frame, depth = frame_with_a_black_piece(1, "16UC1")
    maps = projector_of(frame).project(frame.color, depth)
    warning = unknown_height_warning(unknown_regions(maps.color, maps.height, maps.unknown), GRID.resolution)
    assert warning is not None and "black or glossy" in warning
    for setting in ("laser_power", "exposure", "hole_filling"):
        assert setting in warning


# ---------------------------------------------------------------- a table that is not where it should be

def rotation(axis: str, degrees: float) -> np.ndarray:
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    turn = np.eye(4)
    if axis == "x":
        turn[1:3, 1:3] = [[c, -s], [s, c]]
    else:
        turn[[0, 0, 2, 2], [0, 2, 0, 2]] = [c, s, -s, c]
    return turn


@pytest.mark.parametrize("seed", range(3))
def test_a_camera_tilted_against_its_calibration_is_unusable_naming_the_pose(seed):
    """Tilted 12 deg + 12 deg, calibrated as straight down: the table reads as a slope; the object cells
    of such a map match the truth poorly, and nothing else said so."""
    boxes = random_boxes(seed, num_product=20, num_impurities=1)
    straight = hm.default_camera_pose()
    frame = render_boxes(boxes, camera_pose=straight @ rotation("x", 12.0) @ rotation("y", 12.0))
    check = projector_of(frame, straight).check_depth(frame.depth)
    assert check.far <= hm.MOST  # the far-points check alone does not see it
    problem = hm.depth_problem(check)
    assert problem is not None, check
    assert "tilted 16.9 deg" in problem and "camera_orientation" in problem and "recalibrate" in problem


@pytest.mark.parametrize("heap", [False, True])
@pytest.mark.parametrize("seed", range(3))
def test_a_camera_where_its_calibration_says_passes_scattered_and_heaped(seed, heap):
    frame = render_boxes(random_boxes(seed, num_product=40, num_impurities=2, heap=heap))
    check = projector_of(frame).check_depth(frame.depth)
    assert check.table is not None and check.table.deviation < 1e-4
    assert hm.depth_problem(check) is None


def test_a_table_lower_than_table_z_is_unusable():
    frame = render_boxes(random_boxes(5))
    lower = hm.pose_matrix((0.5, 0.0, 0.735), (1.0, 0.0, 0.0, 0.0))  # calibrated 15 mm too low
    problem = hm.depth_problem(projector_of(frame, lower).check_depth(frame.depth))
    assert problem is not None and "-15 mm at its centre" in problem


# ---------------------------------------------------------------- brightness between frames

def test_a_jump_of_the_mean_brightness_names_the_auto_exposure_settings():
    dim, bright = np.full((48, 64, 3), 100, np.uint8), np.full((48, 64, 3), 140, np.uint8)
    assert hm.brightness_jump(None, hm.mean_brightness(dim)) is None
    jump = hm.brightness_jump(hm.mean_brightness(dim), hm.mean_brightness(bright))
    assert jump is not None and "from 100 to 140" in jump
    for setting in ("rgb_camera.enable_auto_exposure", "rgb_camera.exposure", "power_line_frequency"):
        assert setting in jump


def test_steady_brightness_is_no_jump_and_only_a_still_scene_is_judged():
    frame, other = render_boxes(random_boxes(6)), render_boxes(random_boxes(7))
    assert hm.brightness_jump(hm.mean_brightness(frame.color), hm.mean_brightness(frame.color)) is None
    noisy = frame.depth + np.random.default_rng(0).normal(0.0, 0.002, frame.depth.shape).astype(np.float32)
    assert hm.still_scene(hm.depth_sample(frame.depth), hm.depth_sample(noisy))  # depth noise: still
    assert not hm.still_scene(hm.depth_sample(frame.depth), hm.depth_sample(other.depth))  # a new scene
    crossed = frame.depth.copy()
    crossed[:120, :200] = 0.3  # the arm over a corner of the view
    assert not hm.still_scene(hm.depth_sample(frame.depth), hm.depth_sample(crossed))


# ---------------------------------------------------------------- a colour-depth offset near a frame period

PERIOD_30HZ = 33_333_333


def stream(pairer: StampPairer, depth_offset_ns: int, frames: int = 60, lose_depth: int | None = None):
    """30 Hz: colour frame k stamped k periods, its depth depth_offset_ns later; (pairs, unpaired)."""
    pairs, unpaired = [], []
    for k in range(frames):
        pairs += pairer.add_color(k * PERIOD_30HZ, k)
        if k != lose_depth:
            pairs += pairer.add_depth(k * PERIOD_30HZ + depth_offset_ns, k)
        unpaired += pairer.take_unpaired()
    return pairs, unpaired


def test_an_offset_near_one_frame_period_is_named_with_the_parameter_to_set():
    """Depth stamped 30 ms after its colour frame at 30 Hz: each colour frame pairs with the depth of the
    frame before, and the frame left over was said to have lost its partner."""
    pairer = StampPairer()
    pairs, unpaired = stream(pairer, 30_000_000)
    assert all(depth == color - 1 for color, depth in pairs[1:])  # paired one frame apart
    warning = unpaired_warning(unpaired, pairer, sync_tolerance=0.0)
    assert "depth is stamped +30.0 ms from the nearest colour frame" in warning
    assert "about one frame period (33.3 ms) off" in warning and "set depth_offset to 0.0300 s" in warning


def test_with_depth_offset_set_every_colour_frame_pairs_with_its_own_depth():
    """The node takes depth_offset off the depth stamps before pairing."""
    offset = int(round(hm.HeightmapParams(depth_offset=0.03).depth_offset * 1e9))
    pairs, unpaired = stream(StampPairer(), 30_000_000 - offset)
    assert all(depth == color for color, depth in pairs) and len(pairs) == 60 and not unpaired


def test_a_lost_depth_frame_is_still_said_to_be_lost():
    pairer = StampPairer()
    _, unpaired = stream(pairer, 0, lose_depth=40)
    warning = unpaired_warning(unpaired, pairer, sync_tolerance=0.0)
    assert "their partners never arrived" in warning
