"""The mapped mesh (Bando et al. 2002, §4): seam vertices split, values averaged back."""

import numpy as np
import pytest

from wrinkle_addon.core.bando import mapped


def _strip():
    # two quads side by side (vertices 0..5), the right quad's UVs moved to another island,
    # so vertices 1 and 4 (the shared edge) are on a seam
    tris = np.array([[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4]])
    pos_uv = {0: (0, 0), 1: (0.5, 0), 3: (0, 0.5), 4: (0.5, 0.5), 2: (1, 0), 5: (1, 0.5)}
    uv = np.array([[pos_uv[v] for v in t] for t in tris], float)
    uv[2:] += (0.2, 0.6)  # the right quad is its own island
    return tris, uv


def test_seam_vertices_are_split_and_islands_disconnected():
    tris, uv = _strip()
    m = mapped.mapped_mesh(tris, uv, 6)
    assert len(m.uv) == 8  # 6 vertices, 2 of them on the seam
    assert sorted(np.bincount(m.vert_of).tolist()) == [1, 1, 1, 1, 2, 2]
    np.testing.assert_array_equal(m.vert_of[m.tris], tris)
    np.testing.assert_allclose(m.uv[m.tris], uv)
    left, right = set(m.tris[:2].ravel()), set(m.tris[2:].ravel())
    assert not left & right


def test_values_go_back_to_vertices_averaged():
    tris, uv = _strip()
    m = mapped.mapped_mesh(tris, uv, 7)  # vertex 6 is in no triangle
    vals = m.uv[:, 0] + 10 * m.uv[:, 1]
    back = m.to_vertices(vals)
    assert back.shape == (7,) and back[6] == 0.0
    for v in range(6):
        np.testing.assert_allclose(back[v], vals[m.vert_of == v].mean())
    both = m.to_vertices(np.stack([vals, 2 * vals], 1), verts=np.array([1, 4]))
    np.testing.assert_allclose(both[:, 1], 2 * both[:, 0])


def test_mismatched_uvs_are_refused():
    tris, uv = _strip()
    with pytest.raises(ValueError, match="corner UVs"):
        mapped.mapped_mesh(tris, uv[:3], 6)
