"""Test-time rules (impurity_policy.core.rules): what each of the ten rules keeps and rules out on a small
hand-built scene, how masks and preferences combine in the pipeline, the presets and the parameters;
then the cell preset in a policy's decisions.

Scenes: a 224 x 224 px height map (2 mm / px) with a 112 px crop at (56, 56), so heightmap pixel
(112, 112) is crop pixel (56, 56). Q maps are (16 rotations, 2 primitives, 112, 112).
"""

import math

import numpy as np
import pytest
import torch
from height_scenes import block, covered_heap

from impurity_common.grid import HeightmapGrid
from impurity_policy.core.change import CHANGE_PIXELS_TAU
from impurity_policy.core.network import GRASP, PUSH, NetworkConfig, QNetwork, valid_action_mask
from impurity_policy.core.policy import MODE_OCCLUDED_REGION, MODE_TARGET, Observation, Policy
from impurity_policy.core.pose import PoseRules, heap_top, pushes_passing
from impurity_policy.core.rules import PRESETS, RULE_ORDER, RuleParams, RulePipeline

torch.set_num_threads(1)
SMALL = NetworkConfig(stem_channels=8, growth=8, block_layers=(2, 2), head_channels=16)
CROP, ORIGIN, ROTATIONS = 112, (56, 56), 16


# ---- scenes -----------------------------------------------------------------------------------------

def _square_mask(rows=slice(50, 63), cols=slice(50, 63)):
    """The target's mask in the crop: by default a 13 px square around crop pixel (56, 56)."""
    mask = np.zeros((CROP, CROP), np.uint8)
    mask[rows, cols] = 255
    return mask


def _observation(mode, height, mask=None, origin=ORIGIN, grid=HeightmapGrid()):
    """The crop of `height` at `origin`; without a mask, the whole crop is the attended region."""
    crop = height[origin[0]:origin[0] + CROP, origin[1]:origin[1] + CROP].copy()
    mask = np.full((CROP, CROP), 255, np.uint8) if mask is None else mask
    return Observation(mode, np.full((CROP, CROP, 3), 150, np.uint8), crop, mask, origin, height, grid)


def _free_target_with_taller_neighbour():
    """The target (26 mm) at the crop's centre and a taller block (45 mm) lying against its +col side."""
    height = np.zeros((224, 224), np.float32)
    block(height, (112, 112), 6, 0.026)
    block(height, (112, 126), 6, 0.045)
    return _observation(MODE_TARGET, height, _square_mask())



def _wedged_target():
    """The target wedged in a 3 x 3 packing of 35 mm blocks; the middle one is where _square_mask() lies."""
    height = np.zeros((224, 224), np.float32)
    for d_row in (-15, 0, 15):
        for d_col in (-15, 0, 15):
            block(height, (112 + d_row, 112 + d_col), 6, 0.035)
    return height


def _q(value=0.0):
    return np.full((ROTATIONS, 2, CROP, CROP), value, np.float32)


def _kept(names, obs, q=None, params=RuleParams()):
    """(R, 2, S, S) bool: the actions `names` leave (finite Q) of `q` (all zeros by default), every
    pixel valid for both primitives."""
    q = _q() if q is None else q
    valid = np.ones((2, CROP, CROP), bool)
    return np.isfinite(RulePipeline(names, params).apply(q, obs, valid, PoseRules(), obs.grid))


# ---- each rule on its own -----------------------------------------------------------------------------
def _scene_observation(moved_pixels: int = 0) -> Observation:
    """20 px crop at (100, 50) of a scene with one 20 x 20 block; `moved_pixels` extra cells raised at
    the map's end (the scene changed there)."""
    height = np.zeros((224, 224), np.float32)
    height[100:120, 50:70] = 0.03
    if moved_pixels:
        height.flat[height.size - moved_pixels:] = 0.05
    size = 20
    return Observation(MODE_OCCLUDED_REGION, np.zeros((size, size, 3), np.uint8),
                       np.zeros((size, size), np.float32), np.full((size, size), 255, np.uint8), (100, 50),
                       height)


def _tried(params=RuleParams(tried_action_radius_px=3)):
    return RulePipeline(["tried_actions"], params)


def _tried_apply(pipeline, obs):
    return pipeline.apply(np.zeros((ROTATIONS, 2, 20, 20), np.float32), obs, np.ones((2, 20, 20), bool),
                          PoseRules(), obs.grid)


def test_tried_actions_rules_out_a_failed_grasp_on_its_closing_axis_until_a_push():
    pipeline, obs = _tried(), _scene_observation()
    pipeline.record(GRASP, (110, 60), 3, obs.height, success=False)  # crop pixel (10, 10)
    q = _tried_apply(pipeline, obs)
    for rotation in (3, 11):  # a grasp: its rotation and the opposite one (the same closing axis)
        assert np.isneginf(q[rotation, GRASP, 10, 10]) and np.isneginf(q[rotation, GRASP, 13, 10])
        assert q[rotation, GRASP, 14, 10] == 0 and q[rotation, GRASP, 10, 14] == 0  # 3 px radius
    assert np.isfinite(q[[r for r in range(ROTATIONS) if r not in (3, 11)], GRASP]).all()
    assert np.isfinite(q[:, PUSH]).all()
    moved = _scene_observation(moved_pixels=CHANGE_PIXELS_TAU + 1)
    assert np.isneginf(_tried_apply(pipeline, moved)[3, GRASP, 10, 10])  # a changed scene is not enough...
    pipeline.record(PUSH, (105, 55), 6, obs.height, success=True)
    assert np.isfinite(_tried_apply(pipeline, obs)[:, GRASP]).all()  # ... a push is


def test_tried_actions_rules_out_a_push_in_its_direction_while_the_scene_is_unchanged():
    pipeline, obs = _tried(), _scene_observation()
    pipeline.record(PUSH, (105, 55), 6, obs.height, success=True)  # crop pixel (5, 5)
    q = _tried_apply(pipeline, _scene_observation(moved_pixels=CHANGE_PIXELS_TAU))  # tau px: unchanged
    assert np.isneginf(q[6, PUSH, 5, 5]) and np.isneginf(q[6, PUSH, 8, 5])
    assert np.isfinite(q[[r for r in range(ROTATIONS) if r != 6], PUSH]).all()  # a push: its direction
    assert np.isfinite(q[:, GRASP]).all()
    assert np.isfinite(_tried_apply(pipeline, _scene_observation(moved_pixels=CHANGE_PIXELS_TAU + 1))).all()
    assert np.isfinite(_tried_apply(pipeline, obs)).all()  # once the scene changed, the push is forgotten


def test_tried_actions_forgets_everything_after_a_grasp_that_lifted_something_or_a_clear():
    pipeline, obs = _tried(), _scene_observation()
    pipeline.record(PUSH, (105, 55), 6, obs.height, success=True)
    pipeline.record(GRASP, (110, 60), 3, obs.height, success=False)
    pipeline.record(GRASP, (30, 30), 5, obs.height, success=True)  # something was lifted
    q = np.zeros((ROTATIONS, 2, 20, 20), np.float32)
    assert pipeline.apply(q, obs, np.ones((2, 20, 20), bool), PoseRules(), obs.grid) is q
    pipeline.record(GRASP, (110, 60), 3, obs.height, success=False)
    pipeline.clear()  # an episode's start
    assert pipeline.apply(q, obs, np.ones((2, 20, 20), bool), PoseRules(), obs.grid) is q


def test_tried_actions_rules_out_every_grasp_after_failed_grasps_in_a_row_until_a_push():
    obs = _scene_observation()
    pipeline = _tried(RuleParams(tried_action_radius_px=3, failed_grasps_before_push=2))
    pipeline.record(GRASP, (110, 60), 3, obs.height, success=False)
    assert np.isfinite(_tried_apply(pipeline, obs)[0, GRASP, 0, 0])  # one failure: other grasps stay open
    pipeline.record(GRASP, (100, 50), 7, obs.height, success=False)
    q = _tried_apply(pipeline, obs)
    assert np.isneginf(q[:, GRASP]).all() and np.isfinite(q[:, PUSH]).all()
    pipeline.record(PUSH, (105, 55), 6, obs.height, success=True)
    assert np.isfinite(_tried_apply(pipeline, obs)[:, GRASP]).all()  # the push reopens grasping


def test_finger_clearance_rules_out_grasps_whose_open_fingers_land_on_a_neighbour():
    height = np.zeros((224, 224), np.float32)
    block(height, (112, 112), 6, 0.026)  # a 26 mm cube
    block(height, (112, 112 + 6 + 2 + 7), 6, 0.035)  # a taller one 4 mm away along +x (+col)
    kept = _kept(["finger_clearance"], _observation(MODE_TARGET, height, _square_mask()))
    assert not kept[0, GRASP, 56, 56] and not kept[8, GRASP, 56, 56]  # closing along x: a pad on it
    assert kept[4, GRASP, 56, 56] and kept[12, GRASP, 56, 56]  # closing along y: clear
    assert kept[:, PUSH].all()
    wedged = _kept(["finger_clearance"], _observation(MODE_TARGET, _wedged_target(), _square_mask()))
    assert not wedged[:, GRASP, 56, 56].any()  # wedged on all sides: no grasp at the target is clear


def test_grasp_on_target_keeps_only_grasps_on_the_targets_mask():
    height = np.zeros((224, 224), np.float32)
    block(height, (112, 112), 6, 0.026)  # the target
    block(height, (112, 140), 6, 0.026)  # a free neighbour, not the target
    mask = _square_mask()
    kept = _kept(["grasp_on_target"], _observation(MODE_TARGET, height, mask))
    assert (kept[:, GRASP] == (mask > 0)[None]).all()
    assert kept[:, PUSH].all()


def test_occluded_push_through_heap_keeps_pushes_that_pass_the_heaps_top():
    obs = _observation(MODE_OCCLUDED_REGION, covered_heap())  # the heap's top at crop (56, 56)
    kept = _kept(["occluded_push_through_heap"], obs)
    assert kept[0, PUSH, 56, 20]  # 36 px before the top, pushing towards it (+col)
    assert not kept[8, PUSH, 56, 20]  # pushing away from it
    assert not kept[0, PUSH, 100, 10]  # passing 44 px beside it
    assert kept[:, GRASP].all()


def test_push_end_inside_rules_out_pushes_that_end_near_the_workspace_edge():
    height = np.zeros((224, 224), np.float32)
    origin = (112, 112)  # the crop covers the map's bottom-right quarter; crop col c is map col 112 + c
    kept = _kept(["push_end_inside"], _observation(MODE_TARGET, height, _square_mask(), origin))
    # +x (rotation 0): a 50 px push from map col 112 + c ends 6 cm (30 px) inside the edge for c <= 31
    assert kept[0, PUSH, 56, 20] and not kept[0, PUSH, 56, 40]
    assert kept[8, PUSH, 56, 100]  # -x from the same side: ends well inside
    assert not kept[4, PUSH, 100, 20]  # +y from near the bottom edge
    assert kept[:, GRASP].all()
    wider = HeightmapGrid(x_max=HeightmapGrid().x_max + 0.1)  # the observation's grid sets the edge
    assert _kept(["push_end_inside"], _observation(MODE_TARGET, height, _square_mask(), origin, wider))[
        0, PUSH, 56, 40]


def test_occluded_push_start_on_flank_prefers_pushes_that_start_on_the_heaps_flank():
    kept = _kept(["occluded_push_start_on_flank"], _observation(MODE_OCCLUDED_REGION, covered_heap()))
    assert kept[:, PUSH, 56, 40].all() and kept[:, PUSH, 40, 70].all()  # on the slab: 50 mm of 90
    assert not kept[:, PUSH, 56, 56].any() and not kept[:, PUSH, 56, 52].any()  # on the pile or by it
    assert not kept[:, PUSH, 56, 10].any()  # on the table
    assert kept[:, GRASP].all()


def test_grasp_where_target_on_top_prefers_grasps_where_the_target_is_the_local_top():
    kept = _kept(["grasp_where_target_on_top"], _free_target_with_taller_neighbour())
    assert kept[:, GRASP, 56, 54].all() and kept[:, GRASP, 56, 56].all()
    assert not kept[:, GRASP, 56, 61].any()  # within 3 px of the taller block: it would be lifted
    assert kept[:, PUSH].all()


def test_target_push_start_near_prefers_pushes_that_start_next_to_the_target():
    kept = _kept(["target_push_start_near"], _free_target_with_taller_neighbour())
    assert kept[:, PUSH, 56, 66].all() and kept[:, PUSH, 40, 56].all()  # 4 and 10 px from the mask
    assert not kept[:, PUSH, 56, 100].any() and not kept[:, PUSH, 20, 20].any()  # farther than 12 px
    assert kept[:, GRASP].all()


def test_grasp_at_target_core_keeps_grasps_at_the_middle_of_the_target_only():
    obs = _observation(MODE_TARGET, np.zeros((224, 224), np.float32), _square_mask())
    kept = _kept(["grasp_at_target_core"], obs)
    assert kept[:, GRASP, 56, 56].all()
    assert not kept[:, GRASP, 56, 51].any() and not kept[:, GRASP, 20, 20].any()  # its edge; off it
    assert kept[:, PUSH].all()


@pytest.mark.parametrize("name", ["finger_clearance", "grasp_on_target", "grasp_where_target_on_top",
                                  "target_push_start_near", "grasp_at_target_core"])
def test_target_rules_do_nothing_without_a_target_in_view(name):
    height = _wedged_target()
    assert not _kept([name], _observation(MODE_TARGET, height, _square_mask())).all()  # they act...
    assert _kept([name], _observation(MODE_OCCLUDED_REGION, height)).all()  # ... not on an occluded region
    if name != "finger_clearance":  # which looks at the gripper, not at the mask
        empty = np.zeros((CROP, CROP), np.uint8)
        assert _kept([name], _observation(MODE_TARGET, height, empty)).all()  # nor on an empty mask


def test_occluded_push_off_edge_prefers_pushes_that_do_not_head_for_a_near_edge():
    height = covered_heap()
    origin = (112, 112)  # the crop covers the map's bottom-right quarter; crop col c is map col 112 + c
    on = RuleParams(occluded_push_edge_margin=0.12)
    obs = _observation(MODE_OCCLUDED_REGION, height, origin=origin)
    kept = _kept(["occluded_push_off_edge"], obs, params=on)
    # +x (rotation 0) from map col 112 + c (its centre) ends (61.5 - c) x 2 mm from the edge: 12 cm or more
    # for c <= 1
    assert kept[0, PUSH, 56, 1] and not kept[0, PUSH, 56, 4]
    assert kept[8, PUSH, 56, 100]  # -x, away from that edge
    assert kept[4 + 8, PUSH, 100, 100]  # -y (rotation 12), away from the bottom edge
    assert not kept[4, PUSH, 56, 56]  # +y towards the bottom edge, ending 1.1 cm from it
    assert not kept[3, PUSH, 56, 1]  # 67.5 degrees off +x: it approaches the bottom edge too
    assert kept[:, GRASP].all()


def test_occluded_push_off_edge_gives_way_when_every_push_heads_for_an_edge():
    height = covered_heap()
    obs = _observation(MODE_OCCLUDED_REGION, height, origin=(112, 112))
    q = _q()
    q[:, PUSH] = -np.inf
    q[0, PUSH, 56, 100] = 0.0  # the one push left: +x, into the edge
    on = RuleParams(occluded_push_edge_margin=0.12)
    assert _kept(["occluded_push_off_edge"], obs, q, params=on)[0, PUSH, 56, 100]
    q[0, PUSH, 56, 1] = 0.0  # with a push that keeps off the edge beside it, that one goes
    assert not _kept(["occluded_push_off_edge"], obs, q, params=on)[0, PUSH, 56, 100]


@pytest.mark.parametrize("name", ["occluded_push_through_heap", "occluded_push_off_edge",
                                  "occluded_push_start_on_flank"])
def test_occluded_region_rules_do_nothing_with_a_target_in_view(name):
    height = covered_heap()
    on = RuleParams(occluded_push_edge_margin=0.12)
    assert not _kept([name], _observation(MODE_OCCLUDED_REGION, height), params=on).all()
    assert _kept([name], _observation(MODE_TARGET, height, _square_mask()), params=on).all()


# ---- masks, preferences and their order -----------------------------------------------------------------
def test_a_preference_gives_way_when_it_would_leave_no_action_of_its_primitive():
    flat = np.zeros((224, 224), np.float32)
    block(flat, (112, 112), 20, 0.05)  # a flat block: no flank at 50-70 % of its top
    assert _kept(["occluded_push_start_on_flank"], _observation(MODE_OCCLUDED_REGION, flat)).all()


def test_a_preference_counts_the_actions_already_at_minus_inf():
    obs = _free_target_with_taller_neighbour()
    q = _q()
    near = _kept(["target_push_start_near"], obs)[0, PUSH]
    q[:, PUSH][:, near] = -np.inf  # every push next to the target ruled out already (e.g. tried)
    kept = _kept(["target_push_start_near"], obs, q)
    assert kept[:, PUSH][:, ~near].all()  # the preference gives way: the far pushes stay


def test_a_mask_applies_even_when_it_leaves_no_action_of_its_primitive():
    obs = _observation(MODE_TARGET, np.zeros((224, 224), np.float32), _square_mask())
    q = _q()
    q[:, GRASP, 53:60, 53:60] = -np.inf  # no grasp left at the target's middle
    kept = _kept(["grasp_at_target_core"], obs, q)
    assert not kept[:, GRASP].any() and kept[:, PUSH].all()  # the policy will push


def test_the_pipeline_returns_a_copy_and_keeps_its_input():
    obs = _observation(MODE_TARGET, _wedged_target(), _square_mask())
    q = _q()
    ruled = RulePipeline.preset("cell").apply(q, obs, np.ones((2, CROP, CROP), bool), PoseRules(), obs.grid)
    assert np.isneginf(ruled).any() and ruled.dtype == q.dtype
    assert (q == 0).all()


def test_the_pipeline_applies_rules_in_rule_order_whatever_order_they_are_named_in():
    assert RulePipeline(RULE_ORDER[::-1]).names == RULE_ORDER
    # A sliver of target beside a taller slab: the target is nowhere the local top, the bare table is.
    height = np.zeros((224, 224), np.float32)
    height[106:119, 106:108] = 0.02  # the target, 2 px wide
    height[100:125, 108:130] = 0.045  # the slab against it
    mask = _square_mask(slice(50, 63), slice(50, 52))
    obs = _observation(MODE_TARGET, height, mask)
    kept = _kept(["grasp_where_target_on_top", "grasp_on_target"], obs)
    # grasp_on_target (a mask, 3rd) first leaves the sliver; grasp_where_target_on_top (a preference, 7th)
    # would then leave nothing and gives way. The other way round, no grasp would be left.
    assert (kept[:, GRASP] == (mask > 0)[None]).all()


# ---- presets and parameters ---------------------------------------------------------------------------
def test_preset_none_leaves_the_q_maps_untouched():
    obs = _observation(MODE_TARGET, _wedged_target(), _square_mask())
    q = _q()
    none = RulePipeline.preset("none")
    assert none.names == () and PRESETS["none"] == ()
    assert none.apply(q, obs, np.ones((2, CROP, CROP), bool), PoseRules(), obs.grid) is q
    assert Policy(QNetwork(SMALL)).rules.names == ()  # a policy's default: the paper's argmax


def test_preset_cell_has_every_rule_in_order_and_can_leave_some_out():
    assert RulePipeline.preset("cell").names == PRESETS["cell"] == RULE_ORDER
    assert len(RULE_ORDER) == 12
    without = RulePipeline.preset("cell", without=("finger_clearance", "grasp_at_target_core")).names
    left_out = ("finger_clearance", "grasp_at_target_core")
    assert without == tuple(n for n in PRESETS["cell"] if n not in left_out)


@pytest.mark.parametrize("make, known", [
    (lambda: RulePipeline.preset("everything"), "known: none, cell"),
    (lambda: RulePipeline(["tried_actions", "telepathy"]), "known: " + ", ".join(RULE_ORDER)),
    (lambda: RulePipeline.preset("cell", without=("telepathy",)), "known: " + ", ".join(RULE_ORDER)),
])
def test_unknown_preset_or_rule_names_are_refused_listing_the_known_ones(make, known):
    with pytest.raises(ValueError) as error:
        make()
    assert "unknown" in str(error.value) and known in str(error.value)


@pytest.mark.parametrize("field, value", [
    ("tried_action_radius_px", -1), ("changed_pixels", -1), ("failed_grasps_before_push", 0),
    ("occluded_push_radius_px", 0), ("target_push_radius_px", -1), ("heap_sigma_px", -0.5),
    ("heap_sigma_px", math.nan), ("push_end_margin", -0.01), ("occluded_push_edge_margin", -0.01),
    ("target_on_top_tolerance", -0.001),
    ("grasp_core_depth_px", -1.0), ("grasp_core_fallback_depth_px", -1.0),
    ("grasp_core_fallback_depth_px", 0.5), ("occluded_push_start_band", (0.7, 0.5)),
    ("occluded_push_start_band", (0.5, 1.2)),
])
def test_rule_params_refuse_a_bad_value_naming_the_field(field, value):
    with pytest.raises(ValueError, match=field):
        RuleParams(**{field: value})


# ---- the cell preset in a policy's decisions ------------------------------------------------------------
def test_policy_pushes_when_no_grasp_is_clear_and_grasps_without_rules():
    torch.manual_seed(0)
    height = _wedged_target()
    obs = Observation(MODE_TARGET, np.full((112, 112, 3), 150, np.uint8), height[56:168, 56:168].copy(),
                      np.full((112, 112), 255, np.uint8), (56, 56), height)
    q = _q()
    q[:, GRASP, 50:62, 50:62] = 1.0  # the network would rather grasp the wedged target
    assert Policy(QNetwork(SMALL)).decide(obs, q=q).decision.primitive == GRASP
    cell = Policy(QNetwork(SMALL), rules=RulePipeline.preset("cell"))
    assert cell.decide(obs, q=q).decision.primitive == PUSH


def test_policy_grasps_on_the_target_and_pushes_through_the_heap():
    height = np.zeros((224, 224), np.float32)
    block(height, (112, 112), 6, 0.026)  # the target, free
    block(height, (112, 140), 6, 0.026)  # a free neighbour, not the target
    mask = _square_mask()
    obs = Observation(MODE_TARGET, np.full((112, 112, 3), 150, np.uint8), height[56:168, 56:168].copy(), mask,
                      (56, 56), height)
    q = _q()
    q[:, PUSH] = -1.0
    q[:, GRASP, 56, 84] = 1.0  # the network prefers the neighbour
    decision = Policy(QNetwork(SMALL), rules=RulePipeline.preset("cell")).decide(obs, q=q).decision
    assert decision.primitive == GRASP and mask[decision.pixel]
    assert Policy(QNetwork(SMALL)).decide(obs, q=q).decision.pixel == (56, 84)
    occluded = Observation(MODE_OCCLUDED_REGION, obs.color_crop, obs.height_crop, np.full_like(mask, 255),
                           (56, 56), height)
    q[:, PUSH] = 0.0
    q[0, PUSH, 100, 10] = 1.0  # the network prefers a push far from the pile
    push = Policy(QNetwork(SMALL), rules=RulePipeline.preset("cell")).decide(occluded, q=q).decision
    assert push.primitive == PUSH
    assert pushes_passing(heap_top(occluded.height_crop, valid_action_mask(112), 6.0), 112, 10)[
        push.rotation][push.pixel]


def test_policy_starts_occluded_region_pushes_on_the_heap_flank():
    height = covered_heap()
    occluded = Observation(MODE_OCCLUDED_REGION, np.full((112, 112, 3), 150, np.uint8),
                           height[56:168, 56:168].copy(), np.full((112, 112), 255, np.uint8), (56, 56),
                           height)
    q = _q()
    q[0, PUSH, 56, 56] = 1.0  # the network prefers to push from the top of the pile
    q[0, PUSH, 56, 40] = 0.5  # from the slab, through the pile
    cell = Policy(QNetwork(SMALL), rules=RulePipeline.preset("cell"))
    assert cell.decide(occluded, q=q).decision.pixel == (56, 40)
    no_flank = RulePipeline.preset("cell", without=("occluded_push_start_on_flank",))
    assert Policy(QNetwork(SMALL), rules=no_flank).decide(occluded, q=q).decision.pixel == (56, 56)
    # a heap without a flank in the band (a flat block): the rule gives way instead of leaving no push
    flat = np.zeros((224, 224), np.float32)
    block(flat, (112, 112), 20, 0.05)
    flat_obs = Observation(MODE_OCCLUDED_REGION, occluded.color_crop, flat[56:168, 56:168].copy(),
                           occluded.mask, (56, 56), flat)
    assert cell.decide(flat_obs, q=q).decision.primitive == PUSH


def test_policy_pushes_next_to_the_target_and_grasps_where_it_is_on_top():
    obs = _free_target_with_taller_neighbour()
    preferences = RulePipeline.preset("cell", without=("finger_clearance", "grasp_at_target_core"))
    q = _q(-1.0)
    q[4, GRASP, 56, 61] = 1.0  # the net's grasp: by the taller block, which it would lift
    q[4, GRASP, 56, 54] = 0.5
    assert Policy(QNetwork(SMALL), rules=preferences).decide(obs, q=q).decision.pixel == (56, 54)
    assert Policy(QNetwork(SMALL)).decide(obs, q=q).decision.pixel == (56, 61)
    q[:, GRASP] = -2.0
    q[8, PUSH, 56, 100] = 1.0  # the net's push: far from the target
    q[8, PUSH, 56, 66] = 0.5  # from beside the target
    assert Policy(QNetwork(SMALL), rules=preferences).decide(obs, q=q).decision.pixel == (56, 66)
    assert Policy(QNetwork(SMALL)).decide(obs, q=q).decision.pixel == (56, 100)


def test_policy_grasps_the_middle_of_a_free_target_or_else_pushes():
    height = np.zeros((224, 224), np.float32)
    block(height, (112, 112), 6, 0.026)  # the target, free
    obs = _observation(MODE_TARGET, height, _square_mask())
    q = _q(-1.0)
    q[:, PUSH] = -2.0
    q[4, GRASP, 56, 51] = 1.0  # the net's grasp: at the target's edge
    q[4, GRASP, 56, 56] = 0.5
    middle = RulePipeline.preset("cell", without=("finger_clearance",))
    assert Policy(QNetwork(SMALL), rules=middle).decide(obs, q=q).decision.pixel == (56, 56)
    assert Policy(QNetwork(SMALL)).decide(obs, q=q).decision.pixel == (56, 51)
    q[:, GRASP, 54:59, 54:59] = -np.inf  # e.g. tried already: no grasp within 2 px of the middle, a push
    assert Policy(QNetwork(SMALL), rules=middle).decide(obs, q=q).decision.primitive == PUSH


def test_with_no_grasp_left_at_the_targets_middle_the_policy_grasps_next_to_it_before_pushing():
    height = np.zeros((224, 224), np.float32)
    block(height, (112, 112), 6, 0.026)  # the target, free: its mask 13 px wide, 7 px deep at (56, 56)
    obs = _observation(MODE_TARGET, height, _square_mask())
    q = _q(-1.0)
    q[:, PUSH] = -2.0
    q[4, GRASP, 56, 51] = 1.0  # the net's grasp: at the target's edge
    q[4, GRASP, 56, 54] = 0.5  # 2 px off the middle (5 px deep)
    q[:, GRASP, 55:58, 55:58] = -np.inf  # no grasp left within grasp_core_depth_px (1 px) of the middle
    middle = Policy(QNetwork(SMALL), rules=RulePipeline.preset("cell", without=("finger_clearance",)))
    decision = middle.decide(obs, q=q).decision
    assert decision.primitive == GRASP and decision.pixel == (56, 54)  # within the fallback's 2 px
    narrow = RuleParams(grasp_core_fallback_depth_px=1.0)
    assert Policy(QNetwork(SMALL), rules=RulePipeline.preset("cell", narrow, without=("finger_clearance",))
                  ).decide(obs, q=q).decision.primitive == PUSH


def test_a_greedy_policy_with_the_cell_rules_does_not_repeat_a_failed_grasp():
    torch.manual_seed(0)
    policy = Policy(QNetwork(), rules=RulePipeline.preset("cell"))
    color = np.full((112, 112, 3), 150, np.uint8)
    height = np.zeros((112, 112), np.float32)
    height[40:70, 40:70] = 0.03
    mask = np.zeros((112, 112), np.uint8)
    mask[45:65, 45:65] = 255
    obs = Observation(MODE_TARGET, color, height, mask, (0, 0), np.pad(height, ((0, 112), (0, 112))))
    q = policy.q_maps(obs)
    q[:, PUSH] = -np.inf  # only grasps compete
    first = policy.decide(obs, q=q)
    assert first.decision.primitive == GRASP
    policy.remember(first.pose, obs.height, success=False)
    second = policy.decide(obs, q=q)
    assert second.decision.primitive == GRASP
    same_axis = second.pose.rotation % 8 == first.pose.rotation % 8
    distance = math.dist(second.pose.heightmap_pixel, first.pose.heightmap_pixel)
    assert not (same_axis and distance <= policy.rules.params.tried_action_radius_px)
    policy.rules.clear()  # a new episode: the failed grasp may be tried again
    assert policy.decide(obs, q=q).decision == first.decision
