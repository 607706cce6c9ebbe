"""A colour's distance from a product's colours (impurity_common.colour.ProductReference): Mahalanobis, so
that the product's own shading counts little and one threshold serves every palette."""

import numpy as np
import pytest

from impurity_common.colour import REFERENCE_CELLS, ProductReference, off_colours

LIT, SHADED = (40, 120, 200), (30, 90, 150)  # one blue block, a lit and a shaded face


def test_the_contrast_is_a_mahalanobis_distance_from_the_products_colours():
    reference = ProductReference.from_colors([LIT] * 50 + [SHADED] * 50, min_spread=2.0)
    assert reference.mean == pytest.approx([35, 105, 175])
    # a blue between the two faces is product, even one further from the mean in RGB than a reddish one
    between, reddish = (36, 108, 180), (60, 105, 175)
    assert np.linalg.norm(np.subtract(between, reference.mean)) > 0
    assert np.linalg.norm(np.subtract(between, reference.mean)) < np.linalg.norm(np.subtract(reddish,
                                                                                             reference.mean))
    assert reference.contrast(between) < 1.0 < 4.0 < reference.contrast(reddish)
    assert reference.contrast((200, 30, 30)) > 20


def test_the_least_spread_bounds_the_contrast_on_axes_the_product_does_not_vary_along():
    one_colour = ProductReference.from_colors([LIT] * 100, min_spread=4.0)
    assert one_colour.contrast(np.add(LIT, (0, 0, 8))) == pytest.approx(2.0)  # 8 RGB = 2 spreads of 4
    assert ProductReference.from_colors([LIT] * 100, min_spread=8.0).contrast(np.add(LIT, (0, 0, 8))) == \
        pytest.approx(1.0)


def test_brightness_leaves_the_contrast_unchanged_where_the_product_spreads_beyond_the_least_spread():
    shades = [(100, 100, 100), (160, 130, 150), (120, 170, 110), (150, 110, 170)]
    products, impurity = np.repeat(shades, 64, axis=0), np.array([220, 90, 60])
    for floor in (2.0, 12.0):
        bright = ProductReference.from_colors(products, floor).contrast(impurity)
        dark = ProductReference.from_colors(products * 0.5, floor / 2).contrast(impurity * 0.5)
        assert dark == pytest.approx(bright)  # one stop darker: the same contrast, the same decision


def test_a_view_gives_its_object_cells_outside_the_mask_and_large_views_are_subsampled():
    height = np.zeros((100, 100), np.float32)
    color = np.zeros((100, 100, 3), np.uint8)
    height[:80], color[:80] = 0.03, LIT
    mask = np.zeros((100, 100), bool)
    mask[:10] = True
    reference = ProductReference.from_view(color, height, mask, min_spread=4.0, min_object_height=0.01)
    assert len(reference.colors) == min(70 * 100, REFERENCE_CELLS)
    assert reference.mean == pytest.approx(LIT)
    assert ProductReference.from_view(color, np.zeros((100, 100)), None, min_spread=4.0,
                                      min_object_height=0.01) is None


def test_shading_grants_spread_along_the_products_colour_and_not_across_it():
    # the first view showed lit faces only; a tilted block shows a face of the same hue, 25 % darker
    lit_only = [LIT] * 100
    darker_face = np.multiply(LIT, 0.75)
    other_hue = np.add(LIT, (40, -20, -20))  # a redder blue: off the axis of the product's colour
    plain = ProductReference.from_colors(lit_only, min_spread=24.0)
    shaded = ProductReference.from_colors(lit_only, min_spread=24.0, shading=0.2)
    assert plain.contrast(darker_face) > 2.0  # without shading the darker face reads as another colour
    assert shaded.contrast(darker_face) < 1.5
    assert shaded.contrast(other_hue) == pytest.approx(plain.contrast(other_hue), rel=0.15)
    assert shaded.contrast((200, 30, 30)) > 5
    # a share of the mean colour: the same decision one stop darker
    dark = ProductReference.from_colors(np.multiply(lit_only, 0.5), min_spread=12.0, shading=0.2)
    assert dark.contrast(darker_face * 0.5) == pytest.approx(shaded.contrast(darker_face))


@pytest.mark.parametrize("colors, spread, shading, fragment", [
    (np.zeros((0, 3)), 4.0, 0.0, "at least one"), ([LIT], 0.0, 0.0, "min_spread"),
    ([LIT], 4.0, -0.1, "shading"),
])
def test_bad_input_is_refused_with_the_reason(colors, spread, shading, fragment):
    with pytest.raises(ValueError, match=fragment):
        ProductReference.from_colors(colors, spread, shading)


# a light blue product one stop over: its blue channel at the camera's ceiling on every lit face
CLIPPED_PRODUCT = [(87 + d, 236 + d, 255) for d in (-4, -2, 0, 2, 4)] * 20


def test_a_channel_clipped_on_the_product_is_left_out_with_a_saturation_level():
    # a shaded face: red and green scaled by 0.72, blue still near the ceiling - not on the mean's axis
    shaded, other_hue = (63, 170, 251), (140, 170, 251)
    clipped = ProductReference.from_colors(CLIPPED_PRODUCT, min_spread=4.0, shading=0.15, saturation=250)
    every_channel = ProductReference.from_colors(CLIPPED_PRODUCT, min_spread=4.0, shading=0.15)
    assert list(clipped.channels) == [True, True, False]
    assert list(every_channel.channels) == [True, True, True]
    assert clipped.contrast(shaded) < 2.0 < 5.0 < every_channel.contrast(shaded)
    assert clipped.contrast(other_hue) > 4 * clipped.contrast(shaded)  # another hue stays far


def test_a_product_clipped_in_every_channel_keeps_all_three():
    white = ProductReference.from_colors([(255, 255, 254)] * 30 + [(252, 255, 255)] * 30, min_spread=4.0,
                                         saturation=250)
    assert list(white.channels) == [True, True, True]
    assert white.contrast((120, 120, 120)) > 20


def test_a_bad_saturation_level_is_refused_by_name():
    with pytest.raises(ValueError, match="saturation"):
        ProductReference.from_colors([LIT] * 10, min_spread=4.0, saturation=0.0)


def test_off_colours_marks_colours_rare_among_the_reference_and_judges_only_the_cells_asked_for():
    rng = np.random.default_rng(3)
    color = np.clip(rng.normal((40, 120, 200), 8, size=(40, 40, 3)), 0, 255).astype(np.uint8)  # blue product
    color[10:16, 10:16] = (200, 60, 40)  # a red block
    red = np.zeros((40, 40), bool)
    red[10:16, 10:16] = True
    reference = ~red
    off = off_colours(color, reference)
    assert off[red].all() and off[reference].mean() <= 0.02  # ~1 % of the reference's own cells are rare
    judged = np.zeros((40, 40), bool)
    judged[5:20, 5:30] = True
    assert np.array_equal(off_colours(color, reference, judged), off & judged)  # the same verdicts, no others
