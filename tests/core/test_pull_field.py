"""The Waters pull is a smooth field: no shear streaks at any border of a muscle's area of
influence (C¹ fall-offs across a sheet's width, along its length, at the slab around its
plane and across a linear muscle's cone), and furrows that keep one depth across sheets."""

import numpy as np
import pytest

from tests.core.test_muscles import linear
from wrinkle_addon.core import mesh
from wrinkle_addon.core.muscles import system
from wrinkle_addon.core.muscles.muscle import SHEET, Muscle


def forehead(nx=141, nz=81, width=0.14, height=0.08, radius=0.06):
    """A grid bent around a vertical cylinder (a forehead seen from the front, facing -Y):
    the sheets' slab (``depth``) cuts through it at the temples."""
    x, z = np.meshgrid(np.linspace(-width / 2, width / 2, nx), np.linspace(0.0, height, nz))
    ang = x / radius
    rest = np.stack([radius * np.sin(ang), radius * (1.0 - np.cos(ang)), z], -1).reshape(-1, 3)
    idx = np.arange(nx * nz).reshape(nz, nx)
    quads = np.stack([idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(),
                      idx[1:, :-1].ravel()], 1)
    edges = np.concatenate([np.stack([idx[:, :-1].ravel(), idx[:, 1:].ravel()], 1),
                            np.stack([idx[:-1, :].ravel(), idx[1:, :].ravel()], 1)])
    tris = mesh.fan_triangles(quads.ravel(), np.arange(len(quads)) * 4, np.full(len(quads), 4))
    return rest, edges, tris


def sheet(x0, x1, **kw):
    base = dict(kind=SHEET, attachment=np.array([[x0, 0, 0.07], [x1, 0, 0.07]]),
                insertion=np.array([[x0, 0, 0.02], [x1, 0, 0.02]]), length=0.075,
                spread=abs(x1 - x0), spread_c=abs(x1 - x0) / 6.0, lambda_w=0.0, n_wrinkles=5,
                k0=0.001, alpha=1.0, pull=0.08, depth=0.012, back_reach=0.15)
    base.update(kw)
    return Muscle(**base)


def strain_jump(nx, nz, muscles):
    """The largest change of the pull's strain |L' - L| / L between an edge and its parallel
    neighbour on the grid, over the largest strain (every muscle fully contracted).

    A C¹ field changes its strain by about the grid step times the strain's gradient from
    one edge to the next: a small fraction of the largest strain on this 1 mm grid, whose
    fall-offs are 5 mm wide or more.  A hard cut or a kink in the profile (a slab cut, a
    cone's side, the end of a cosine fall-off) steps the strain from nothing to its full
    value across one edge: the ratio is then near 1."""
    rest, edges, tris = forehead(nx, nz)
    plan = system.build_plan(rest, edges, tris, muscles)
    off = system.evaluate(plan, rest.astype(np.float32), np.ones(len(muscles)), strength=0.0)
    rest_len = mesh.edge_lengths(rest, edges)
    strain = np.abs(mesh.edge_lengths(rest + off, edges) - rest_len) / rest_len
    h = strain[: nz * (nx - 1)].reshape(nz, nx - 1)
    v = strain[nz * (nx - 1):].reshape(nz - 1, nx)
    jumps = [np.abs(np.diff(g, axis=a)).max() for g in (h, v) for a in (0, 1)]
    return max(jumps) / strain.max()


@pytest.mark.parametrize("case", ["sheets", "linear"])
def test_the_pull_has_no_shear_streaks(case):
    if case == "sheets":
        # laid out as the Frontalis preset: centres D apart, 1.5 D wide, h_c = D / 4
        muscles = [sheet(-0.07, -0.01), sheet(-0.03, 0.03), sheet(0.01, 0.07)]
    else:
        muscles = [linear(insertion=np.array([[0.03, 0.0, 0.04]]), length=0.045, pull=0.15)]
    ratio = strain_jump(141, 81, muscles)
    assert 0.0 < ratio < 0.35, ratio  # a cut or a kink gives 0.96-1.0 here


def test_strain_is_continuous_across_the_line_of_convergence():
    """A sheet that reaches behind its attachment line pulls both sides toward the line with
    the same slope: the strain of vertical edges next to the line matches on both sides."""
    rest, edges, tris = forehead(nx=41, nz=161)
    m = sheet(-0.05, 0.05, spread=0.1, spread_c=0.04, depth=0.2, back_reach=0.5)
    plan = system.build_plan(rest, edges, tris, [m])
    off = system.evaluate(plan, rest.astype(np.float32), np.ones(1), strength=0.0)
    centre = np.abs(rest[:, 0]) < 1e-9
    z = rest[centre, 2]
    dz = off[centre, 2]
    assert np.all(dz[z > 0.07 + 1e-6][:5] <= 0.0)  # above the line: moved down, toward it
    assert np.all(dz[z < 0.07 - 1e-6][-5:] >= 0.0)  # below: moved up, toward it
    slope = np.diff(dz) / np.diff(z)
    mid = 0.5 * (z[1:] + z[:-1])
    above = slope[(mid > 0.07) & (mid < 0.0725)]
    below = slope[(mid < 0.07) & (mid > 0.0675)]
    assert above.mean() == pytest.approx(below.mean(), rel=0.1)
    assert below.mean() < 0.0  # both sides converge: the line itself is compressed


def test_neighbouring_sheets_keep_one_furrow_depth():
    """Two sheets whose attenuation ramps overlap (as the Frontalis preset lays them out)
    sum to one amplitude across their border: the furrow does not dip or bump there."""
    rest, edges, tris = forehead(nx=281, nz=81)
    # centres D = 0.06 apart, each 1.5 D wide with h_c = D / 4: both ramps span |x| < D / 4
    a = sheet(-0.075, 0.015, depth=0.2)
    b = sheet(-0.015, 0.075, depth=0.2)
    pair = system.build_plan(rest, edges, tris, [a, b])
    one = system.build_plan(rest, edges, tris, [sheet(-0.075, 0.075, spread_c=0.06, depth=0.2)])

    def amplitude(plan):
        amp = np.zeros(len(rest))
        np.add.at(amp, plan.verts[plan.row_vert], plan.row_amp)
        return amp

    near = np.abs(rest[:, 0]) < 0.012  # the border's ramps
    np.testing.assert_allclose(amplitude(pair)[near], amplitude(one)[near], atol=1e-9)
