"""The perception verdict on a grasp (impurity_policy.core.verdict): was the lifted object the attended
impurity? Judged from two heightmaps and what the gripper reports, as a real cell must."""

import numpy as np
import pytest

from impurity_policy.core.verdict import (
    DEFAULT_MIN_COLOR_CONTRAST,
    MIN_COLOR_SPREAD,
    GripperReport,
    ProductReference,
    VerdictParams,
    brightness_gain,
    full_mask,
    gripper_holds,
    judge_grasp,
    piece_height,
    product_color_contrast,
    product_color_distance,
    product_reference,
    target_gone_fraction,
)

SHAPE = (40, 40)
RED, GREY, TABLE = (200, 30, 30), (120, 120, 120), (60, 60, 60)


def scene(blocks):
    """Height (m) and colour maps with rectangular blocks: (row0, row1, col0, col1, height, colour)."""
    height = np.zeros(SHAPE, np.float32)
    color = np.zeros((*SHAPE, 3), np.uint8)
    color[:] = TABLE
    for r0, r1, c0, c1, h, rgb in blocks:
        height[r0:r1, c0:c1] = h
        color[r0:r1, c0:c1] = rgb
    return height, color


TARGET = (10, 20, 10, 20, 0.03, RED)
NEIGHBOUR = (10, 20, 22, 32, 0.03, GREY)
BEFORE = scene([TARGET, NEIGHBOUR])
MASK = np.zeros(SHAPE, bool)
MASK[10:20, 10:20] = True
HOLDS = GripperReport(holding=True, opening=0.03)
EMPTY = GripperReport(holding=False, opening=0.0)


def judge(after, gripper=HOLDS, mask=MASK, params=VerdictParams()):
    return judge_grasp(*BEFORE, mask, *after, gripper, params)


def test_the_target_gone_and_something_held_is_an_impurity_picked():
    verdict = judge(scene([NEIGHBOUR]))
    assert verdict.impurity_picked and verdict.holding
    assert verdict.gone_fraction == 1.0 and "impurity picked" in verdict.reason


def test_a_neighbour_lifted_while_the_target_stays_is_not_an_impurity():
    verdict = judge(scene([TARGET]))
    assert not verdict.impurity_picked and verdict.holding and verdict.gone_fraction == 0.0
    assert "not the impurity" in verdict.reason


def test_the_target_moved_but_nothing_held_is_not_an_impurity():
    verdict = judge(scene([(10, 20, 0, 8, 0.03, RED), NEIGHBOUR]), gripper=EMPTY)
    assert not verdict.impurity_picked and not verdict.holding and verdict.gone_fraction == 1.0
    assert "nothing held" in verdict.reason


def test_a_product_revealed_under_the_target_counts_as_gone_by_its_colour():
    # the impurity lay on a grey block: the height drops by 1 cm only, the colour changes
    before = scene([(10, 20, 10, 20, 0.02, GREY), (10, 20, 10, 20, 0.03, RED)])
    after = scene([(10, 20, 10, 20, 0.02, GREY)])
    assert target_gone_fraction(*before, MASK, *after) == 1.0
    same_colour = scene([(10, 20, 10, 20, 0.029, RED)])  # 1 mm lower, same colour: still there
    assert target_gone_fraction(*before, MASK, *same_colour) == 0.0


def test_the_gone_share_must_reach_min_gone_fraction():
    partly = scene([(10, 15, 10, 20, 0.03, RED), NEIGHBOUR])  # half the target's cells remain
    assert judge(partly).gone_fraction == pytest.approx(0.5)
    assert judge(partly, params=VerdictParams(min_gone_fraction=0.5)).impurity_picked
    assert not judge(partly, params=VerdictParams(min_gone_fraction=0.6)).impurity_picked


def test_the_gripper_test_uses_holding_when_reported_else_the_opening():
    params = VerdictParams(closed_opening=0.004)
    assert gripper_holds(GripperReport(holding=True, opening=0.0), params)  # the driver's word wins
    assert not gripper_holds(GripperReport(holding=False, opening=0.03), params)
    assert gripper_holds(GripperReport(holding=None, opening=0.02), params)
    assert not gripper_holds(GripperReport(holding=None, opening=0.004), params)
    assert not gripper_holds(GripperReport(), params)  # nothing reported, nothing measured


def test_a_grasp_without_an_attended_target_is_never_an_impurity():
    verdict = judge(scene([NEIGHBOUR]), mask=None)
    assert not verdict.impurity_picked and verdict.gone_fraction == -1.0
    assert "no attended target" in verdict.reason
    missing = judge_grasp(*BEFORE, MASK, None, None, HOLDS)
    assert not missing.impurity_picked and "no heightmap" in missing.reason


@pytest.mark.parametrize("mask, after, fragment", [
    (np.zeros(SHAPE, bool), scene([]), "empty"),
    (MASK[:30], scene([]), "shape"),
    (MASK, (np.zeros(SHAPE, np.float32), np.zeros((*SHAPE, 4), np.uint8)), "after_color"),
    (MASK, (np.full(SHAPE, np.nan, np.float32), scene([])[1]), "finite"),
])
def test_inconsistent_maps_are_refused_with_the_reason(mask, after, fragment):
    with pytest.raises(ValueError, match=fragment):
        target_gone_fraction(*BEFORE, mask, *after)


@pytest.mark.parametrize("fields, fragment", [
    ({"min_height_drop": 0.0}, "min_height_drop"), ({"min_color_change": -1.0}, "min_color_change"),
    ({"min_gone_fraction": 0.0}, "min_gone_fraction"), ({"min_gone_fraction": 1.5}, "min_gone_fraction"),
    ({"closed_opening": -0.001}, "closed_opening"),
    ({"min_color_contrast": -1.0}, "min_color_contrast"),
])
def test_bad_thresholds_are_refused(fields, fragment):
    with pytest.raises(ValueError, match=fragment):
        VerdictParams(**fields)


def test_a_crop_mask_lands_in_the_full_map_at_its_origin_and_is_clipped_at_the_border():
    crop = np.zeros((6, 6), np.uint8)
    crop[2:4, 2:4] = 255
    placed = full_mask(crop, (10, 12), SHAPE)
    assert placed.sum() == 4 and placed[12:14, 14:16].all()
    clipped = full_mask(np.full((6, 6), 255, np.uint8), (-3, 37), SHAPE)  # padded past two borders
    assert clipped.sum() == 3 * 3 and clipped[0:3, 37:40].all()
    assert not full_mask(crop, (100, 100), SHAPE).any()  # wholly outside


def test_with_a_colour_test_a_lifted_region_coloured_like_the_product_is_not_counted():
    # once the impurity is gone, attention may take a product block (grey like the others) for a target
    products = [(0, 8, 0, 8, 0.03, GREY), (25, 33, 25, 33, 0.03, (110, 110, 110))]  # two shades
    grey_target = scene([(10, 20, 10, 20, 0.03, (124, 122, 120))] + products)
    after = scene(products)
    params = VerdictParams(min_color_contrast=2.0)
    contrast = product_color_contrast(grey_target[1], grey_target[0], MASK)
    assert contrast < 2.0
    taken = judge_grasp(*grey_target, MASK, *after, HOLDS, params)
    assert not taken.impurity_picked and f"colour lies {contrast:.1f} from the product's" in taken.reason
    red_target = scene([TARGET] + products)
    assert judge_grasp(*red_target, MASK, *after, HOLDS, params).impurity_picked
    any_colour = VerdictParams(min_color_contrast=0.0)
    assert judge_grasp(*grey_target, MASK, *after, HOLDS, any_colour).impurity_picked  # every contrast >= 0


def test_the_colour_distance_is_measured_from_the_median_of_the_other_objects():
    products = [(0, 8, 0, 8, 0.03, GREY), (25, 35, 25, 35, 0.03, GREY)]
    red_target = scene([TARGET] + products)
    assert product_color_distance(red_target[1], red_target[0], MASK) == pytest.approx(
        np.linalg.norm(np.subtract(RED, GREY)))


def test_the_colour_test_needs_other_objects_to_compare_with():
    alone = scene([TARGET])
    assert product_color_distance(alone[1], alone[0], MASK) is None
    assert product_color_contrast(alone[1], alone[0], MASK) is None
    verdict = judge_grasp(*alone, MASK, *scene([]), HOLDS, VerdictParams(min_color_contrast=3.0))
    assert verdict.impurity_picked  # nothing to compare with: the colour test does not refuse it


def test_the_product_reference_is_the_first_views_objects_without_the_attended_target():
    first = scene([TARGET, (0, 8, 0, 8, 0.03, (100, 100, 100)), (25, 33, 25, 33, 0.03, (140, 140, 140))])
    reference = product_reference(first[1], first[0], MASK)
    assert reference.mean == pytest.approx([120, 120, 120])  # the target's cells are left out
    assert len(reference.colors) == 2 * 64
    assert product_reference(*scene([])[::-1], None) is None  # no object cell: no reference


def test_the_verdicts_least_spread_keeps_colours_near_the_products_as_product():
    lit, shaded = (40, 120, 200), (30, 90, 150)  # a lit and a shaded blue
    reference = ProductReference.from_colors([lit] * 50 + [shaded] * 50, MIN_COLOR_SPREAD)
    assert reference.contrast((60, 105, 175)) < DEFAULT_MIN_COLOR_CONTRAST < reference.contrast(RED)


def test_with_the_episodes_reference_a_product_shade_left_alone_is_not_taken_for_an_impurity():
    # once the impurity is gone, one brownish product block among grey ones stands out in its own view
    products = [(0, 8, 0, 8, 0.03, (100, 100, 100)), (25, 33, 25, 33, 0.03, (100, 100, 100))]
    light = scene([(10, 20, 10, 20, 0.03, (160, 110, 60))] + products)
    first = scene([TARGET] + products + [(30, 38, 0, 8, 0.03, (160, 110, 60))])  # both shades in sight
    reference = product_reference(first[1], first[0], MASK)
    params = VerdictParams(min_color_contrast=1.5)
    assert judge_grasp(*light, MASK, *scene(products), HOLDS, params).impurity_picked  # its own view
    judged = judge_grasp(*light, MASK, *scene(products), HOLDS, params, reference=reference)
    assert not judged.impurity_picked and "from the product's" in judged.reason


def test_a_shaded_face_of_the_product_is_not_taken_for_an_impurity():
    # the first view showed the lit tops of the product blocks; after the impurity is gone a tilted block
    # shows a face of the product's hue, darker by a fifth: product, by the verdict's shading allowance
    lit, shaded = (40, 120, 200), (32, 96, 160)
    products = [(0, 8, 0, 8, 0.03, lit), (25, 33, 25, 33, 0.03, lit)]
    first = scene([TARGET] + products)
    reference = product_reference(first[1], first[0], MASK)
    tilted = scene([(10, 20, 10, 20, 0.03, shaded)] + products)
    judged = judge_grasp(*tilted, MASK, *scene(products), HOLDS, reference=reference)
    assert not judged.impurity_picked and "from the product's" in judged.reason
    without_shading = ProductReference.from_view(first[1], first[0], MASK, MIN_COLOR_SPREAD, 0.01)
    assert without_shading.contrast(shaded) > DEFAULT_MIN_COLOR_CONTRAST  # it would have counted
    red = scene([(10, 20, 10, 20, 0.03, RED)] + products)
    assert judge_grasp(*red, MASK, *scene(products), HOLDS, reference=reference).impurity_picked


def test_the_decision_needs_the_target_gone_a_hold_and_a_colour_apart():
    from impurity_policy.core.verdict import decide_picked

    params = VerdictParams(min_color_contrast=0.75)
    gone = params.min_gone_fraction
    assert decide_picked(gone, True, 2.0, params)[0]
    assert decide_picked(gone, True, None, params)[0]  # nothing to compare the colour with
    assert "Mahalanobis" in decide_picked(gone, True, 0.5, params)[1]
    assert "nothing held" in decide_picked(gone, False, 2.0, params)[1]
    assert "only" in decide_picked(gone / 2, True, 2.0, params)[1]


def exposed(view, factor):
    """The same heightmap seen at another exposure: RGB scaled by `factor`, clipped at 255 as a camera."""
    height, color = view
    return height, np.clip(np.rint(color * float(factor)), 0, 255).astype(np.uint8)


FLAT_TARGET = (10, 20, 10, 20, 0.002, RED)  # a flake 2 mm thick: its removal shows in its colour alone


@pytest.mark.parametrize("factor", [0.6, 0.7, 0.8, 1.25])
def test_a_change_of_exposure_alone_does_not_make_an_untouched_target_gone(factor):
    # the gripper lifted the neighbour; the view after the grasp came out darker (auto exposure, flicker)
    verdict = judge(exposed(scene([TARGET]), factor))
    assert not verdict.impurity_picked and verdict.gone_fraction == 0.0 and verdict.holding
    assert verdict.gain == pytest.approx(factor, rel=0.02) and f"{factor:.2f}x" in verdict.reason
    flat = scene([FLAT_TARGET, NEIGHBOUR])
    untouched = judge_grasp(*flat, MASK, *exposed(scene([FLAT_TARGET]), factor), HOLDS)
    assert not untouched.impurity_picked and untouched.gone_fraction == 0.0


@pytest.mark.parametrize("factor", [0.6, 0.7, 0.8, 1.25])
def test_a_target_really_picked_is_still_gone_at_another_exposure(factor):
    assert judge(exposed(scene([NEIGHBOUR]), factor)).impurity_picked
    flat = scene([FLAT_TARGET, NEIGHBOUR])
    picked = judge_grasp(*flat, MASK, *exposed(scene([NEIGHBOUR]), factor), HOLDS)
    assert picked.impurity_picked and picked.gone_fraction == 1.0


def test_the_brightness_gain_is_measured_away_from_the_grasp_on_cells_that_did_not_move():
    after = exposed(scene([(10, 20, 10, 20, 0.03, GREY)]), 0.6)  # the target's cells turned grey
    assert brightness_gain(*BEFORE, MASK, *after) == pytest.approx(0.6, rel=0.02)
    lifted = exposed(scene([TARGET]), 0.6)  # the neighbour's cells lost height: not reference cells
    assert brightness_gain(*BEFORE, MASK, *lifted) == pytest.approx(0.6, rel=0.02)
    assert brightness_gain(*BEFORE, MASK, *scene([TARGET])) == 1.0  # same exposure: exactly 1


def test_without_enough_reference_cells_the_views_are_taken_as_equally_bright():
    dark = np.zeros(SHAPE, np.float32), np.zeros((*SHAPE, 3), np.uint8)  # a black table: nothing to measure
    assert brightness_gain(*dark, MASK, *dark) == 1.0
    saturated = np.zeros(SHAPE, np.float32), np.full((*SHAPE, 3), 255, np.uint8)
    assert brightness_gain(*saturated, MASK, *saturated) == 1.0


def test_a_colour_change_well_beyond_the_exposure_still_counts_the_cells():
    before = scene([(10, 20, 10, 20, 0.002, GREY)])  # a flat grey flake; after it, a red one lies there
    after = exposed(scene([(10, 20, 10, 20, 0.002, RED)]), 0.7)
    assert target_gone_fraction(*before, MASK, *after, gain=0.7) == 1.0
    assert target_gone_fraction(*before, MASK, *exposed(before, 0.7), gain=0.7) == 0.0
    with pytest.raises(ValueError, match="gain"):
        target_gone_fraction(*before, MASK, *after, gain=0.0)


def test_a_tall_piece_whose_height_stayed_is_not_gone_whatever_the_light_did_to_its_colour():
    # a shadow or a flicker band over the grasp darkens the untouched target alone: the brightness gain,
    # measured away from the grasp, does not see it; the target's height did not fall
    after_height, after_color = scene([TARGET])
    after_color[MASK] = (np.asarray(RED) * 0.4).astype(np.uint8)
    verdict = judge((after_height, after_color))
    assert not verdict.impurity_picked and verdict.gone_fraction == 0.0


def test_a_pieces_height_is_measured_above_its_surroundings():
    assert piece_height(BEFORE[0], MASK) == pytest.approx(0.03)  # a block on the table
    on_block = scene([(6, 24, 6, 24, 0.02, GREY), (10, 20, 10, 20, 0.022, RED)])  # a 2 mm flake on a block
    assert piece_height(on_block[0], MASK) == pytest.approx(0.002, abs=1e-6)
