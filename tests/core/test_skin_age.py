"""Skin Age's factors (core.skin_age): 1 at the neutral age, so old files look as they
did; young skin has no fine wrinkles at rest, shallower and more regular furrows; old skin
the reverse; bad ages are neutral."""

import math

import numpy as np
import pytest

from wrinkle_addon.core import skin_age
from wrinkle_addon.core.bando import field


def test_every_factor_is_one_at_the_neutral_age():
    a = skin_age.NEUTRAL
    assert skin_age.rest_factor(a) == skin_age.depth_factor(a) == skin_age.irregularity_factor(a) == 1.0
    assert skin_age.rest_height(0.5, a) == 0.5 and skin_age.rest_height(0.37, a) == 0.37


def test_each_factor_grows_with_age_from_young_to_old():
    ages = np.linspace(0.0, 1.0, 11)
    for f in (skin_age.rest_factor, skin_age.depth_factor, skin_age.irregularity_factor):
        values = [f(a) for a in ages]
        assert all(b > a for a, b in zip(values, values[1:])), f.__name__
    assert skin_age.rest_height(0.5, 0.0) == 0.0  # young: no fine crackle at rest
    assert skin_age.rest_height(0.5, 1.0) == 1.0  # old: full height at rest
    assert skin_age.rest_height(0.8, 1.0) == 1.0  # clamped
    assert skin_age.depth_factor(0.0) == pytest.approx(0.6)
    assert skin_age.depth_factor(1.0) == pytest.approx(1.4)
    assert skin_age.irregularity_factor(0.0) == 0.5 and skin_age.irregularity_factor(1.0) == 1.5
    assert 0.0 < skin_age.YOUNG < skin_age.NEUTRAL


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_a_non_finite_age_is_neutral_and_out_of_range_is_clamped(bad):
    assert skin_age.clamp(bad) == skin_age.NEUTRAL
    assert skin_age.depth_factor(bad) == 1.0
    assert skin_age.clamp(-3.0) == 0.0 and skin_age.clamp(7.0) == 1.0
    assert skin_age.rest_height(math.nan, 0.5) == 0.0


def test_young_fine_wrinkles_still_fold_where_the_skin_compresses():
    """At Skin Age 0 the effective r is 0: Bando's eq. 5 gives nothing at rest or where
    the skin stretches, and the full rise where it compresses."""
    r = skin_age.rest_height(0.5, 0.0)
    s = np.array([-0.5, 0.0, 0.3, 1.0])
    m = field.modulation(s, r)
    np.testing.assert_allclose(m, [0.0, 0.0, 0.3, 1.0], atol=1e-12)
    old = field.modulation(s, skin_age.rest_height(0.5, 1.0))
    assert np.all(old >= m) and old[1] == 1.0
