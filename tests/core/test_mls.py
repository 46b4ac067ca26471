"""Moving least squares ("Pattern functions and tears", §4.2) and the shedding tear's
roughness and reveal."""

import numpy as np
import pytest

from wrinkle_addon.core.patterns import mls, tears

RNG = np.random.default_rng(11)


@pytest.mark.parametrize("degree", [0, 1, 2, 3])
@pytest.mark.parametrize("eps", [0.0, 0.05, 0.5])
def test_the_fit_reproduces_polynomials_of_its_degree(degree, eps):
    p = RNG.uniform(-1, 1, (80, 2))
    q = RNG.uniform(-0.8, 0.8, (40, 2))
    exps = mls.exponents(2, degree)
    c = RNG.normal(size=len(exps))
    f = mls.basis(p, exps) @ c
    np.testing.assert_allclose(mls.fit(p, f, q, degree, eps), mls.basis(q, exps) @ c, atol=1e-7)


def test_with_eps_zero_it_interpolates_and_with_eps_it_smooths():
    p = RNG.uniform(-1, 1, (60, 2))
    f = RNG.normal(size=60)
    np.testing.assert_allclose(mls.fit(p, f, p, 1, 0.0), f, atol=1e-9)
    smooth = mls.fit(p, f, p, 1, 0.5)
    assert np.std(smooth) < 0.8 * np.std(f)


def test_the_basis_and_bad_input():
    assert len(mls.exponents(2, 2)) == 6 and len(mls.exponents(3, 2)) == 10
    with pytest.raises(ValueError):
        mls.fit(np.zeros((2, 2)), np.zeros(2), np.zeros((1, 2)), degree=1)


def test_the_noise_only_rises_and_is_seeded():
    uv = np.stack(np.meshgrid(np.linspace(0, 0.02, 30), np.linspace(0, 0.004, 8)), -1).reshape(-1, 2)
    a = tears.rise_noise(uv, 0.2, 0.0004, seed=3, eps=0.001)
    assert (a >= 0).all() and a.max() > 0
    np.testing.assert_array_equal(a, tears.rise_noise(uv, 0.2, 0.0004, seed=3, eps=0.001))
    assert (a != tears.rise_noise(uv, 0.2, 0.0004, seed=4, eps=0.001)).any()
    assert (tears.rise_noise(uv, 0.0, 0.0004, 3, 0.001) == 0).all()


def test_the_revealed_length_is_monotone_in_time_and_the_head_is_smooth():
    t = np.linspace(0, 5, 200)
    h = tears.revealed(t, 0.002, 0.01)
    assert (np.diff(h) > 0).all() and h[0] == pytest.approx(0.002)
    assert (tears.revealed(t, -0.01, 0.01) >= 0).all()
    arc = np.linspace(0, 0.05, 501)
    prof = tears.reveal_profile(arc, 0.03, 0.004)
    assert (prof[arc <= 0.026] == 1).all() and (prof[arc >= 0.03] == 0).all()
    assert (np.diff(prof) <= 1e-15).all()
    shown = [int((tears.reveal_profile(arc, L, 0.004) > 0).sum()) for L in tears.revealed(t, 0.002, 0.01)]
    assert all(a <= b for a, b in zip(shown, shown[1:]))
