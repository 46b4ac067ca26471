# SPDX-License-Identifier: GPL-3.0-or-later
"""Animated wrinkle maps (Jimenez, Echevarria, Oat & Gutierrez 2011): the NumPy reference.

Encodings (all images hold values in [0, 1]; ``decode(c) = 2 c - 1``):

standard normal map
    RGB = 0.5 + 0.5 n, n a unit tangent-space normal (OpenGL / Blender: +Y is +V).
partial-derivative (PD) map, §1.2
    n' = (n_x / n_z, n_y / n_z) stored as RG = 0.5 + 0.5 n', B = 0.  The paper drops the
    minus sign of [Acton 08] in both the conversion and the reconstruction, and so do we.
    The encoding covers the 45 degree cone |n'_x|, |n'_y| <= 1 around (0, 0, 1); steeper
    normals are clipped to it (the paper: "little impact" on faces).
difference map, §1.2.1
    d = 0.5 + 0.5 (w - b) per channel, on the encoded RGB of the wrinkle map ``w`` and the
    base map ``b``; so decode(d) = w - b and the decoded normal difference is 2 decode(d).

The blend (Listing 1.1, with more than one wrinkle map and per-map zone weights)::

    s_k      = sum_z mask_z * clamp(weight_kz, 0, 1)            (8 zones, 2 RGBA masks)
    PD:      n = normalize(b'_x + S sum_k s_k w'_kx,  b'_y + S sum_k s_k w'_ky,  1)
    diff:    n = normalize(decode(b) + S sum_k s_k 2 decode(d_k))

``b'`` is the base normal map converted to PD in the shader, ``S`` the overall strength.
Everything here works on arrays of any leading shape ``(..., C)``.
"""

import math

import numpy as np

N_ZONES = 8
_EPS = 1e-6

# Zones, in mask order: mask A holds zones 1-4 in R, G, B, A; mask B zones 5-8.  The
# paper names them by their colour in Fig. 1.3; their places follow from Table 1.1
# (anger cancels surprise in zones 1-4, so they are the forehead; fear and sadness raise
# the inner brows, so 3-4 are the inner forehead; anger and disgust wrinkle 5-7, the
# brows and the nose; sadness pouts the chin, zone 8).  L is the character's left (+X).
ZONES = (
    ("Red", "Forehead Outer L"),
    ("Green", "Forehead Outer R"),
    ("Blue", "Forehead Inner L"),
    ("Brown", "Forehead Inner R"),
    ("Cyan", "Brows L"),
    ("Magenta", "Brows R"),
    ("Orange", "Nose"),
    ("Gray", "Chin"),
)

# Table 1.1 of the paper: weights per expression and zone.
TABLE_1_1 = {
    "Joy": (1.0, 1.0, 0.2, 0.2, 0.0, 0.0, 0.0, 0.0),
    "Surprise": (0.8, 0.8, 0.8, 0.8, 0.0, 0.0, 0.0, 0.0),
    "Fear": (0.2, 0.2, 0.75, 0.75, 0.3, 0.3, 0.0, 0.6),
    "Anger": (-0.6, -0.6, -0.8, -0.8, 0.8, 0.8, 1.0, 0.0),
    "Disgust": (0.0, 0.0, -0.1, -0.1, 1.0, 1.0, 1.0, 0.5),
    "Sad": (0.2, 0.2, 0.75, 0.75, 0.0, 0.0, 0.1, 1.0),
}

# Which zone each muscle role wrinkles, as (zone of the left muscle, zone of the right
# one), 0-based.  Roles without a zone (the cheeks: zygomatici, risorius, depressor) get no
# wrinkle map, as in the paper ("we have not created wrinkles for the zones corresponding
# to the cheeks").
ZONE_OF_ROLE = {
    "FRONTALIS_OUTER": (0, 1),
    "FRONTALIS_MAJOR": (2, 3),
    "FRONTALIS_INNER": (2, 3),
    "CORRUGATOR": (4, 5),
    "NASALIS": (6, 6),
    "MENTALIS": (7, 7),
}


# Neutral pixels of the encodings: a flat normal, zero slopes, no difference.  A pixel
# that is not finite (NaN or an infinity) in a source map stands for one of these.
FLAT_NORMAL = (0.5, 0.5, 1.0)  # standard normal map: n = (0, 0, 1)
FLAT_DERIVATIVE = (0.5, 0.5)  # PD map, R and G: n' = (0, 0)
FLAT_DIFFERENCE = (0.5, 0.5, 0.5)  # difference map: w = b


def replace_non_finite(maps, flat):
    """Give every pixel that is not finite the neutral value ``flat``.

    ``maps`` are arrays (..., C) of the same leading shape, the inputs of one conversion;
    only their first ``len(flat)`` channels (those the conversion reads) are looked at.  A
    pixel that holds a NaN or an infinity there in any of the maps is set to ``flat`` in
    all of them, so that it converts to the neutral output (a flat normal map gives a
    flat PD map and no difference, a flat PD map a flat normal).  Returns the cleaned
    maps (float32 copies; the inputs themselves when all is finite) and the number of
    such pixels.
    """
    k = len(flat)
    maps = [np.asarray(m, np.float32) for m in maps]
    bad = np.zeros(maps[0].shape[:-1], bool)
    for m in maps:
        bad |= ~np.isfinite(m[..., :k]).all(axis=-1)
    n = int(bad.sum())
    if n == 0:
        return maps, 0
    cleaned = []
    for m in maps:
        m = m.copy()
        m[bad, :k] = np.asarray(flat, np.float32)
        cleaned.append(m)
    return cleaned, n


def decode(c):
    return 2.0 * np.asarray(c, dtype=np.float32) - 1.0


def encode(v):
    return 0.5 + 0.5 * np.asarray(v, dtype=np.float32)


def normalize(v):
    """Unit vectors along the last axis; (0, 0, 1) where the length is zero."""
    v = np.asarray(v, dtype=np.float32)
    length = np.sqrt(np.sum(v * v, axis=-1, keepdims=True))
    up = np.zeros_like(v)
    up[..., 2] = 1.0
    return np.where(length > _EPS, v / np.maximum(length, _EPS), up)


def derivatives_of_normals(n):
    """PD slopes (..., 2) of unit normals (..., 3): n' = (n_x/n_z, n_y/n_z), clipped to
    the 45 degree cone; normals facing away (n_z <= 0) clip to its edge."""
    n = np.asarray(n, dtype=np.float32)
    nz = np.maximum(n[..., 2:3], _EPS)
    return np.clip(n[..., :2] / nz, -1.0, 1.0)


def normals_of_derivatives(d):
    """Unit normals (..., 3) of PD slopes (..., 2): normalize(n'_x, n'_y, 1)."""
    d = np.asarray(d, dtype=np.float32)
    return normalize(np.concatenate([d, np.ones_like(d[..., :1])], axis=-1))


def normal_to_derivative(rgb):
    """Standard tangent-space normal map (..., >=3) -> PD map (..., 3), B = 0."""
    d = derivatives_of_normals(normalize(decode(np.asarray(rgb)[..., :3])))
    return np.concatenate([encode(d), np.zeros_like(d[..., :1])], axis=-1)


def derivative_to_normal(rgb):
    """PD map (..., >=2; only R and G are read) -> standard normal map (..., 3)."""
    return encode(normals_of_derivatives(decode(np.asarray(rgb)[..., :2])))


def difference_map(base_rgb, wrinkle_rgb):
    """§1.2.1: d = 0.5 + 0.5 (w - b) on the encoded RGB of two standard normal maps."""
    b = np.asarray(base_rgb, dtype=np.float32)[..., :3]
    w = np.asarray(wrinkle_rgb, dtype=np.float32)[..., :3]
    return 0.5 + 0.5 * (w - b)


def zone_response(raw, strength=1.0, power=1.0):
    """Per-zone weight from the summed expression weights ``raw`` (..., 8):
    ``strength * clamp(raw, 0, 1) ** power`` (the clamp is the paper's; strength 0-2 and
    power 0.25-2 are the per-region controls artists know from CC/iC tools)."""
    c = np.clip(np.asarray(raw, dtype=np.float32), 0.0, 1.0)
    return np.asarray(strength, np.float32) * c ** np.asarray(power, np.float32)


def expression_sums(values, table):
    """Summed zone weights (8,) = sum_e values_e * table_e (table (E, 8)); may be < 0."""
    return np.asarray(values, np.float32) @ np.asarray(table, np.float32).reshape(-1, N_ZONES)


def mask_sum(mask_a, mask_b, weights):
    """sum_z mask_z * clamp(weights_z, 0, 1) per pixel: masks (..., 4) each, weights (8,)."""
    w = np.clip(np.asarray(weights, np.float32), 0.0, 1.0)
    return np.asarray(mask_a, np.float32)[..., :4] @ w[:4] + np.asarray(mask_b, np.float32)[..., :4] @ w[4:]


def blend(base_rgb, wrinkle_rgbs, mask_a, mask_b, weights, strength=1.0, difference=False):
    """Unit tangent-space normals (..., 3) of Listing 1.1 generalised to K maps.

    ``base_rgb`` a standard normal map (..., 3); ``wrinkle_rgbs`` K maps, PD maps or, with
    ``difference``, difference maps; ``weights`` (K, 8) zone weights, one row per map.
    """
    weights = np.asarray(weights, np.float32).reshape(-1, N_ZONES)
    maps = list(wrinkle_rgbs)
    if len(maps) != len(weights):
        raise ValueError(f"{len(maps)} wrinkle maps but {len(weights)} rows of zone weights")
    base = decode(np.asarray(base_rgb)[..., :3])
    if difference:
        n = base
        for w, m in zip(weights, maps):
            n = n + (strength * mask_sum(mask_a, mask_b, w))[..., None] * 2.0 * decode(np.asarray(m)[..., :3])
        return normalize(n)
    d = base[..., :2] / np.maximum(base[..., 2:3], _EPS)
    for w, m in zip(weights, maps):
        d = d + (strength * mask_sum(mask_a, mask_b, w))[..., None] * decode(np.asarray(m)[..., :2])
    return normals_of_derivatives(d)


def table_from_expressions(expressions, zone_of_role=None, sides=("L", "R")):
    """Zone weights (E, 8) of expressions given as ``{name: {role: contraction}}``.

    A muscle role with zones ``(left, right)`` gives its contraction to both (the presets
    contract both sides alike); a zone takes the largest contraction that reaches it.
    """
    zone_of_role = ZONE_OF_ROLE if zone_of_role is None else zone_of_role
    table = np.zeros((len(expressions), N_ZONES), np.float32)
    for row, contractions in zip(table, expressions.values()):
        for role, c in contractions.items():
            for z in zone_of_role.get(role, ()):
                row[z] = max(row[z], float(c))
    return table


def zone_tension(vertex_masks, compression, gain=1.0):
    """Tension-driven zone weights (8,): the mask-weighted mean compression in each zone.

    ``vertex_masks`` (V, 8) the zone masks at the vertices, ``compression`` (V,) the
    measured skin compression (edge shrinkage, >= 0 where the skin is compressed).
    ``clamp(gain * sum_v m_zv c_v / sum_v m_zv, 0, 1)``; 0 for an empty zone.  Always
    finite: a non-finite ``gain`` (NaN or an infinity, e.g. from a crafted file or an
    F-curve) counts as 0, no tension wrinkles, and so do NaN masks.
    """
    m = np.asarray(vertex_masks, np.float32).reshape(-1, N_ZONES)
    m = np.nan_to_num(m, nan=0.0, posinf=0.0, neginf=0.0)
    c = np.nan_to_num(np.asarray(compression, np.float32).ravel())
    g = float(gain)
    g = g if math.isfinite(g) else 0.0
    total = m.sum(axis=0)
    with np.errstate(over="ignore", invalid="ignore"):
        mean = (c @ m) / np.where(total > 0, total, 1.0)
        out = np.clip(g * np.where(total > 0, mean, 0.0), 0.0, 1.0)
    return np.nan_to_num(out, nan=0.0).astype(np.float32)


def vertex_compression(skin, edges, rest_length):
    """Per-vertex compression (V,): the mean over a vertex's edges of the shrinkage
    ``max(tau, 0)``, tau = (L - l) / L (Zhang eq. 9); 0 on stretched or rest skin.
    ``rest_length`` (E,) the edges' rest lengths (static: the caller keeps them)."""
    from ..mesh import edge_lengths, edge_shrinkage

    skin = np.asarray(skin, np.float32).reshape(-1, 3)
    e = np.asarray(edges, np.int64).reshape(-1, 2)
    tau = np.maximum(np.nan_to_num(edge_shrinkage(rest_length, edge_lengths(skin, e))), 0.0)
    n = len(skin)
    total = np.bincount(e.ravel(), weights=np.repeat(tau, 2), minlength=n)
    count = np.bincount(e.ravel(), minlength=n)
    return (total / np.maximum(count, 1)).astype(np.float32)


class TensionPlan:
    """:func:`zone_tension` of :func:`vertex_compression` folded onto the edges, for every
    frame of one face: with ``c_v = sum_{e at v} tau_e / deg_v`` and ``T_z = sum_v m_zv``,
    the zone's mean ``sum_v m_zv c_v / T_z`` is ``sum_e tau_e w_ez``, where
    ``w_ez = m_z(a) / (deg_a T_z) + m_z(b) / (deg_b T_z)`` for the edge's ends ``a, b``.
    Only the edges with a weight (those touching a masked vertex) are kept: ``edges``
    (E', 2), ``rest`` (E',) float32 their rest lengths, ``weights`` (8, E') float32, a row
    per zone: eight 1-D dot products per frame (a (E',) @ (E', 8) product goes through
    OpenBLAS's threaded gemv, measured 100 times slower at 75k edges)."""

    __slots__ = ("edges", "rest", "weights")

    def __init__(self, edges, rest, weights):
        self.edges, self.rest, self.weights = edges, rest, weights


def tension_plan(edges, rest_length, vertex_masks):
    """The :class:`TensionPlan` of a face with ``edges`` (E, 2), their ``rest_length`` (E,)
    and the zone masks at its vertices ``vertex_masks`` (V, 8) (NaN masks count as 0, as in
    :func:`zone_tension`)."""
    m = np.nan_to_num(np.asarray(vertex_masks, np.float64).reshape(-1, N_ZONES), nan=0.0, posinf=0.0,
                      neginf=0.0)
    e = np.asarray(edges, np.int64).reshape(-1, 2)
    total = m.sum(axis=0)
    per_zone = np.where(total > 0, 1.0 / np.where(total > 0, total, 1.0), 0.0)
    degree = np.bincount(e.ravel(), minlength=len(m))
    per_vertex = m * (per_zone / np.maximum(degree, 1)[:, None])
    weights = per_vertex[e[:, 0]] + per_vertex[e[:, 1]]
    keep = (weights != 0.0).any(axis=1)
    rest = np.asarray(rest_length, np.float32).ravel()[keep]
    return TensionPlan(np.ascontiguousarray(e[keep]), rest, np.ascontiguousarray(weights[keep].T, np.float32))


def plan_tension(plan, skin, gain=1.0):
    """This frame's tension-driven zone weights (8,) float32 from a :class:`TensionPlan` and
    the skin (V, 3): equal to ``zone_tension(masks, vertex_compression(skin, ...), gain)``
    (tested), with the same care for a non-finite gain or skin."""
    from ..mesh import edge_lengths, edge_shrinkage

    p = np.asarray(skin, np.float32).reshape(-1, 3)
    g = float(gain)
    g = g if math.isfinite(g) else 0.0
    with np.errstate(over="ignore", invalid="ignore"):
        tau = np.maximum(np.nan_to_num(edge_shrinkage(plan.rest, edge_lengths(p, plan.edges))), 0.0)
        out = np.clip(g * np.array([np.dot(w, tau) for w in plan.weights]), 0.0, 1.0)
    return np.nan_to_num(out, nan=0.0).astype(np.float32)


def sample_nearest(image, uv):
    """Nearest-texel lookup of ``image`` (H, W, C), row 0 at v = 0, at ``uv`` (V, 2).
    UVs outside [0, 1] wrap like Blender's default Repeat extension; 1.0 itself is the
    last texel (a vertex on the border of the UV square belongs to it)."""
    image = np.asarray(image)
    h, w = image.shape[:2]
    uv = np.nan_to_num(np.asarray(uv, np.float64).reshape(-1, 2))
    uv = np.where((uv < 0.0) | (uv > 1.0), np.mod(uv, 1.0), uv)
    col = np.floor(uv[:, 0] * w).astype(np.int64).clip(0, w - 1)
    row = np.floor(uv[:, 1] * h).astype(np.int64).clip(0, h - 1)
    return image[row, col]
