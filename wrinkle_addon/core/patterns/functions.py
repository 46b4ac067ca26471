# SPDX-License-Identifier: GPL-3.0-or-later
"""Pattern functions for detailed animated expressions ("Pattern functions and tears", §3).

A pattern is an implicit surface ``p(x, y, t) - z = 0`` in the local frame of the layer
(an Empty: its x, y span the skin, its z the skin's normal), so each pattern is a height
``z = f(x, y, t)`` in local units.  The frame's scale scales the pattern in all three axes:
the add-on displaces the skin along its normal by ``f`` times the frame's z scale.  The
layer is damped to zero toward its region's border (:func:`damping_radius`,
:func:`damping_border`) and, for the paper's "dynamic animation", applied only at a random
fraction of the region's vertices (:func:`valid_vertices`).

The text was extracted from a PDF; the readings chosen, and why:

* **Forehead** - the formula is missing from the text ("a controls depth of wrinkles and b
  describes the style of wrinkles", a running cycle).  Ours: ``f = a sin(y + b sin x - t)``:
  horizontal furrows (across the local y) whose *style* b bends them from straight (b = 0)
  into waves, running upward as t grows (a running cycle, period 2 pi in t).
* **Eye corner** - ``f = a exp(-b |sqrt(x^2 + y^2) - t sin(g arctan(y / x))|)``.  The
  garbled ``rxsin`` is ``t x sin`` (the extraction turns t into r elsewhere too): a rose
  curve ``rho = t sin(g phi)`` whose petals radiate from the eye corner; b is the paper's
  preset constant (how narrow each furrow is), g the number of furrows (petals per half
  turn), t their length.  ``arctan(y / x)``, not ``atan2``: the pattern is mirror-symmetric
  about the y axis, as printed.  a < 0 carves furrows.
* **Cheek** - ``f = a sin(b sqrt(x^2 + y^2) + t)``: ``y¥ +y>`` is the square root of
  ``x^2 + y^2`` and ``+1`` is ``+ t``.  Concentric ripples, b of them per 2 pi of radius,
  running as t grows (period 2 pi).
* **Frown** - ``f = a sin(x y / (b + t))``: ``xxy`` is ``x × y`` as in ``Bxy`` (``b × ...``)
  of the cheek, ``f+1`` is ``b + t``.  Furrows along the hyperbolas ``x y = k pi (b + t)``:
  nearly vertical beside the vertical axis, fanning out from the glabella; b sets the
  distance between them.
* **Dimple** - ``f = a (log(x^2 + y^2 + t) - log(1 + t))``, from ``log(x^2 + y^2 + t)``:
  the printed function has no depth parameter and grows without bound away from the
  centre, so it is scaled by a and shifted to 0 at the unit circle (the frame's scale is
  the dimple's radius).  The dimple is ``a log((1 + t) / t)`` deep: t > 0 sets how narrow
  and deep it is (small t: deep and sharp).
* **Eye pouch** - ``f = |cos(x + a t) + cos(y + b t)| / g``: a and b the trembling's
  speeds along x and y (its style), g the flatness (the bumps stand out by at most 2 / g).
  Periodic in t when a and b are commensurate.

Three of them cannot draw the real wrinkle with any parameters (docs/model.md, "What the
paper's functions cannot draw"): the eye corner's rose gives petal loops (rays only near the
centre of a rose far larger than the region, through the corner both ways and unfaded), the
frown's ``sin(x y / s)`` is odd in x (a furrow facing a ridge across the midline) and the
cheek's rings are no fold.  Beside each is a variant, ``shape`` ``FACE`` (:data:`VARIANTS`:
:func:`fan`, :func:`lines`, :func:`fold`, with the sharp furrow and round bulges of
:func:`furrow`); ``PAPER`` keeps the reading above.  :data:`FRAMES` and :func:`places` size
and place each type's frame from the face's landmarks.
"""

from dataclasses import dataclass, replace

import numpy as np

from ..mesh import edge_shrinkage, smoothstep

_EPS = 1e-12


@dataclass(frozen=True)
class Param:
    """One parameter of a pattern: its key (``alpha``, ``beta``, ``gamma``), the setting that
    holds it (``prop``, e.g. ``depth``), the name the artist sees, and a default that gives a
    visible result."""

    key: str
    prop: str
    name: str
    default: float


def forehead(x, y, t, alpha, beta, gamma=None):
    return alpha * np.sin(y + beta * np.sin(x) - t)


def eye_corner(x, y, t, alpha, beta, gamma):
    rho = np.sqrt(x * x + y * y)
    phi = np.arctan(y / np.where(np.abs(x) < _EPS, np.where(x < 0, -_EPS, _EPS), x))
    return alpha * np.exp(-beta * np.abs(rho - t * np.sin(gamma * phi)))


def cheek(x, y, t, alpha, beta, gamma=None):
    return alpha * np.sin(beta * np.sqrt(x * x + y * y) + t)


def frown(x, y, t, alpha, beta, gamma=None):
    return alpha * np.sin(x * y / np.maximum(beta + t, _EPS))


def dimple(x, y, t, alpha, beta=None, gamma=None):
    t = np.maximum(t, 1e-6)
    return alpha * (np.log(x * x + y * y + t) - np.log1p(t))


def eye_pouch(x, y, t, alpha, beta, gamma):
    return np.abs(np.cos(x + alpha * t) + np.cos(y + beta * t)) / np.maximum(gamma, _EPS)


@dataclass(frozen=True)
class Pattern:
    """A pattern type: its height function, its parameters, its default time ``t``, whether
    ``t`` runs with the scene by default (running cycles; the eye corner's and the dimple's
    ``t`` is a size instead) and whether ``t`` changes the pattern at all."""

    function: object
    params: tuple
    time: float
    runs: bool
    uses_time: bool = True


# (type, name, description): the list the interface shows
KINDS = (
    ("FOREHEAD", "Forehead", "Horizontal forehead furrows, straight or wavy, running as time goes on"),
    ("EYE_CORNER", "Eye Corner", "Crow's feet: furrows fanning out from the eye corner"),
    ("CHEEK", "Cheek", "The smile's cheek: the fold from the nose wing to beyond the mouth corner "
     "(the paper's reading: concentric ripples)"),
    ("FROWN", "Frown", "Frown furrows between the brows"),
    ("DIMPLE", "Dimple", "A dimple: a round indentation of the cheek"),
    ("EYE_POUCH", "Eye Pouch", "Trembling skin under the eye (anger, sadness)"),
)

PATTERNS = {
    "FOREHEAD": Pattern(forehead, (Param("alpha", "depth", "Depth", -0.12),
                                   Param("beta", "waviness", "Waviness", 0.3)), 0.0, True),
    "EYE_CORNER": Pattern(eye_corner, (Param("alpha", "depth", "Depth", -0.12),
                                       Param("beta", "sharpness", "Sharpness", 6.0),
                                       Param("gamma", "count", "Count", 3.0)), 1.0, False),
    "CHEEK": Pattern(cheek, (Param("alpha", "depth", "Depth", -0.08),
                             Param("beta", "count", "Count", 6.0)), 0.0, True),
    "FROWN": Pattern(frown, (Param("alpha", "depth", "Depth", -0.12),
                             Param("beta", "spacing", "Spacing", 0.3)), 0.0, True),
    "DIMPLE": Pattern(dimple, (Param("alpha", "depth", "Depth", 0.1),), 0.2, False),
    "EYE_POUCH": Pattern(eye_pouch, (Param("alpha", "speed_x", "Speed X", 6.0),
                                     Param("beta", "speed_y", "Speed Y", 6.0),
                                     Param("gamma", "flatness", "Flatness", 40.0)), 0.0, True),
}


# --------------------------------------------------------------------------- the face's shapes
# Where the text's formula cannot give the real wrinkle with any parameters (docs/model.md,
# "Pattern functions"), a variant beside it: the same frame, parameters and time, a shape
# that reads as the real thing.  ``SHAPES`` is the list the interface shows.
SHAPES = (
    ("PAPER", "Paper", "The pattern function as the paper's text reads (files saved before the "
     "choice existed keep it)"),
    ("FACE", "Anatomical", "A variant of the paper's function shaped as the wrinkle is on a face: "
     "crow's feet fanning out from the eye corner, two vertical frown lines, the smile's cheek fold"),
)
FAN_PITCH = np.radians(24.0)  # the angle between two crow's-feet furrows
FAN_MAX = 12  # at most this many furrows
LINE_WIDTH = 0.09  # a frown line's least half-width (frame units)
LINE_SOFTNESS = 2.0  # and at least this many times its depth: a soft valley, never a slit
LINE_DIVERGE = 0.12  # how much the frown lines part per frame unit upward
FOLD_RADIUS = 2.0  # the cheek fold's radius of curvature (frame units), its centre medial
FOLD_BULGE = (0.5, 0.3, 0.2)  # the cheek's bulge beside the fold: height, distance, width
_SOFT = 0.2  # the furrow's cusp, rounded over this fraction of its width


def furrow(q):
    """A furrow's cross-section at ``q`` half-widths from its line: 1 on the line (a cusp,
    slightly rounded: sharp), 0 at one half-width, a round bulge of ``-e^-2`` at two, then
    back to 0: ``(1 - |q|) e^-|q|``, whose integral is 0 (what the furrow takes, its bulges
    give back), with ``|q|`` rounded over ``_SOFT``.  Scaled to 1 on the line."""
    a = np.sqrt(q * q + _SOFT * _SOFT)
    return (1.0 - a) * np.exp(-a) / ((1.0 - _SOFT) * np.exp(-_SOFT))


def fan(x, y, t, alpha, beta, gamma):
    """Crow's feet as furrows fanning out from the eye corner (the frame's origin) toward
    its +x: ``gamma`` straight furrows ``FAN_PITCH`` apart, centred on the x axis, each
    ``2 / beta`` wide (the paper's sharpness) with the :func:`furrow` cross-section at
    constant width along it, rising from the corner over a quarter of ``t`` (their length)
    and fading out to nothing at ``t``.  Near the corner of the paper's rose (``t`` far beyond
    the region) its furrows are these rays, through the corner both ways and never fading."""
    rho = np.sqrt(x * x + y * y)
    phi = np.arctan2(y, x)
    n = float(np.clip(gamma, 0.0, FAN_MAX))
    k = np.arange(int(np.ceil(n)), dtype=np.float64)
    if len(k) == 0:
        return np.zeros_like(rho)
    angles = (k - 0.5 * (n - 1.0)) * FAN_PITCH
    weight = np.clip(n - k, 0.0, 1.0)  # a fractional count: the last furrow fainter
    turn = phi[..., None] - angles
    across = rho[..., None] * np.sin(turn) * max(float(beta), 0.0)
    r = rho[..., None] * np.cos(turn) / max(float(t), _EPS)
    along = smoothstep(r / 0.25) * (1.0 - smoothstep((r - 0.25) / 0.75))
    return alpha * np.sum(furrow(across) * along * weight, axis=-1)


def lines(x, y, t, alpha, beta, gamma=None):
    """Frown lines: two furrows, one each side of the frame's y axis (the midline), ``beta +
    t`` apart (the paper's spacing and time), parting by ``LINE_DIVERGE`` per unit upward,
    :func:`line_width` half-wide with the :func:`furrow` cross-section, full over 1.4 units
    of length about the origin and gone at 2.4 units."""
    half = 0.5 * max(float(beta) + float(t), 0.0) * (1.0 + LINE_DIVERGE * y)
    q = (np.abs(x) - half) / line_width(alpha)
    length = 1.0 - smoothstep((np.abs(y) - 0.7) / 0.5)
    return alpha * furrow(q) * length


def line_width(alpha):
    """A frown line's half-width (frame units) for its depth ``alpha``: ``LINE_WIDTH``, or
    ``LINE_SOFTNESS`` times the depth when that is wider.  The line is a valley twice that
    wide between the zero crossings of :func:`furrow`, so never narrower than 4 times its
    depth: real lines this deep are soft valleys with the skin bunched beside them, and a
    narrower one reads as a cut."""
    return max(LINE_WIDTH, LINE_SOFTNESS * abs(float(alpha)))


def fold(x, y, t, alpha, beta, gamma=None):
    """The smile's cheek: one fold through the frame's origin along its y (from the nose wing,
    +y, to beyond the mouth corner, -y), an arc of the paper's cheek rings of radius
    ``FOLD_RADIUS`` whose centre lies medially (-x): a :func:`furrow` ``2 / beta`` wide on the
    arc and the cheek's round bulge beside it, laterally (``FOLD_BULGE``); full over 1.6
    units of its length, gone at 2.4.  ``t`` does not change it."""
    s = np.sqrt((x + FOLD_RADIUS) ** 2 + y * y) - FOLD_RADIUS  # + lateral of the fold
    height, at, width = FOLD_BULGE
    bulge = height * np.exp(-(((s - at) / width) ** 2))
    length = 1.0 - smoothstep((np.abs(y) - 0.8) / 0.4)
    return alpha * (furrow(s * max(float(beta), 0.0)) - bulge) * length


VARIANTS = {
    "EYE_CORNER": Pattern(fan, (Param("alpha", "depth", "Depth", -0.05),
                                Param("beta", "sharpness", "Sharpness", 16.0),
                                Param("gamma", "count", "Count", 3.0)), 1.0, False),
    "FROWN": Pattern(lines, (Param("alpha", "depth", "Depth", -0.08),
                             Param("beta", "spacing", "Spacing", 1.0)), 0.0, False),
    "CHEEK": Pattern(fold, (Param("alpha", "depth", "Depth", -0.06),
                            Param("beta", "sharpness", "Sharpness", 12.0)), 0.0, False, False),
}

# Per type, for the shape a new layer gets (the variant where there is one): the frame's size
# (one unit of the pattern) and the region's radius, in units of the distance E between the
# eyes (about 63 mm on an adult), and the frame's height over its width (an oval dimple).
FRAMES = {
    "FOREHEAD": {"unit": 0.04, "radius": 0.8},
    "EYE_CORNER": {"unit": 0.30, "radius": 0.34},
    "CHEEK": {"unit": 0.30, "radius": 0.48},
    "FROWN": {"unit": 0.16, "radius": 0.25},
    "DIMPLE": {"unit": 0.08, "radius": 0.12, "aspect": 1.25},
    "EYE_POUCH": {"unit": 0.05, "radius": 0.3},
}
LATERAL = {"EYE_CORNER", "CHEEK", "DIMPLE"}  # the frame's +x points away from the midline


def spec(kind, shape="PAPER"):
    """The :class:`Pattern` of type ``kind`` in ``shape`` (``PAPER`` or ``FACE``); a type without
    a variant is its paper reading in either.  Raises ValueError for an unknown type."""
    if kind not in PATTERNS:
        raise ValueError(f"unknown pattern {kind!r}; one of {', '.join(PATTERNS)}")
    if shape == "FACE" and kind in VARIANTS:
        return VARIANTS[kind]
    return PATTERNS[kind]


def eye_distance(marks):
    """The distance ``E`` between the eyes (face units) from the face's landmarks ``marks``
    (twice the left eye's distance from the midline, at the glabella): the unit of
    :data:`FRAMES` and :func:`places`."""
    return 2.0 * abs(float(np.asarray(marks["eye_L"])[0]) - float(np.asarray(marks["glabella"])[0]))


def places(marks):
    """Where each type's frame goes on the character's left, from the face's landmarks
    (``marks``: name -> face-space point; those of ``core.landmark_finder.LANDMARKS``, the
    face looking toward -Y, Z up, its left +X), and the frame's up: ``{kind: (point, up)}``.
    The eye corner at the outer canthus (a fifth of E beyond the eye's centre, where the
    eyelid zone of ``core.zones`` ends); the frown between the brows at the glabella; the
    cheek fold's middle, from beside the nose wing to beyond the mouth corner (its up along
    it); the dimple beside the mouth corner, just beyond the fold.
    The points lie near the skin, not on it."""
    eye, mouth, g = (np.asarray(marks[k], np.float64) for k in ("eye_L", "mouth_corner_L", "glabella"))
    e = eye_distance(marks)
    up = np.array([0.0, 0.0, 1.0])
    top, bottom = fold_ends(marks)
    return {
        "EYE_CORNER": (eye + np.array([0.22 * e, 0.02 * e, 0.0]), up),
        "FROWN": (g + np.array([0.0, 0.0, -0.03 * e]), up),
        "CHEEK": (0.5 * (top + bottom), (top - bottom) / max(np.linalg.norm(top - bottom), _EPS)),
        "DIMPLE": (mouth + np.array([0.27 * e, 0.0, -0.03 * e]), up),
        "FOREHEAD": (g + np.array([0.0, 0.0, 0.35 * e]), up),
        "EYE_POUCH": (eye + np.array([0.0, 0.0, -0.3 * e]), up),
    }


def fold_ends(marks):
    """The smile's cheek fold on the character's left (face space): from beside the nose wing
    (just lateral of it, four fifths of the way up from the mouth corner to the nose tip) to
    below and beyond the mouth corner; both at the mouth corner's depth."""
    mouth, nose, g = (np.asarray(marks[k], np.float64) for k in ("mouth_corner_L", "nose_tip", "glabella"))
    e = eye_distance(marks)
    dx = mouth[0] - g[0]
    top = np.array([g[0] + 0.85 * dx, mouth[1], mouth[2] + 0.8 * (nose[2] - mouth[2])])
    bottom = np.array([mouth[0] + 0.2 * e, mouth[1], mouth[2] - 0.12 * e])
    return top, bottom


def half_cycle(kind, t, alpha=0.0, beta=0.0, gamma=0.0, shape="PAPER"):
    """How far (local units) it is from a furrow of pattern ``kind`` to the next bulge, what
    the mesh must resolve: the eye corner's furrow is about ``2 / b`` wide, the cheek's
    ripples ``pi / b`` apart, the frown's ``pi (b + t)`` at a unit from its axes, the
    dimple about ``2 sqrt(t)`` across; the forehead's and the eye pouch's period is 2 pi.
    The variants: a crow's-foot furrow and the cheek fold ``2 / b``, a frown line
    ``2`` :func:`line_width`."""
    face = shape == "FACE" and kind in VARIANTS
    if face and kind == "FROWN":
        return 2.0 * line_width(alpha)
    if kind == "EYE_CORNER" or face:  # the rose's furrow, a crow's-foot furrow, the cheek fold
        return 2.0 / max(abs(float(beta)), _EPS)
    if kind == "CHEEK":
        return np.pi / max(abs(float(beta)), _EPS)
    if kind == "FROWN":
        return np.pi * max(abs(float(beta) + float(t)), _EPS)
    if kind == "DIMPLE":
        return 2.0 * np.sqrt(max(float(t), 1e-6))
    return np.pi


def pattern(kind, x, y, t, alpha=0.0, beta=0.0, gamma=0.0, shape="PAPER"):
    """The height ``f(x, y, t)`` (local units) of pattern ``kind`` in ``shape`` (:func:`spec`)
    at local coordinates ``x``, ``y`` (arrays), time ``t``, parameters ``alpha``, ``beta``,
    ``gamma`` (those the pattern does not use are ignored).  Non-finite results (huge
    parameters) become 0."""
    fn = spec(kind, shape).function
    x = np.asarray(x, np.float64)
    y = np.asarray(y, np.float64)
    with np.errstate(all="ignore"):
        h = fn(x, y, float(t), float(alpha), float(beta), float(gamma))
    return _finite(np.asarray(h, np.float64))


def _finite(a):
    """``a`` with its non-finite values set to 0: one reduction when all are finite (every
    frame, normally), a copy only when some are not (a sum that overflows counts as not)."""
    with np.errstate(all="ignore"):
        if np.isfinite(a.sum()):
            return a
    return np.nan_to_num(a, nan=0.0, posinf=0.0, neginf=0.0)


def damping_radius(distance, radius, width):
    """A radius region's damping: 1 inside ``radius - width``, falling to 0 at ``radius``
    along ``1 - smoothstep`` (C¹: zero slope at both ends), 0 beyond.  ``width`` is clamped to
    ``[0, radius]``; 0 gives a hard edge."""
    d = np.asarray(distance, np.float64)
    radius = max(float(radius), 0.0)
    width = min(max(float(width), 0.0), radius)
    if width <= _EPS:
        return (d <= radius).astype(np.float64)
    return 1.0 - smoothstep((d - (radius - width)) / width)


def damping_border(border_distance, width, weight=None):
    """A vertex-group region's damping: ``smoothstep(border_distance / width)``, the distance
    from each region vertex to the nearest vertex outside the region, rising from 0 at the
    border to 1 at ``width`` inside (C¹), times the group ``weight`` when given."""
    d = np.asarray(border_distance, np.float64)
    out = np.ones_like(d) if float(width) <= _EPS else smoothstep(d / float(width))
    return out if weight is None else out * np.clip(np.asarray(weight, np.float64), 0.0, 1.0)


def valid_vertices(n_region, fraction, seed):
    """The paper's "valid vertices" for dynamic animation: a boolean mask over the region's
    ``n_region`` vertices with ``round(fraction n_region)`` of them set, drawn with ``seed``
    (the same seed, the same vertices).  Fraction 1 keeps every vertex."""
    n_region = int(n_region)
    k = int(round(np.clip(float(fraction), 0.0, 1.0) * n_region))
    mask = np.zeros(n_region, bool)
    if k >= n_region:
        mask[:] = True
    elif k > 0:
        mask[np.random.default_rng(int(seed)).permutation(n_region)[:k]] = True
    return mask


def border_distance(positions, edges, inside, limit):
    """The distance along the mesh's edges from each vertex to the nearest vertex that is
    not ``inside`` (0 there), for the border damping of a vertex-group region: relaxed over
    all edges at once until nothing changes, up to ``limit`` (farther: ``limit``).
    ``positions`` (N, 3), ``edges`` (E, 2), ``inside`` (N,) bool."""
    positions = np.asarray(positions, np.float64)
    edges = np.asarray(edges, np.int64).reshape(-1, 2)
    inside = np.asarray(inside, bool)
    d = np.where(inside, float(limit), 0.0)
    if len(edges) == 0 or not inside.any():
        return d
    a, b = edges[:, 0], edges[:, 1]
    length = np.linalg.norm(positions[a] - positions[b], axis=1)
    for _ in range(len(positions)):  # converges in as many rounds as edges across ``limit``
        new = d.copy()
        np.minimum.at(new, a, d[b] + length)
        np.minimum.at(new, b, d[a] + length)
        new = np.where(inside, new, 0.0)
        if np.array_equal(new, d):
            break
        d = new
    return d


@dataclass(frozen=True)
class Layer:
    """One layer's static data: its pattern ``kind``, the region's vertices ``verts`` (K,),
    their local coordinates ``x``, ``y`` (K,) in the frame, their ``weight`` (K,) (damping
    times the valid vertices), the frame's ``scale`` (a local height unit in the face's
    units) and the region's edges ``edges`` (E, 2) with their ``rest_length`` (E,), for a
    strength driven by the compression; ``rest`` (K, 3) the region's rest positions in the
    face's space, from which :func:`in_frame` places it in a frame that moved."""

    kind: str
    verts: np.ndarray
    x: np.ndarray
    y: np.ndarray
    weight: np.ndarray
    scale: float
    edges: np.ndarray
    rest_length: np.ndarray
    shape: str = "PAPER"
    rest: np.ndarray = None


def layer(kind, local, rest, edges, weight, fraction=1.0, seed=0, scale=1.0, shape="PAPER"):
    """A :class:`Layer` from the rest mesh's coordinates ``local`` (N, 3) in the frame, the
    region's ``weight`` (N,) (its damping: 0 outside), the valid ``fraction`` and ``seed``, and
    the ``shape`` (:func:`spec`)."""
    weight = np.asarray(weight, np.float64)
    verts = np.flatnonzero(weight > 0.0)
    w = weight[verts] * valid_vertices(len(verts), fraction, seed)
    inside = np.zeros(len(weight), bool)
    inside[verts] = True
    edges = np.asarray(edges, np.int64).reshape(-1, 2)
    e = edges[inside[edges[:, 0]] & inside[edges[:, 1]]]
    rest = np.asarray(rest, np.float64)
    length = np.linalg.norm(rest[e[:, 0]] - rest[e[:, 1]], axis=1)
    local = np.asarray(local, np.float64)
    return Layer(kind, verts, local[verts, 0], local[verts, 1], w, float(scale), e, length, shape,
                 rest[verts])


def in_frame(lay, face_to_frame, scale):
    """``lay`` with its region in a frame that moved: ``x``, ``y`` of its rest positions through
    the 4x4 matrix ``face_to_frame`` (face space -> the frame's), and the frame's ``scale``.
    O(K), the region's size: the rest of the static data (the region, its damping and valid
    vertices, its edges) does not depend on where the frame is."""
    m = np.asarray(face_to_frame, np.float64).reshape(4, 4)
    local = lay.rest @ m[:3, :3].T + m[:3, 3]
    return replace(lay, x=local[:, 0], y=local[:, 1], scale=float(scale))


def compression(lay, skin):
    """The mean edge compression (Zhang 2005 eq. 9, stretch counted as 0) of the layer's
    region on the skin (N, 3); 0 without edges."""
    if len(lay.edges) == 0:
        return 0.0
    skin = np.asarray(skin, np.float64)
    length = np.linalg.norm(skin[lay.edges[:, 0]] - skin[lay.edges[:, 1]], axis=1)
    tau = np.maximum(edge_shrinkage(lay.rest_length, length), 0.0)
    return float(np.mean(tau))


@dataclass(frozen=True)
class Plan:
    """The layers of a face and where they write: ``footprint`` (H,) sorted vertex ids, the
    union of the regions, and per layer the positions of its vertices in it (``index``)."""

    layers: tuple
    footprint: np.ndarray
    index: tuple


def plan(layers):
    layers = tuple(layers)
    verts = [lay.verts for lay in layers]
    footprint = np.unique(np.concatenate(verts)) if verts else np.zeros(0, np.int64)
    return Plan(layers, footprint, tuple(np.searchsorted(footprint, v) for v in verts))


def heights(pl, values):
    """The summed height (H,) at the plan's footprint, for this frame's ``values``: per
    layer ``(t, strength, alpha, beta, gamma)``; a strength of 0 skips the layer.  In the
    face's units, along the skin normal."""
    out = np.zeros(len(pl.footprint), np.float64)
    for lay, idx, (t, strength, alpha, beta, gamma) in zip(pl.layers, pl.index, values):
        if strength == 0.0 or len(idx) == 0:
            continue
        h = pattern(lay.kind, lay.x, lay.y, t, alpha, beta, gamma, lay.shape)
        out[idx] += h * lay.weight * (strength * lay.scale)
    return _finite(out)
