"""The ICT Face Model Light skin (``ict_head.npz``) in Blender's convention.

The file lives outside the repository (see ``shared/data/README.md``); it is
never copied in. ``load_ict`` is pure NumPy; ``ict_object`` needs bpy.

ICT stores centimetres with Y up and the face toward +Z. Blender wants metres,
Z up and the face toward -Y: (x, y, z) -> (x, -z, y) * 0.01, a proper rotation,
so the character's left stays +X.

The landmarks have the same names as ``headgen.make_head``'s and are vertex
positions found from the geometry: the eye holes, the mouth hole and the most
forward point of the nose anchor them; the rest are the surface points seen from
the front at fixed offsets from those anchors (or, for the glabella, chin and
lips, the most forward midline vertex in a height band).
"""

from pathlib import Path

import numpy as np

__all__ = ["DEFAULT_PATH", "load_ict", "ict_object"]

DEFAULT_PATH = Path(__file__).resolve().parents[3] / "shared" / "data" / "ict_head.npz"


def _to_blender(a):
    """ICT (cm, Y up, face +Z) -> Blender (m, Z up, face -Y)."""
    a = np.asarray(a, dtype=np.float32)
    out = np.empty_like(a)
    out[..., 0] = a[..., 0]
    out[..., 1] = -a[..., 2]
    out[..., 2] = a[..., 1]
    return out * np.float32(0.01)


def _boundary_loops(quads):
    """Vertex sets of the boundary loops (edges used by one face)."""
    edges = np.concatenate([quads[:, [0, 1]], quads[:, [1, 2]], quads[:, [2, 3]], quads[:, [3, 0]]])
    edges = np.sort(edges, axis=1)
    uniq, count = np.unique(edges, axis=0, return_counts=True)
    border = uniq[count == 1]
    # Connected components by label propagation over the border edges.
    verts = np.unique(border)
    label = {int(v): int(v) for v in verts}
    lab = np.array([label[int(v)] for v in verts])
    index = np.searchsorted(verts, border)
    while True:
        low = np.minimum(lab[index[:, 0]], lab[index[:, 1]])
        new = lab.copy()
        np.minimum.at(new, index[:, 0], low)
        np.minimum.at(new, index[:, 1], low)
        if np.array_equal(new, lab):
            break
        lab = new
    return [verts[lab == k] for k in np.unique(lab)]


def _vertex_normals(pos, quads):
    p = pos.astype(np.float64)
    n = np.cross(p[quads[:, 2]] - p[quads[:, 0]], p[quads[:, 3]] - p[quads[:, 1]])
    vn = np.zeros_like(p)
    for k in range(4):
        np.add.at(vn, quads[:, k], n)
    return vn / np.maximum(np.linalg.norm(vn, axis=1, keepdims=True), 1e-20)


def _find_landmarks(pos, quads):
    p = pos.astype(np.float64)
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    frontal = _vertex_normals(pos, quads)[:, 1] < -0.25

    loops = _boundary_loops(quads)
    centres = np.array([p[v].mean(axis=0) for v in loops])
    # The neck opening is the lowest loop, the mouth the one on the midline,
    # and the eyes the highest on either side.
    holes = list(np.argsort(centres[:, 2])[1:])
    mouth = min(holes, key=lambda i: abs(centres[i, 0]))
    eye_l = max(holes, key=lambda i: centres[i, 2] if centres[i, 0] > 0.01 else -np.inf)
    eye_r = max(holes, key=lambda i: centres[i, 2] if centres[i, 0] < -0.01 else -np.inf)

    def front(px, pz):
        """The frontal vertex seen from the front at (px, pz)."""
        d2 = (x - px) ** 2 + (z - pz) ** 2 + 1e-6 * y
        d2 = np.where(frontal, d2, np.inf)
        return int(np.argmin(d2))

    def forward(lo, hi, half_width=0.004):
        """The most forward midline vertex with lo < z < hi."""
        sel = frontal & (np.abs(x) < half_width) & (z > lo) & (z < hi)
        idx = np.flatnonzero(sel)
        return int(idx[np.argmin(y[idx])])

    out = {}
    mouth_v = loops[mouth]
    m_left = mouth_v[np.argmax(x[mouth_v])]
    m_right = mouth_v[np.argmin(x[mouth_v])]
    mouth_z = centres[mouth, 2]
    eye_c = {"L": centres[eye_l], "R": centres[eye_r]}
    eye_z = 0.5 * (eye_c["L"][2] + eye_c["R"][2])
    nose = forward(mouth_z, eye_z, 0.01)
    out["nose_tip"] = nose
    out["mouth_corner_L"], out["mouth_corner_R"] = int(m_left), int(m_right)
    out["upper_lip"] = forward(mouth_z, mouth_z + 0.012)
    out["lower_lip"] = forward(mouth_z - 0.015, mouth_z)
    out["chin"] = forward(mouth_z - 0.060, mouth_z - 0.025)
    # Nasion: the deepest midline point between the eyes and the brows;
    # glabella: the most forward one above it.
    band = frontal & (np.abs(x) < 0.004) & (z > eye_z - 0.01) & (z < eye_z + 0.03)
    idx = np.flatnonzero(band)
    nasion_z = z[idx[np.argmax(y[idx])]]
    out["glabella"] = forward(nasion_z, nasion_z + 0.03)
    out["nose_bridge"] = front(0.0, eye_z)
    glab_z = z[out["glabella"]]
    out["hairline_center"] = front(0.0, glab_z + 0.055)
    for side, s in (("L", 1.0), ("R", -1.0)):
        ex, ez = abs(eye_c[side][0]), eye_c[side][2]
        loop = loops[eye_l if side == "L" else eye_r]
        out[f"eye_{side}"] = int(loop[np.argmin(np.linalg.norm(p[loop] - eye_c[side], axis=1))])
        out[f"brow_inner_{side}"] = front(s * (ex - 0.016), ez + 0.018)
        out[f"brow_mid_{side}"] = front(s * ex, ez + 0.022)
        out[f"brow_outer_{side}"] = front(s * (ex + 0.016), ez + 0.019)
        out[f"hairline_{side}"] = front(s * ex, glab_z + 0.050)
        out[f"cheekbone_{side}"] = front(s * (ex + 0.018), ez - 0.022)
        out[f"nose_ala_{side}"] = front(s * 0.0165, z[nose] - 0.007)
        corner = p[out[f"mouth_corner_{side}"]]
        out[f"jaw_{side}"] = front(s * (abs(corner[0]) + 0.004), z[out["chin"]] + 0.004)
        # Lateral cheek: at mouth height, 60 degrees round from the front.
        band = (np.abs(z - corner[2]) < 0.004) & (s * x > 0)
        idx = np.flatnonzero(band)
        centre_y = 0.5 * (y[idx].min() + y[idx].max())
        azimuth = np.degrees(np.arctan2(np.abs(x[idx]), centre_y - y[idx]))
        out[f"cheek_lateral_{side}"] = int(idx[np.argmin(np.abs(azimuth - 60.0))])
    return out


def load_ict(path=DEFAULT_PATH):
    """Read ``ict_head.npz`` into Blender units and axes.

    Returns a dict: ``positions`` (N, 3) float32 metres, ``quads`` (F, 4)
    int32, ``corner_uvs`` (F, 4, 2) float32, ``expression_names`` (list of
    str), ``expression_deltas`` (E, N, 3) float32 metres and ``landmarks``
    (name -> (3,) float32 vertex position, the names of ``headgen``).
    """
    with np.load(Path(path)) as data:
        positions = _to_blender(data["positions"])
        quads = np.ascontiguousarray(data["quads"], dtype=np.int32)
        corner_uvs = np.ascontiguousarray(data["corner_uvs"], dtype=np.float32)
        names = [str(n) for n in data["expression_names"]]
        deltas = _to_blender(data["expression_deltas"])
    index = _find_landmarks(positions, quads)
    landmarks = {name: positions[i].copy() for name, i in sorted(index.items())}
    return {
        "positions": positions,
        "quads": quads,
        "corner_uvs": corner_uvs,
        "expression_names": names,
        "expression_deltas": np.ascontiguousarray(deltas),
        "landmarks": landmarks,
    }


def ict_object(data, name="ICTHead", collection=None):
    """A mesh object with a Basis shape key and one shape key per expression."""
    from .scene_setup import mesh_object_from_arrays

    obj = mesh_object_from_arrays(name, data["positions"], data["quads"], data["corner_uvs"],
                                  collection=collection)
    obj.shape_key_add(name="Basis", from_mix=False)
    base = np.ascontiguousarray(data["positions"], dtype=np.float32)
    for expr, delta in zip(data["expression_names"], data["expression_deltas"]):
        key = obj.shape_key_add(name=expr, from_mix=False)
        key.points.foreach_set("co", (base + delta).astype(np.float32).ravel())
        key.value = 0.0
    obj.data.update()
    return obj
