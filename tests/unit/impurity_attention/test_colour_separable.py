"""evaluation.colour_separable: whether a visible scene's impurity can be told from the product by colour
at all (a per-cell oracle read from the truth), the figure a palette's detection rate is read against."""

import numpy as np

from impurity_attention.core.evaluation import SEPARABLE_MIN_CELLS, SceneRecord, colour_separable

PRODUCT_LIT, PRODUCT_SHADED = (60, 140, 210), (30, 70, 105)  # one blue product, a lit and a shaded face


def scene(impurity_rgb, num_targets=1, seed=0):
    """A 60 x 60 map: four 20 x 20 product blocks (left half of each lit, right half shaded), and with
    num_targets a 10 x 10 impurity block of impurity_rgb; colours with +-3 of noise per channel."""
    rng = np.random.default_rng(seed)
    color = np.full((60, 60, 3), 90, np.uint8)
    height = np.zeros((60, 60), np.float32)
    labels = np.full((60, 60), -1, np.int32)
    for label, (row, col) in enumerate([(5, 5), (5, 35), (35, 5), (35, 35)], start=1):
        height[row:row + 20, col:col + 20] = 0.03
        labels[row:row + 20, col:col + 20] = label
        color[row:row + 20, col:col + 10] = PRODUCT_LIT
        color[row:row + 20, col + 10:col + 20] = PRODUCT_SHADED
    target_ids = ()
    if num_targets:
        height[25:35, 25:35] = 0.03
        labels[25:35, 25:35] = 9
        color[25:35, 25:35] = impurity_rgb
        target_ids = (9,)
    noise = rng.integers(-3, 4, size=color.shape)
    color = np.clip(color.astype(int) + noise, 0, 255).astype(np.uint8)
    return SceneRecord("random", seed, num_targets, 5, color, height, labels, target_ids, ((30, 30),))


def test_an_impurity_of_another_hue_is_separable():
    assert colour_separable(scene((210, 60, 40))) is True


def test_an_impurity_coloured_like_the_products_shaded_faces_is_not():
    assert colour_separable(scene(PRODUCT_SHADED)) is False


def test_a_scene_without_a_visible_impurity_is_not_judged():
    assert colour_separable(scene((210, 60, 40), num_targets=0)) is None


def test_an_impurity_showing_fewer_distinct_cells_than_a_region_needs_is_not_separable():
    record = scene((210, 60, 40))
    # leave fewer than SEPARABLE_MIN_CELLS of the impurity off the product's colours
    cells = np.argwhere(record.labels == 9)
    for row, col in cells[SEPARABLE_MIN_CELLS - 1:]:
        record.color[row, col] = PRODUCT_LIT
    assert colour_separable(record) is False
