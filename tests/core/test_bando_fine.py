"""Fine wrinkles per frame (Bando et al. 2002, §7): both fields' shrinkage at the mesh's
vertices equals ``field.shrinkage`` at each vertex's copy, seams included; and skin
directions turn into texture-space vectors of the same skin length."""

import numpy as np
import pytest

from wrinkle_addon.core.bando import field, fine, mapped


def _sheet(n=31, seam=True):
    x, y = np.meshgrid(np.linspace(0, 0.1, n), np.linspace(0, 0.06, n))
    rest = np.stack([x.ravel(), y.ravel(), 0.01 * np.sin(30 * x.ravel())], 1)
    i = np.arange(n - 1)
    a = (i[:, None] * n + i[None, :]).ravel()
    tris = np.concatenate([np.stack([a, a + 1, a + n + 1], 1), np.stack([a, a + n + 1, a + n], 1)])
    uv = np.stack([x.ravel() / 0.1 * 0.8 + 0.1, y.ravel() / 0.06 * 0.8 + 0.1], 1)[tris]
    if seam:  # the right half is its own island
        right = uv[:, :, 0].mean(1) > 0.5
        uv[right, :, 1] += 1e-6
    return rest, tris, mapped.mapped_mesh(tris, uv, len(rest))


def test_both_fields_match_the_reference_at_every_vertex():
    rest, _tris, m = _sheet()
    rng = np.random.default_rng(0)
    f1 = np.stack([np.ones(len(m.uv)), 0.3 * np.sin(20 * m.uv[:, 1])], 1)
    f2 = field.rotate(f1, 1.1)
    plan = fine.plan(m, rest, f1, f2)
    skin = (rest * [1.0, 0.8, 1.0] + 1e-5 * rng.standard_normal(rest.shape)).astype(np.float32)
    got = fine.shrinkages(plan, skin)
    rep = np.zeros(m.n_verts, np.int64)
    rep[m.vert_of] = np.arange(len(m.vert_of))
    for k, f in enumerate((f1, f2)):
        ref = field.shrinkage(field.shrinkage_plan(m.uv, m.tris, f, m.positions(rest)), skin[m.vert_of])
        np.testing.assert_allclose(got[k], ref[rep], atol=2e-5)
    assert got[0].mean() > 0.1  # the squash along y is across field 1's furrows (along u)


def test_rows_without_a_direction_measure_no_edge_and_out_is_filled():
    rest, _tris, m = _sheet()
    f1 = np.stack([np.ones(len(m.uv)), 0.3 * np.sin(20 * m.uv[:, 1])], 1)
    f2 = np.where((m.uv[:, 0] < 0.5)[:, None], field.rotate(f1, 1.1), 0.0)  # no field 2 on the right
    plan = fine.plan(m, rest, f1, f2)
    assert plan.none.any() and np.all(plan.ends[0] != plan.ends[1])  # no zero-length edge measured
    skin = (rest * [1.0, 0.8, 1.0]).astype(np.float32)
    out = np.full((2, m.n_verts), np.nan, np.float32)
    got = fine.shrinkages(plan, skin, out)
    assert got is out or np.shares_memory(got, out)
    np.testing.assert_array_equal(out, fine.shrinkages(plan, skin))
    rep = np.zeros(m.n_verts, np.int64)
    rep[m.vert_of] = np.arange(len(m.vert_of))
    for k, f in enumerate((f1, f2)):
        ref = field.shrinkage(field.shrinkage_plan(m.uv, m.tris, f, m.positions(rest)), skin[m.vert_of])
        np.testing.assert_allclose(out[k], ref[rep], atol=2e-5)
    assert np.all(out[1][m.vert_of[m.uv[:, 0] > 0.5]] == 0.0)
    with pytest.raises(ValueError):
        fine.shrinkages(plan, skin[:-1])


def test_uv_directions_keep_the_skin_length_and_direction():
    rest, _tris, m = _sheet(seam=False)
    pos = m.positions(rest)
    v = np.tile([0.5, 0.0, 0.0], (len(pos), 1))  # along x on the skin
    uvd = fine.uv_directions(pos, m.uv, m.tris, v)
    flat = np.abs(np.cos(30 * pos[:, 0])) > 0.99  # where the sheet is level, x maps to u
    np.testing.assert_allclose(np.linalg.norm(uvd, axis=1), 0.5, rtol=1e-6)
    assert np.all(np.abs(uvd[flat, 1]) < 1e-6)


@pytest.mark.parametrize("missing_field", [False, True], ids=["both-fields", "field-2-partly-missing"])
def test_the_tree_transcription_computes_exactly_the_reference(missing_field):
    """The per-vertex slots the Geometry Nodes tree reads, evaluated as the tree does
    (``slot_shrinkages``), give the reference ``shrinkages`` bit for bit: on a squash, a
    stretch and a random jitter, with seams and vertices that have no direction."""
    rest, _tris, m = _sheet()
    f1 = np.stack([np.ones(len(m.uv)), 0.3 * np.sin(20 * m.uv[:, 1])], 1)
    f2 = field.rotate(f1, 1.1)
    if missing_field:
        f2 = np.where((m.uv[:, 0] < 0.5)[:, None], f2, 0.0)
    plan = fine.plan(m, rest, f1, f2)
    slots = fine.vertex_slots(plan)
    n = len(rest)
    assert slots.far.shape == (2, 4, n) and slots.far.dtype == np.int32
    assert slots.coef.dtype == np.float32 and slots.share.shape == (2, n)
    assert np.all((slots.far >= 0) & (slots.far < n))
    rng = np.random.default_rng(3)
    for skin in (rest * [1.0, 0.8, 1.0], rest * [1.1, 1.3, 1.0],
                 rest + 2e-3 * rng.standard_normal(rest.shape)):
        skin = skin.astype(np.float32)
        want = fine.shrinkages(plan, skin)
        got = fine.slot_shrinkages(slots, skin)
        np.testing.assert_array_equal(got, want)
    # no direction on the right half: a share of 0 there (a corner of the sheet may have none)
    assert ((slots.share[1] == 0).sum() > n // 3) == missing_field
