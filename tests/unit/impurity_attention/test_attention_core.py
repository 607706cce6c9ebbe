"""Saliency (VOCUS2), DBSCAN clusters and Algorithm 1 on synthetic heightmaps (no ROS, no simulator)."""

import dataclasses

import numpy as np
import pytest

from impurity_attention.core import attention as att
from impurity_attention.core import density, saliency
from impurity_attention.core.heightmap import rgbd_to_heightmaps
from impurity_attention.core.synthetic import Box, random_boxes, render_boxes

IMPURITY_LABEL_OFFSET = 20  # random_boxes labels: product 1..n, impurities after


def heightmaps(boxes):
    frame = render_boxes(boxes)
    return rgbd_to_heightmaps(frame.color, frame.depth, frame.intrinsics, frame.camera_pose,
                              labels=frame.labels)


# ---------------------------------------------------------------- saliency

def test_opponent_colour_planes():
    pixels = np.array([[[255, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 255]]], dtype=np.uint8)
    planes = saliency.opponent_colour(pixels)[0]
    assert planes[0] == pytest.approx([1 / 3, 1.0, -0.5], abs=1e-6)  # red: I, RG, BY
    assert planes[1] == pytest.approx([1 / 3, -1.0, -0.5], abs=1e-6)
    assert planes[2] == pytest.approx([1 / 3, 0.0, 1.0], abs=1e-6)
    assert planes[3] == pytest.approx([1.0, 0.0, 0.0], abs=1e-6)


def test_uniform_image_has_no_saliency():
    maps = saliency.vocus2(np.full((224, 224, 3), 90, np.uint8), keep_features=True)
    assert maps.saliency.shape == (224, 224)
    assert float(maps.saliency.max()) < 1e-5
    assert set(maps.conspicuity) == {"I", "RG", "BY"} and len(maps.features) == 6


@pytest.mark.parametrize("params", [saliency.VOCUS2_DEFAULTS, saliency.VOCUS2_CLUTTER,
                                    saliency.CELL_SALIENCY])
def test_odd_patch_is_the_most_salient_place(params):
    image = np.full((224, 224, 3), (40, 120, 200), np.uint8)
    image[150:165, 60:75] = (220, 60, 40)
    sal = saliency.vocus2(image, params).saliency
    row, col = np.unravel_index(np.argmax(sal), sal.shape)
    assert 145 <= row < 170 and 55 <= col < 80
    assert np.all(sal >= 0.0)


def test_saliency_keeps_the_input_size():
    sal = saliency.vocus2(np.random.default_rng(0).integers(0, 255, (97, 131, 3), dtype=np.uint8)).saliency
    assert sal.shape == (97, 131) and sal.dtype == np.float32


def test_saliency_params_are_checked():
    with pytest.raises(ValueError):
        saliency.SaliencyParams(center_sigma=5.0, surround_sigma=4.0)
    with pytest.raises(ValueError):
        saliency.SaliencyParams(n_scales=0)


def test_normalised_flat_map_is_zero():
    assert not saliency.normalised(np.ones((4, 4), np.float32)).any()
    assert saliency.normalised(np.arange(4, dtype=np.float32)).max() == pytest.approx(1.0)


# ---------------------------------------------------------------- density

def test_tall_heap_is_the_chosen_cluster_and_a_flat_layer_is_not():
    heap = [Box(0.40 + 0.03 * i, -0.10 + 0.03 * j, 0.03, 0.03, 0.03 * (1 + (i + j) % 2), (0, 0, 255), 1)
            for i in range(3) for j in range(3)]
    layer = [Box(0.55 + 0.03 * i, 0.08 + 0.03 * j, 0.03, 0.03, 0.03, (0, 0, 255), 2)
             for i in range(4) for j in range(4)]
    maps = heightmaps(heap + layer)
    clusters = density.find_clusters(maps.height, 0.002)
    assert len(clusters) == 2
    chosen = density.select_occluded_region(clusters)
    assert chosen is not None and chosen.height == pytest.approx(0.06, abs=1e-3)
    assert np.all(maps.labels[chosen.mask] == 1)
    assert not clusters[1].passes  # the wider layer is one block high: nothing can hide under it


def test_scattered_objects_and_an_empty_table_give_no_region():
    assert density.find_clusters(np.zeros((224, 224), np.float32), 0.002) == []
    sparse = heightmaps([Box(0.3 + 0.1 * i, -0.15 + 0.1 * j, 0.02, 0.02, 0.05, (0, 0, 255), 1)
                         for i in range(4) for j in range(4)])
    assert density.select_occluded_region(density.find_clusters(sparse.height, 0.002)) is None


def test_density_params_are_checked():
    with pytest.raises(ValueError):
        density.DensityParams(stride=0)


# ---------------------------------------------------------------- crops

def test_crop_centered_pads_with_zeros_outside():
    image = np.arange(224 * 224, dtype=np.float32).reshape(224, 224) + 1
    crop, origin = att.crop_centered(image, 10, 220, 112)
    assert origin == (-46, 164) and crop.shape == (112, 112)
    assert np.all(crop[:46] == 0) and np.all(crop[:, 60:] == 0)
    assert crop[46, 0] == image[0, 164]
    inside, origin = att.crop_centered(image, 112, 112, 112)
    assert origin == (56, 56) and np.array_equal(inside, image[56:168, 56:168])
    far, _ = att.crop_centered(np.ones((224, 224, 3), np.uint8), -500, -500, 112)
    assert far.shape == (112, 112, 3) and not far.any()


# ---------------------------------------------------------------- Algorithm 1

@pytest.mark.parametrize("seed", range(4))
def test_visible_impurity_is_the_target(seed):
    maps = heightmaps(random_boxes(seed, num_product=IMPURITY_LABEL_OFFSET, num_impurities=1))
    out = att.attend(maps.color, maps.height)
    assert out.mode == att.AttentionMode.TARGET, out.reason
    assert np.any(maps.labels[out.target_region.mask] == IMPURITY_LABEL_OFFSET + 1)
    assert out.color_crop.shape == (112, 112, 3) and out.height_crop.shape == (112, 112)
    assert out.mask.dtype == np.uint8 and out.mask.max() == 255 and out.mask[56, 56] == 255
    assert out.center_xy == pytest.approx(att.HeightmapGrid().pixel_to_base(*out.center))
    impurity = maps.labels == IMPURITY_LABEL_OFFSET + 1
    covered = np.count_nonzero(out.target_mask & impurity) / np.count_nonzero(impurity)
    precise = np.count_nonzero(out.target_mask & impurity) / np.count_nonzero(out.target_mask)
    assert covered > 0.9 and precise > 0.95  # the whole impurity, not just its most salient part


@pytest.mark.parametrize("seed", range(4))
def test_no_impurity_is_not_a_target(seed):
    maps = heightmaps(random_boxes(seed, num_product=25, num_impurities=0))
    out = att.attend(maps.color, maps.height)
    assert out.mode != att.AttentionMode.TARGET, out.reason


def test_buried_impurity_gives_the_heap_as_occluded_region():
    heap = [Box(0.45 + 0.03 * i, 0.05 + 0.03 * j, 0.03, 0.03, 0.06, (40, 120, 200), 1)
            for i in range(4) for j in range(4)]
    buried = Box(0.495, 0.095, 0.03, 0.03, 0.03, (220, 60, 40), 2)  # under the heap: never seen
    maps = heightmaps(heap + [buried, Box(0.32, -0.18, 0.03, 0.03, 0.03, (40, 120, 200), 1)])
    assert not np.any(maps.labels == 2)
    out = att.attend(maps.color, maps.height)
    assert out.mode == att.AttentionMode.OCCLUDED_REGION, out.reason
    assert out.cluster.mask[att.HeightmapGrid().base_to_pixel(0.495, 0.095)]
    assert np.all(out.mask == 255) and out.score == pytest.approx(0.06, abs=1e-3)


@pytest.mark.parametrize("name, color, height", [
    ("all black", np.zeros((224, 224, 3), np.uint8), np.zeros((224, 224), np.float32)),
    ("uniform", np.full((224, 224, 3), 128, np.uint8), np.zeros((224, 224), np.float32)),
    ("uniform raised", np.full((224, 224, 3), 128, np.uint8), np.full((224, 224), 0.02, np.float32)),
    ("NaN height", np.full((224, 224, 3), 128, np.uint8), np.full((224, 224), np.nan, np.float32)),
    ("noise colour, flat", np.random.default_rng(0).integers(0, 255, (224, 224, 3), dtype=np.uint8),
     np.zeros((224, 224), np.float32)),
])
def test_degenerate_maps_give_none_without_exceptions(name, color, height):
    out = att.attend(color, height)
    assert out.mode == att.AttentionMode.NONE, f"{name}: {out.reason}"
    assert not out.mask.any() and np.all(np.isfinite(out.saliency))


def test_empty_table_gives_none():
    maps = heightmaps([])
    out = att.attend(maps.color, maps.height)
    assert out.mode == att.AttentionMode.NONE and out.reason


def test_bad_shapes_are_refused():
    with pytest.raises(ValueError):
        att.attend(np.zeros((224, 224), np.uint8), np.zeros((224, 224), np.float32))
    with pytest.raises(ValueError):
        att.attend(np.zeros((224, 224, 3), np.uint8), np.zeros((200, 224), np.float32))
    with pytest.raises(ValueError):
        att.AttentionParams(crop_size=111)


def test_decisions_are_deterministic():
    maps = heightmaps(random_boxes(7, num_product=20, num_impurities=1))
    first, second = att.attend(maps.color, maps.height), att.attend(maps.color, maps.height)
    assert first.mode == second.mode and first.center == second.center
    assert np.array_equal(first.mask, second.mask)


def test_debug_image_writes_why_at_the_bottom():
    maps = heightmaps(random_boxes(1, num_product=20, num_impurities=1))
    out = att.attend(maps.color, maps.height)
    silent = dataclasses.replace(out, reason="")
    bottom, bare = att.debug_image(maps.color, out)[-12:], att.debug_image(maps.color, silent)[-12:]
    assert not np.array_equal(bottom, bare)
    assert att.reason_summary("region 1 of 3: impurity probability 0.91 >= 0.76; cluster") == \
        "region 1 of 3: impurity probability 0.91 >= 0.76"
    long = att.reason_summary("salient region 2 of 15 (412 px): impurity probability 0.91 >= 0.76")
    assert len(long) == att.REASON_CHARS and long.endswith("0.91 >= 0.76")


def test_debug_image_marks_the_crop():
    maps = heightmaps(random_boxes(1, num_product=20, num_impurities=1))
    out = att.attend(maps.color, maps.height)
    picture = att.debug_image(maps.color, out)
    assert picture.shape == (224, 224, 3) and picture.dtype == np.uint8
    row0, col0 = out.crop_origin
    if 0 <= row0 < 224 and 0 <= col0 + 50 < 224:
        assert tuple(picture[row0, col0 + 50]) == att.MODE_COLORS[att.AttentionMode.TARGET]
