"""attend's stall look (closer=True; the model's stall_look): the verifier's threshold for a
look the picking loop asks for after pushes that found nothing. The loop's side is specified in
tests/unit/impurity_policy/test_stall_look.py."""

import dataclasses

import pytest
from test_verifier import two_colour_view

from impurity_attention.core import attention as att
from impurity_attention.core import verifier as ver


def coin(threshold=0.6, stall_look=0.25):
    """A model that rates every region 0.5, with its own thresholds (no last look at 0.5)."""
    n = len(ver.FEATURES)
    return ver.RegionVerifier(mean=(0.0,) * n, scale=(1.0,) * n, coef=(0.0,) * n, intercept=0.0,
                              threshold=threshold, last_look=0.99, stall_look=stall_look, low=(-1e9,) * n,
                              high=(1e9,) * n)


def params(**thresholds):
    return att.AttentionParams(verifier=coin(**thresholds))


def test_a_region_below_the_threshold_is_a_target_on_a_closer_look_and_the_reason_says_so():
    color, height, *_ = two_colour_view()
    plain = att.attend(color, height, params(stall_look=0.25))
    assert plain.mode != att.AttentionMode.TARGET and "0.50 < 0.60" in plain.reason
    closer = att.attend(color, height, params(stall_look=0.25), closer=True)
    assert closer.mode == att.AttentionMode.TARGET
    assert "0.50 >= 0.25 (stall look)" in closer.reason


def test_a_closer_look_still_needs_the_stall_threshold():
    color, height, *_ = two_colour_view()
    closer = att.attend(color, height, params(stall_look=0.55), closer=True)
    assert closer.mode != att.AttentionMode.TARGET and "0.50 < 0.55 (stall look)" in closer.reason




def test_the_closer_look_replaces_the_models_threshold_even_a_higher_one():
    color, height, *_ = two_colour_view()
    closer = att.attend(color, height, params(threshold=0.9, stall_look=0.3), closer=True)
    assert closer.mode == att.AttentionMode.TARGET and "0.50 >= 0.30" in closer.reason


@pytest.mark.parametrize("field", ["threshold", "last_look", "stall_look"])
@pytest.mark.parametrize("value", [0.0, 1.0])
def test_a_models_thresholds_outside_0_1_are_refused_by_name(field, value):
    with pytest.raises(ValueError, match=field):
        dataclasses.replace(coin(), **{field: value})
