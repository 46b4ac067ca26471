"""The mesh helpers the per-frame path is built on: bins and normals."""

import numpy as np

from tests.core.meshes import grid
from wrinkle_addon.core import mesh


def test_bins_sum_like_add_at_and_drop_keys_outside_the_domain():
    rng = np.random.default_rng(3)
    keys = rng.integers(0, 40, 500)
    values = rng.normal(size=(3, 500)).astype(np.float32)
    domain = np.arange(0, 40, 2)  # odd keys are dropped
    bins = mesh.Bins.of(keys, domain=domain)
    want = np.zeros((3, 40))
    for c in range(3):
        np.add.at(want[c], keys, values[c])
    got = bins.sum(values)
    assert got.dtype == np.float32 and got.shape == (3, len(domain))
    np.testing.assert_allclose(got, want[:, domain], rtol=1e-5, atol=1e-5)
    default = mesh.Bins.of(keys)
    np.testing.assert_array_equal(default.keys, np.unique(keys))
    np.testing.assert_allclose(default.sum(values[0]), want[0][np.unique(keys)], rtol=1e-5, atol=1e-5)
    assert mesh.Bins.of([], domain=[1, 2]).sum(np.zeros(0, np.float32)).tolist() == [0.0, 0.0]


def test_vertex_normals_are_area_weighted_cross_products():
    rest, _edges, tris, _quads = grid(9, 7)
    rng = np.random.default_rng(1)
    pos = (rest + rng.normal(scale=0.002, size=rest.shape)).astype(np.float32)
    fn = np.cross(pos[tris[:, 1]] - pos[tris[:, 0]], pos[tris[:, 2]] - pos[tris[:, 0]])
    want = np.zeros_like(fn, shape=pos.shape)
    for k in range(3):
        np.add.at(want, tris[:, k], fn)
    want /= np.linalg.norm(want, axis=1, keepdims=True)
    np.testing.assert_allclose(mesh.vertex_normals(pos, tris, len(pos)), want, atol=1e-5)
    lonely = mesh.vertex_normals(np.vstack([pos, [[9, 9, 9]]]).astype(np.float32), tris, len(pos) + 1)
    assert np.all(lonely[-1] == 0.0)  # a vertex without triangles gets no direction
