"""Attention with a known product (product_memory.known_product, attend's known_product): the colours of
a view that showed product only. A revealed impurity is still found; a region coloured like much of the known
product is passed over, whatever the verifier's probability.

Synthetic scenes of test_attention_palettes (no simulator): the clean version of a scene is the view before
anything was revealed."""

import numpy as np
import pytest
from test_attention_palettes import PALETTES, scene

from impurity_attention.core import attention as att
from impurity_attention.core.product_memory import known_product, near_miss
from impurity_attention.core.verifier import MIN_SPREAD
from impurity_common.colour import REFERENCE_CELLS, ProductReference, lab, mask_colour


def whole_view(color, height) -> ProductReference:
    """Every object cell's colour, the view's near miss kept."""
    return ProductReference.from_view(color, height, None, MIN_SPREAD,
                                      att.AttentionParams().density.occupied_height)


def known(palette: str, seed: int, with_impurity: bool = False) -> ProductReference:
    """The known product of a scene's view; with_impurity: of a view that showed the impurity and was handed
    over all the same, its near miss kept (as if the decision had missed it and nothing left it out)."""
    color, height, _ = scene(palette, seed, with_impurity=with_impurity)
    return whole_view(color, height) if with_impurity else known_product(color, height)


def test_a_view_remembers_the_colours_of_its_objects():
    product = known("cream_grey", 0)
    shades, impurity = PALETTES["cream_grey"]
    assert 0 < len(product.colors) <= REFERENCE_CELLS
    assert product.share_near(lab(np.array(shades[0], np.uint8))[0], 8.0) > 0.2
    assert product.share_near(lab(np.array(impurity, np.uint8))[0], 8.0) == 0.0
    assert product.share_near(lab(np.array(shades[0], np.uint8))[0], 200.0) == 1.0  # every colour lies within


def test_only_object_cells_are_remembered_and_nan_heights_are_no_objects():
    color = np.zeros((8, 8, 3), np.uint8)
    color[:4] = (200, 30, 30)  # the table half is red, the object half black
    height = np.zeros((8, 8), np.float32)
    height[4:] = 0.02
    height[7, 7] = np.nan  # an object cell the camera did not see
    product = known_product(color, height)
    assert len(product.colors) == 31
    assert product.share_near(lab(np.array([0, 0, 0], np.uint8))[0], 1.0) == 1.0


def test_a_view_without_objects_remembers_nothing_and_bad_shapes_are_refused():
    color = np.zeros((8, 8, 3), np.uint8)
    assert known_product(color, np.zeros((8, 8), np.float32)) is None
    with pytest.raises(ValueError, match="share one"):
        known_product(color, np.zeros((8, 9), np.float32))


@pytest.mark.parametrize("palette", ["coal_slate", "cream_grey", "brown_dark", "green_light", "blue_red"])
def test_a_revealed_impurity_is_found_as_before_when_the_product_is_known(palette):
    color, height, impurity = scene(palette, 1)
    plain = att.attend(color, height)
    remembered = att.attend(color, height, known_product=known(palette, 1))
    assert remembered.mode == att.AttentionMode.TARGET, remembered.reason
    assert np.array_equal(remembered.target_mask, plain.target_mask)
    mask = remembered.target_mask
    assert np.count_nonzero(mask & impurity) > 0.5 * np.count_nonzero(mask)


@pytest.mark.parametrize("palette", ["coal_slate", "cream_grey", "green_light"])
def test_with_a_heap_left_a_region_coloured_like_the_known_product_is_passed_over(palette):
    color, height, impurity = scene(palette, 0, heap=True)
    plain = att.attend(color, height)
    assert plain.mode == att.AttentionMode.TARGET
    # a memory that holds the impurity's colour too (as if the first view had shown it, called clean)
    product = known(palette, 0, with_impurity=True)
    defaults = att.AttentionParams()
    share = product.share_near(mask_colour(color, plain.target_mask), defaults.known_product_delta_e)
    assert share > defaults.known_product_max_share
    remembered = att.attend(color, height, known_product=product)
    assert "known product" in remembered.reason
    if remembered.mode == att.AttentionMode.TARGET:  # another region may be called, never the impurity
        assert not np.any(remembered.target_mask & impurity)
    else:
        assert remembered.mode == att.AttentionMode.OCCLUDED_REGION  # the heap is pushed instead


def test_with_no_heap_left_the_verifier_decides_alone():
    color, height, _ = scene("cream_grey", 0)  # no heap could hide anything
    plain = att.attend(color, height)
    remembered = att.attend(color, height, known_product=known("cream_grey", 0, with_impurity=True))
    assert remembered.mode == plain.mode == att.AttentionMode.TARGET
    assert np.array_equal(remembered.target_mask, plain.target_mask)
    assert "known product" not in remembered.reason


@pytest.mark.parametrize("field, value", [("known_product_delta_e", 0.0), ("known_product_max_share", 1.0),
                                          ("known_product_max_share", -0.1)])
def test_known_product_parameters_out_of_range_are_refused_by_name(field, value):
    with pytest.raises(ValueError, match=field):
        att.AttentionParams(**{field: value})


NEAR_MISS = att.AttentionParams()




@pytest.mark.parametrize("palette", ["coal_slate", "cream_grey", "brown_dark", "green_light", "blue_red"])
def test_the_near_miss_is_the_region_attention_would_take_at_the_last_looks_threshold(palette):
    color, height, impurity = scene(palette, 0)
    mask = near_miss(color, height, NEAR_MISS)
    assert mask is not None and np.count_nonzero(mask & impurity) > 0.5 * np.count_nonzero(mask)
    clean_color, clean_height, _ = scene(palette, 0, with_impurity=False)
    assert near_miss(clean_color, clean_height, NEAR_MISS) is None




@pytest.mark.parametrize("palette", ["coal_slate", "cream_grey", "green_light"])
def test_a_near_miss_is_not_remembered_as_product_and_is_found_later(palette):
    # the first view showed the impurity and the decision missed it (here: a view with it, handed over as if
    # clean); with near misses left out, its colour is not product, so with a heap left it is still found
    color, height, impurity = scene(palette, 0, with_impurity=True)
    product = known_product(color, height, NEAR_MISS)
    plain = whole_view(color, height)
    assert len(product.colors) <= len(plain.colors)
    assert plain.share_near(lab(np.array(PALETTES[palette][1], np.uint8))[0], 4.0) > 0.01
    shades, impurity_rgb = PALETTES[palette]
    defaults = att.AttentionParams()
    assert product.share_near(lab(np.array(impurity_rgb, np.uint8))[0], defaults.known_product_delta_e) \
        <= defaults.known_product_max_share
    heap_color, heap_height, heap_impurity = scene(palette, 0, heap=True)
    found = att.attend(heap_color, heap_height, known_product=product)
    assert found.mode == att.AttentionMode.TARGET, found.reason
    assert np.count_nonzero(found.target_mask & heap_impurity) > 0.5 * np.count_nonzero(found.target_mask)


def test_a_clean_view_is_remembered_whole_with_near_misses_left_out():
    color, height, _ = scene("coal_slate", 2, with_impurity=False)
    assert len(known_product(color, height, NEAR_MISS).colors) == \
        len(whole_view(color, height).colors)
