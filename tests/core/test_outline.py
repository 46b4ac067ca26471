"""Viewport outlines of the area of influence and the wrinkling region."""

import numpy as np

from tests.core.meshes import grid
from tests.core.test_muscles import linear, sheet
from wrinkle_addon.core.muscles.fields import muscle_field
from wrinkle_addon.core.muscles.outline import muscle_outline


def test_sheet_outline_bounds_the_region():
    m = sheet()
    out = muscle_outline(m)
    assert out["aoi"].shape[1] == 3 and len(out["aoi"]) % 2 == 0
    rest, *_ = grid(120, 80)
    region = rest[muscle_field(rest, m).region]
    lo, hi = out["region"].min(axis=0), out["region"].max(axis=0)
    assert np.all(region[:, [0, 2]] >= lo[[0, 2]] - 1e-9) and np.all(region[:, [0, 2]] <= hi[[0, 2]] + 1e-9)
    # the region lies inside the area of influence
    assert out["aoi"][:, 2].max() >= hi[2] - 1e-9 and out["aoi"][:, 2].min() <= lo[2] + 1e-9


def test_linear_outline_reaches_radius_and_degenerate_muscles_draw_nothing():
    m = linear()
    out = muscle_outline(m)
    d = np.linalg.norm(out["aoi"] - m.attachment[0], axis=1)
    assert np.isclose(d.max(), m.length)
    bad = linear(insertion=m.attachment.copy())
    assert all(len(v) == 0 for v in muscle_outline(bad).values())


def test_sphincter_outline_draws_its_reach_and_its_sector():
    from tests.core.test_sphincter import CENTRE, plane, polar, ring

    m = ring()
    out = muscle_outline(m)
    rho, theta = polar(out["aoi"])
    np.testing.assert_allclose(rho, m.length, atol=1e-9)  # the outer ellipse at the outer reach
    rho, theta = polar(out["region"])
    assert np.isclose(rho.min(), m.lambda_w * m.length)
    assert np.isclose(rho.max(), m.length) and np.isclose(np.abs(theta).max(), m.spread)
    rest, *_ = plane(61)
    region = polar(rest[muscle_field(rest, m).region])
    assert region[0].min() >= rho.min() - 1e-9 and np.abs(region[1]).max() <= m.spread + 1e-9
    assert np.allclose(out["region"][:, 1], CENTRE[1])
