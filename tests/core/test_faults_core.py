"""Core maths stays finite on input that is not: a NaN or infinite tension gain, and
map pixels that are NaN or infinite (cleaned and counted for the converters)."""

import numpy as np
import pytest

from wrinkle_addon.core.maps import jimenez as wm


def _masks_and_compression():
    masks = np.zeros((4, 8), np.float32)
    masks[:2, 0] = 1.0
    masks[2:, 3] = 1.0
    compression = np.array([0.1, 0.3, 0.0, 0.2], np.float32)
    return masks, compression


@pytest.mark.parametrize("gain", [float("nan"), float("inf"), float("-inf"), np.float32("nan")])
def test_zone_tension_is_finite_for_a_non_finite_gain(gain):
    masks, compression = _masks_and_compression()
    out = wm.zone_tension(masks, compression, gain)
    assert out.shape == (8,) and out.dtype == np.float32
    assert np.isfinite(out).all()
    np.testing.assert_array_equal(out, 0.0)  # a gain that is not a number gives no wrinkles


def test_zone_tension_is_finite_for_nan_masks_and_a_huge_gain():
    masks, compression = _masks_and_compression()
    masks[1, 0] = np.nan
    out = wm.zone_tension(masks, compression, 3.4e38)
    assert np.isfinite(out).all() and out.min() >= 0.0 and out.max() <= 1.0
    np.testing.assert_allclose(out[[0, 3]], 1.0)
    # finite input: unchanged behaviour
    masks, compression = _masks_and_compression()
    np.testing.assert_allclose(wm.zone_tension(masks, compression, 2.0)[[0, 3]], [0.4, 0.2], atol=1e-6)


def _with_bad_pixels(rgb):
    rgb = np.array(rgb, np.float32)
    rgb[0, 0, 0] = np.nan
    rgb[1, 2, 1] = np.inf
    rgb[3, 3, 2] = -np.inf
    return rgb


def test_replace_non_finite_counts_and_flattens_the_pixels_read():
    normal = _with_bad_pixels(np.full((4, 5, 4), 0.6, np.float32))
    normal[2, 4, 3] = np.nan  # alpha is not read: neither counted nor changed
    (clean,), n = wm.replace_non_finite([normal], wm.FLAT_NORMAL)
    assert n == 3
    np.testing.assert_array_equal(clean[0, 0, :3], wm.FLAT_NORMAL)
    np.testing.assert_array_equal(clean[1, 2, :3], wm.FLAT_NORMAL)
    np.testing.assert_array_equal(clean[3, 3, :3], wm.FLAT_NORMAL)
    assert clean[0, 1, 0] == np.float32(0.6) and np.isnan(clean[2, 4, 3])
    assert np.isnan(normal[0, 0, 0])  # the input is not changed
    out = wm.normal_to_derivative(clean)
    assert np.isfinite(out).all()
    np.testing.assert_allclose(out[0, 0], (0.5, 0.5, 0.0), atol=1e-7)
    # a PD map: only R and G are read
    pd = _with_bad_pixels(np.full((4, 5, 3), 0.4, np.float32))
    (clean,), n = wm.replace_non_finite([pd], wm.FLAT_DERIVATIVE)
    assert n == 2
    out = wm.derivative_to_normal(clean)
    assert np.isfinite(out).all()
    np.testing.assert_allclose(out[1, 2], wm.FLAT_NORMAL, atol=1e-7)


def test_replace_non_finite_flattens_a_pixel_of_either_map_in_both():
    base = _with_bad_pixels(np.full((4, 5, 3), 0.5, np.float32))
    wrinkle = np.full((4, 5, 3), 0.7, np.float32)
    wrinkle[0, 0, 2] = np.nan  # the same pixel as the base's NaN: one pixel
    wrinkle[2, 2, 0] = np.inf
    (b, w), n = wm.replace_non_finite([base, wrinkle], wm.FLAT_NORMAL)
    assert n == 4
    diff = wm.difference_map(b, w)
    assert np.isfinite(diff).all()
    for row, col in ((0, 0), (1, 2), (3, 3), (2, 2)):
        np.testing.assert_allclose(diff[row, col], wm.FLAT_DIFFERENCE, atol=1e-7)
    np.testing.assert_allclose(diff[0, 1], 0.5 + 0.5 * (0.7 - 0.5), atol=1e-6)


def test_replace_non_finite_returns_finite_maps_as_they_are():
    a = np.full((2, 2, 4), 0.25, np.float32)
    (same,), n = wm.replace_non_finite([a], wm.FLAT_NORMAL)
    assert n == 0 and same is a


def test_the_converters_without_cleaning_let_non_finite_pixels_through():
    """Why the converters clean first: the maths alone passes infinities on as NaN."""
    normal = _with_bad_pixels(np.full((4, 5, 3), 0.6, np.float32))
    with np.errstate(invalid="ignore"):
        assert not np.isfinite(wm.normal_to_derivative(normal)).all()
        assert not np.isfinite(wm.difference_map(normal, normal)).all()
