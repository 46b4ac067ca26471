"""The ICT Face Model Light skin (``ict_head.npz``) in Blender's convention.

The file is the add-on's sample data (``wrinkle_addon/data/``, written by
``tools/ict_to_npz.py``). ``load_ict`` is pure NumPy; ``ict_object`` needs bpy.

ICT stores centimetres with Y up and the face toward +Z. Blender wants metres,
Z up and the face toward -Y: (x, y, z) -> (x, -z, y) * 0.01, a proper rotation,
so the character's left stays +X.

The landmarks have the same names as ``headgen.make_head``'s. The eight the add-on
uses come from its own finder (``wrinkle_addon.core.landmark_finder``, which
reads the eye and mouth openings here), the right side mirrored; headgen's extra
names are frontal vertices at fixed offsets from those (or, for the lips, the most
forward midline vertex in a height band).
"""

from pathlib import Path

import numpy as np

__all__ = ["DEFAULT_PATH", "load_ict", "ict_object", "DRESS"]

#: Whether :func:`ict_object` dresses the head as Add Sample Head does (skin material, eyes,
#: lashes, teeth): the demo and the showcase switch it on; the tests keep the bare skin.
DRESS = {"on": False}

DEFAULT_PATH = Path(__file__).resolve().parents[2] / "wrinkle_addon" / "data" / "ict_head.npz"


def _to_blender(a):
    """ICT (cm, Y up, face +Z) -> Blender (m, Z up, face -Y)."""
    a = np.asarray(a, dtype=np.float32)
    out = np.empty_like(a)
    out[..., 0] = a[..., 0]
    out[..., 1] = -a[..., 2]
    out[..., 2] = a[..., 1]
    return out * np.float32(0.01)


def _vertex_normals(pos, quads):
    p = pos.astype(np.float64)
    n = np.cross(p[quads[:, 2]] - p[quads[:, 0]], p[quads[:, 3]] - p[quads[:, 1]])
    vn = np.zeros_like(p)
    for k in range(4):
        np.add.at(vn, quads[:, k], n)
    return vn / np.maximum(np.linalg.norm(vn, axis=1, keepdims=True), 1e-20)


def _find_landmarks(pos, quads):
    """``headgen.LANDMARK_NAMES`` -> (3,) float64 point: the add-on's eight from its own
    finder (``landmark_finder``), their right-side mirrors, and headgen's extra names as
    frontal vertices at offsets from them."""
    from wrinkle_addon.core import landmark_finder

    found, _method, _message = landmark_finder.find_landmarks(pos, quads)
    p = pos.astype(np.float64)
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    frontal = _vertex_normals(pos, quads)[:, 1] < -0.25
    mid = float(found["glabella"][0])

    def front(px, pz):
        """The frontal vertex seen from the front at (px, pz)."""
        d2 = np.where(frontal, (x - px) ** 2 + (z - pz) ** 2 + 1e-6 * y, np.inf)
        return p[int(np.argmin(d2))]

    def forward(lo, hi, half_width=0.004):
        """The most forward midline vertex with lo < z < hi."""
        idx = np.flatnonzero(frontal & (np.abs(x - mid) < half_width) & (z > lo) & (z < hi))
        return p[idx[np.argmin(y[idx])]]

    out = {k: np.asarray(v, np.float64) for k, v in found.items()}
    for key in ("eye", "brow_outer", "mouth_corner", "cheekbone"):
        out[key + "_R"] = out[key + "_L"] * (-1.0, 1.0, 1.0) + (2.0 * mid, 0.0, 0.0)
    mouth_z = out["mouth_corner_L"][2]
    eye_z, glab_z, nose = out["eye_L"][2], out["glabella"][2], out["nose_tip"]
    out["upper_lip"] = forward(mouth_z, mouth_z + 0.012)
    out["lower_lip"] = forward(mouth_z - 0.015, mouth_z)
    out["nose_bridge"] = front(mid, eye_z)
    for side, s in (("L", 1.0), ("R", -1.0)):
        ex = abs(out[f"eye_{side}"][0] - mid)
        out[f"brow_inner_{side}"] = front(mid + s * (ex - 0.016), eye_z + 0.018)
        out[f"brow_mid_{side}"] = front(mid + s * ex, eye_z + 0.022)
        out[f"hairline_{side}"] = front(mid + s * ex, glab_z + 0.050)
        out[f"nose_ala_{side}"] = front(mid + s * 0.0165, nose[2] - 0.007)
        corner = out[f"mouth_corner_{side}"]
        out[f"jaw_{side}"] = front(mid + s * (abs(corner[0] - mid) + 0.004), out["chin"][2] + 0.004)
        # Lateral cheek: at mouth height, 60 degrees round from the front.
        idx = np.flatnonzero((np.abs(z - corner[2]) < 0.004) & (s * (x - mid) > 0))
        centre_y = 0.5 * (y[idx].min() + y[idx].max())
        azimuth = np.degrees(np.arctan2(np.abs(x[idx] - mid), centre_y - y[idx]))
        out[f"cheek_lateral_{side}"] = p[int(idx[np.argmin(np.abs(azimuth - 60.0))])]
    return out


def load_ict(path=DEFAULT_PATH):
    """Read ``ict_head.npz`` into Blender units and axes.

    Returns a dict: ``positions`` (N, 3) float32 metres, ``quads`` (F, 4)
    int32, ``corner_uvs`` (F, 4, 2) float32, ``expression_names`` (list of
    str), ``expression_deltas`` (E, N, 3) float32 metres and ``landmarks``
    (name -> (3,) float32 point, the names of ``headgen``).
    """
    with np.load(Path(path)) as data:
        positions = _to_blender(data["positions"])
        quads = np.ascontiguousarray(data["quads"], dtype=np.int32)
        corner_uvs = np.ascontiguousarray(data["corner_uvs"], dtype=np.float32)
        names = [str(n) for n in data["expression_names"]]
        deltas = _to_blender(data["expression_deltas"])
    found = _find_landmarks(positions, quads)
    landmarks = {name: found[name].astype(np.float32) for name in sorted(found)}
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
    import bpy

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
    if DRESS["on"]:
        from wrinkle_addon.glue import sample_head

        sample_head.dress(obj, collection or bpy.context.scene.collection, landmarks=data["landmarks"])
    return obj
