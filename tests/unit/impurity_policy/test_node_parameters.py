"""The policy and episode nodes declare their parameters from the core dataclasses: each threshold is
declared once, on its core field, and the node's parameter has its name and default."""

import dataclasses

from impurity_common.parameters import parameter_specs
from impurity_policy.core.picking import EpisodeLimits
from impurity_policy.core.pose import PoseRules
from impurity_policy.core.rules import PRESETS, RuleParams
from impurity_policy.core.verdict import VerdictParams
from impurity_policy.episode_node import EpisodeParameters
from impurity_policy.policy_node import PolicyParameters
from impurity_policy.ros_cell import RosCellTimeouts


def _defaults(cls) -> dict:
    return {spec.name: spec.default for spec in parameter_specs(cls)}


def test_every_pose_and_rule_threshold_is_a_policy_parameter_with_its_core_default():
    declared = _defaults(PolicyParameters)
    for core in (PoseRules, RuleParams):
        assert _defaults(core).items() <= declared.items(), core.__name__


def test_the_policy_parameters_serve_as_the_pose_rules_and_the_rule_thresholds():
    params = PolicyParameters(push_end_margin=0.08, grasp_depth=0.025)
    pipeline = params.rule_pipeline()
    assert isinstance(params, PoseRules) and isinstance(params, RuleParams)
    assert pipeline.params.push_end_margin == 0.08 and params.grasp_depth == 0.025
    assert pipeline.names == PRESETS["cell"]  # the node's default preset


def test_every_episode_limit_wait_and_verdict_threshold_is_an_episode_parameter():
    declared = _defaults(EpisodeParameters)
    for core in (EpisodeLimits, RosCellTimeouts):
        assert _defaults(core).items() <= declared.items(), core.__name__
    verdict = {f"verdict.{name}": value for name, value in _defaults(VerdictParams).items()}
    assert verdict.items() <= declared.items()


def test_the_episode_parameters_serve_as_the_episode_limits():
    params = EpisodeParameters(stall_look_views=3, verdict=VerdictParams(min_gone_fraction=0.6))
    assert isinstance(params, EpisodeLimits) and isinstance(params, RosCellTimeouts)
    assert params.verdict.min_gone_fraction == 0.6
    assert {f.name for f in dataclasses.fields(EpisodeLimits)} <= {f.name for f in dataclasses.fields(params)}
