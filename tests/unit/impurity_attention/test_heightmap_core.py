"""Heightmap projection: geometry, depth encodings, holes, bounds (no ROS, no simulator)."""

import math

import numpy as np
import pytest

from impurity_attention.core import heightmap as hm
from impurity_attention.core.synthetic import Box, render_boxes

GRID = hm.HeightmapGrid()


def scene():
    return render_boxes([Box(0.50, 0.00, 0.04, 0.04, 0.05, (255, 0, 0), 1),
                         Box(0.35, -0.15, 0.03, 0.06, 0.02, (0, 255, 0), 2)])


def project(frame, depth=None, grid=GRID):
    depth = frame.depth if depth is None else depth
    return hm.rgbd_to_heightmaps(frame.color, depth, frame.intrinsics, frame.camera_pose, grid,
                                 labels=frame.labels)


def test_grid_matches_cell_constants():
    assert GRID.shape == (224, 224)
    assert GRID.pixel_to_base(0, 0) == pytest.approx((0.277, -0.223))
    assert GRID.base_to_pixel(0.501, 0.001) == (112, 112)


def test_boxes_land_at_their_place_height_and_colour():
    maps = project(scene())
    assert maps.color.shape == (224, 224, 3) and maps.color.dtype == np.uint8
    assert maps.height.shape == (224, 224) and maps.height.dtype == np.float32
    row, col = GRID.base_to_pixel(0.50, 0.00)
    assert maps.height[row, col] == pytest.approx(0.05, abs=1e-4)
    assert tuple(maps.color[row, col]) == (255, 0, 0) and maps.labels[row, col] == 1
    row, col = GRID.base_to_pixel(0.35, -0.15)
    assert maps.height[row, col] == pytest.approx(0.02, abs=1e-4)
    assert maps.labels[row, col] == 2
    # footprints: 40 x 40 mm = 20 x 20 cells, 30 x 60 mm = 15 x 30 cells (one cell of slack per side)
    assert abs(np.count_nonzero(maps.labels == 1) - 400) <= 80
    assert abs(np.count_nonzero(maps.labels == 2) - 450) <= 90
    table = maps.labels == 0
    assert np.all(np.abs(maps.height[table]) < 1e-4)


def test_16uc1_millimetres_equal_32fc1_metres():
    frame = scene()
    depth_mm = np.round(frame.depth * 1000.0).astype(np.uint16)
    from_mm = project(frame, hm.depth_to_meters(depth_mm, "16UC1"))
    from_m = project(frame, hm.depth_to_meters(np.round(frame.depth * 1000.0).astype(np.float32) / 1000.0,
                                               "32FC1"))
    assert np.allclose(from_mm.height, from_m.height, atol=1e-5)
    assert np.array_equal(from_mm.color, from_m.color)


@pytest.mark.parametrize("hole_value", [0.0, np.nan, np.inf])
def test_holes_stay_empty_never_spikes(hole_value):
    frame = scene()
    depth = frame.depth.copy()
    depth[200:280, 280:360] = hole_value  # a hole over the red box and the table around it
    depth[0:5, :] = hole_value
    maps = project(frame, hm.depth_to_meters(depth, "32FC1"))
    assert np.all(np.isfinite(maps.height))
    assert maps.height.max() <= 0.05 + 1e-4
    assert np.all(maps.height[~maps.seen] == 0.0)
    # cells no pixel reached are black; those of the hole's pixels keep their colour, as height unknown
    assert np.all(maps.color[~maps.seen & ~maps.unknown] == 0) and not np.any(maps.unknown & maps.seen)
    assert np.count_nonzero(maps.unknown) > 100 and np.all(maps.color[maps.unknown].any(axis=1))


def test_all_holes_give_a_map_of_unknown_height():
    """Nothing seen and no height anywhere; the colour is there, of unknown height (the heightmap node drops
    such a frame: too few pixels have a depth)."""
    frame = scene()
    maps = project(frame, np.full_like(frame.depth, np.nan))
    assert not maps.seen.any() and not maps.height.any() and maps.unknown.all()
    assert np.isnan(maps.height_or_unknown()).all()


def test_points_above_max_height_and_outside_the_workspace_are_dropped():
    frame = render_boxes([Box(0.50, 0.00, 0.04, 0.04, 0.40, (255, 0, 0), 1),  # 40 cm: the gripper, say
                          Box(0.80, 0.00, 0.04, 0.04, 0.05, (0, 0, 255), 2)])  # beyond x_max
    maps = project(frame)
    assert maps.height.max() < 1e-4
    assert not np.any(maps.labels == 1) and not np.any(maps.labels == 2)


def test_below_table_noise_is_clipped_to_zero():
    frame = scene()
    depth = frame.depth.copy()
    depth[frame.labels == 0] += 0.01  # table seen 1 cm too far
    maps = project(frame, depth)
    assert maps.height.min() == 0.0


def test_custom_grid_bounds_and_resolution():
    grid = hm.HeightmapGrid(x_min=0.4, x_max=0.6, y_min=-0.1, y_max=0.1, resolution=0.004)
    maps = project(scene(), grid=grid)
    assert maps.height.shape == (50, 50)
    row, col = grid.base_to_pixel(0.5, 0.0)
    assert maps.height[row, col] == pytest.approx(0.05, abs=1e-4)


def test_pose_matrix():
    assert np.allclose(hm.pose_matrix((1, 2, 3), (0, 0, 0, 1)), [[1, 0, 0, 1], [0, 1, 0, 2], [0, 0, 1, 3],
                                                                 [0, 0, 0, 1]])
    flip = hm.pose_matrix((0, 0, 0), (1, 0, 0, 0))
    assert np.allclose(flip[:3, :3], np.diag([1, -1, -1]))
    half = math.sqrt(0.5)
    yaw = hm.pose_matrix((0, 0, 0), (0, 0, half, half))
    assert np.allclose(yaw[:3, :3] @ [1, 0, 0], [0, 1, 0])
    with pytest.raises(ValueError):
        hm.pose_matrix((0, 0, 0), (0, 0, 0, 0))


@pytest.mark.parametrize("depth, encoding", [
    (np.zeros((4, 4), np.uint16), "mono8"),
    (np.zeros((4, 4), np.float32), "16UC1"),
    (np.zeros((4, 4), np.uint16), "32FC1"),
    (np.zeros((4, 4, 3), np.float32), "32FC1"),
])
def test_bad_depth_is_refused_with_a_reason(depth, encoding):
    with pytest.raises(hm.DepthFormatError):
        hm.depth_to_meters(depth, encoding)


def test_mismatched_sizes_and_bad_intrinsics_raise():
    frame = scene()
    projector = hm.HeightmapProjector(frame.intrinsics, frame.camera_pose, frame.depth.shape)
    with pytest.raises(ValueError):
        projector.project(frame.color[:-1], frame.depth)
    with pytest.raises(ValueError):
        projector.project(frame.color, frame.depth[:, :-1])
    with pytest.raises(ValueError):
        hm.HeightmapProjector(np.zeros((3, 3)), frame.camera_pose, frame.depth.shape)


def test_projector_cache_rebuilds_only_on_change():
    frame = scene()
    cache = hm.ProjectorCache()
    first = cache.get(frame.intrinsics, frame.camera_pose, frame.depth.shape, GRID)
    assert cache.get(frame.intrinsics.copy(), frame.camera_pose.copy(), frame.depth.shape, GRID) is first
    moved = frame.camera_pose.copy()
    moved[0, 3] += 0.01
    assert cache.get(frame.intrinsics, moved, frame.depth.shape, GRID) is not first


def exposure_scene(product_rgb, objects_share=0.5):
    """A 40 x 40 colour heightmap: the left objects_share of the columns are objects of product_rgb, the
    rest table (grey, height 0)."""
    color = np.full((40, 40, 3), 120, np.uint8)
    height = np.zeros((40, 40), np.float32)
    width = int(40 * objects_share)
    color[:, :width] = product_rgb
    height[:, :width] = 0.03
    return color, height


def test_a_well_exposed_product_raises_no_exposure_problem():
    assert hm.exposure_problem(*exposure_scene((200, 180, 150))) is None


def test_a_channel_clipped_on_most_objects_is_named_with_the_exposure_to_lower():
    problem = hm.exposure_problem(*exposure_scene((255, 230, 200)))
    assert problem is not None and "clipped" in problem and " R " in problem
    assert "rgb_camera.exposure" in problem


def test_nearly_black_objects_ask_for_more_exposure():
    problem = hm.exposure_problem(*exposure_scene((3, 2, 4)))
    assert problem is not None and "nearly black" in problem and "Raise" in problem


def test_a_clipped_table_alone_is_not_an_exposure_problem():
    color, height = exposure_scene((200, 180, 150))
    color[:, 20:] = 255  # a white table at the ceiling: nothing to compare there
    assert hm.exposure_problem(color, height) is None


def test_exposure_is_judged_on_the_same_objects_as_attention():
    from impurity_attention.core.density import DensityParams

    assert hm.exposure_problem.__defaults__[0] == DensityParams().occupied_height


def test_clipped_channel_names_the_channel_most_often_at_the_ceiling_and_its_share():
    colours = np.array([[255, 250, 10], [255, 100, 10], [200, 252, 10], [255, 251, 10]], np.uint8)
    assert hm.clipped_channel(colours) == (0, 0.75)  # R at 250+ on three of four, G on two
    assert hm.clipped_channel(np.zeros((0, 3), np.uint8)) == (0, 0.0)
    for bad in (np.full((3, 6), 255, np.uint8), np.full((6, 4), 255, np.uint8), colours / 255.0):
        with pytest.raises(ValueError, match=r"\(N, 3\) uint8"):  # channel-first, RGBA, float: refused
            hm.clipped_channel(bad)


# ---- the heightmap's parameters ------------------------------------------------------------------------
def test_the_default_parameters_give_the_cells_grid_and_camera():
    params = hm.HeightmapParams()
    assert params.grid() == GRID
    assert np.array_equal(params.camera_pose(), hm.default_camera_pose())


def test_a_grid_from_parameters_carries_every_grid_setting():
    params = hm.HeightmapParams(workspace_x=(0.4, 0.6), workspace_y=(-0.1, 0.1), resolution=0.004,
                                table_z=0.01, max_height=0.2)
    assert params.grid() == hm.HeightmapGrid(x_min=0.4, x_max=0.6, y_min=-0.1, y_max=0.1, resolution=0.004,
                                             table_z=0.01, max_height=0.2)


def test_a_sync_tolerance_of_zero_leaves_pairing_automatic():
    assert hm.HeightmapParams().pairing_tolerance_ns() is None
    assert hm.HeightmapParams(sync_tolerance=0.004).pairing_tolerance_ns() == 4_000_000


def test_a_resolution_coarser_than_the_workspace_is_refused_by_name():
    with pytest.raises(ValueError, match="resolution"):
        hm.HeightmapParams(workspace_x=(0.4, 0.41), resolution=0.02)


def test_the_node_declares_the_heightmaps_parameters_and_only_its_logging_settings_besides():
    from impurity_attention.heightmap_node import HeightmapNodeParameters
    from impurity_common.parameters import parameter_specs

    core = [spec.name for spec in parameter_specs(hm.HeightmapParams)]
    assert [spec.name for spec in parameter_specs(HeightmapNodeParameters)] == [*core, "log_throttle",
                                                                                 "frame_timeout"]
