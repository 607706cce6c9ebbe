"""grasp_before_push (impurity_policy.core.rules.GraspBeforePush): with a target in view, the cell grasps it
while a grasp on it is left whose Q value reaches `grasp_before_push_q`, even where the network values a push
higher; it pushes where the grasp rules leave no grasp on the target, or only poor ones.

Scenes: a 224 x 224 px height map (2 mm / px) with a 112 px crop at (56, 56); heightmap pixel (112, 112) is
crop pixel (56, 56). Q maps are (16 rotations, 2 primitives, 112, 112).
"""

import numpy as np
import torch
from height_scenes import block

from impurity_common.grid import HeightmapGrid
from impurity_policy.core.network import GRASP, PUSH, NetworkConfig, QNetwork
from impurity_policy.core.policy import MODE_OCCLUDED_REGION, MODE_TARGET, Observation, Policy
from impurity_policy.core.pose import PoseRules
from impurity_policy.core.rules import RULE_ORDER, RuleParams, RulePipeline

torch.set_num_threads(1)
SMALL = NetworkConfig(stem_channels=8, growth=8, block_layers=(2, 2), head_channels=16)
CROP, ROTATIONS = 112, 16
THRESHOLD = RuleParams().grasp_before_push_q


def _target_mask() -> np.ndarray:
    """The target's mask in the crop: a 13 px square around crop pixel (56, 56)."""
    mask = np.zeros((CROP, CROP), np.uint8)
    mask[50:63, 50:63] = 255
    return mask


def _observation(height: np.ndarray, mode=MODE_TARGET, mask=None) -> Observation:
    mask = _target_mask() if mask is None else mask
    return Observation(mode, np.full((CROP, CROP, 3), 150, np.uint8), height[56:168, 56:168].copy(), mask,
                       (56, 56), height, HeightmapGrid())


def _free_target() -> np.ndarray:
    """A 26 mm target at the crop's centre, and a product block 28 px (56 mm) away."""
    height = np.zeros((224, 224), np.float32)
    block(height, (112, 112), 6, 0.026)
    block(height, (112, 140), 6, 0.026)
    return height


def _wedged_target() -> np.ndarray:
    """The target in the middle of a 3 x 3 packing of 35 mm blocks with 2 px gaps: no open finger fits."""
    height = np.zeros((224, 224), np.float32)
    for d_row in (-15, 0, 15):
        for d_col in (-15, 0, 15):
            block(height, (112 + d_row, 112 + d_col), 6, 0.035)
    return height


def _q(grasp_on_target: float, push: float = 1.0) -> np.ndarray:
    """The network valuing every push at `push` and grasps on the target's mask at `grasp_on_target`
    (elsewhere far lower)."""
    q = np.full((ROTATIONS, 2, CROP, CROP), -1.0, np.float32)
    q[:, PUSH] = push
    q[:, GRASP][:, _target_mask() > 0] = grasp_on_target
    return q


def _cell(**params) -> Policy:
    return Policy(QNetwork(SMALL), rules=RulePipeline.preset("cell", RuleParams(**params)))


def test_the_cell_grasps_a_free_target_that_the_network_would_rather_push():
    obs, q = _observation(_free_target()), _q(grasp_on_target=THRESHOLD + 0.2, push=THRESHOLD + 0.5)
    assert Policy(QNetwork(SMALL)).decide(obs, q=q).decision.primitive == PUSH  # the network alone
    decision = _cell().decide(obs, q=q).decision
    assert decision.primitive == GRASP and _target_mask()[decision.pixel]


def test_the_cell_pushes_when_the_best_grasp_on_the_target_is_valued_below_the_threshold():
    obs, q = _observation(_free_target()), _q(grasp_on_target=THRESHOLD - 0.1, push=THRESHOLD + 0.5)
    assert _cell().decide(obs, q=q).decision.primitive == PUSH
    assert _cell(grasp_before_push_q=THRESHOLD - 0.2).decide(obs, q=q).decision.primitive == GRASP


def test_the_cell_pushes_a_wedged_target_however_high_the_network_values_a_grasp_on_it():
    obs, q = _observation(_wedged_target()), _q(grasp_on_target=THRESHOLD + 0.5, push=THRESHOLD)
    assert _cell().decide(obs, q=q).decision.primitive == PUSH  # finger_clearance left no grasp on it


def test_only_grasps_the_rules_before_it_leave_count():
    height = _free_target()
    obs = _observation(height)
    q = _q(grasp_on_target=THRESHOLD - 0.1, push=THRESHOLD + 0.5)
    q[:, GRASP, 56, 84] = THRESHOLD + 0.5  # a high grasp on the product block beside the target
    valid = np.ones((2, CROP, CROP), bool)
    alone = RulePipeline(["grasp_before_push"]).apply(q, obs, valid, PoseRules(), obs.grid)
    assert np.isneginf(alone[:, PUSH]).all()  # on its own it counts the grasp off the target
    on_target = RulePipeline(["grasp_on_target", "grasp_before_push"]).apply(q, obs, valid, PoseRules(),
                                                                           obs.grid)
    assert np.isfinite(on_target[:, PUSH]).all()  # after grasp_on_target, only poor grasps are left
    assert RULE_ORDER.index("grasp_before_push") > max(
        RULE_ORDER.index(name) for name in ("tried_actions", "finger_clearance", "grasp_on_target",
                                            "grasp_where_target_on_top", "grasp_at_target_core"))


def test_after_failed_grasps_in_a_row_the_cell_pushes_again():
    obs, q = _observation(_free_target()), _q(grasp_on_target=THRESHOLD + 0.2, push=THRESHOLD + 0.5)
    policy = _cell(failed_grasps_before_push=2)
    for _ in range(2):
        choice = policy.decide(obs, q=q)
        assert choice.decision.primitive == GRASP
        policy.remember(choice.pose, obs.height, success=False)
    assert policy.decide(obs, q=q).decision.primitive == PUSH


def test_with_no_target_in_view_pushes_are_left_alone():
    height = _free_target()
    occluded = _observation(height, MODE_OCCLUDED_REGION, np.full((CROP, CROP), 255, np.uint8))
    q = _q(grasp_on_target=THRESHOLD + 0.5)
    valid = np.ones((2, CROP, CROP), bool)
    ruled = RulePipeline(["grasp_before_push"]).apply(q, occluded, valid, PoseRules(), occluded.grid)
    assert np.isfinite(ruled[:, PUSH]).all()
