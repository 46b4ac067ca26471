"""Procedural human head for demos, tests and benchmarks. Pure NumPy, no bpy.

Conventions: metres, Z up, the face looks toward -Y, the character's left is +X.
The chin is near z = 0.02 and the crown at z = 0.223; the skull is 0.15 m wide
and 0.19 m long from the glabella to the back of the head.

How it is built
---------------
* The shape is an implicit function ``head_field(p)`` (negative inside, close to
  a signed distance): smoothly blended primitives (a superellipsoid cranium,
  ellipsoids for the mid-face, the mouth and the buccal pads, capsules for the
  mandible and neck, spheres for the eyeballs between open lids) minus a relief
  displaced along the normal: Gaussians, ridges and grooves for the brow ridge,
  eye sockets, lids, nose (dorsum, tip, alae, nostrils either side of the
  columella), cheekbones, soft nasolabial folds, philtrum, lips (the corners
  tucked in beside the modiolus) and mouth line, chin, and the ears.
* Every vertex is the root of the field along a ray. Above the throat the rays
  leave ``ORIGIN`` (the head is star-shaped from there; ``tests`` checks it);
  the neck is sampled by level rays from the same vertical axis, so the open
  neck ring lies in the plane z = -0.085.
* The rays form a latitude-longitude grid whose columns and rows are packed
  densely over the face and sparsely elsewhere: at the default 40k vertices the
  forehead, brows, eyes, nose and mouth get edges of 1.6-1.9 mm while the back
  of the skull gets 3-7 mm. The crown is closed by a quad cap: a Coons patch on
  the azimuthal-equidistant plane, relaxed together with the top rows so its
  four valence-3 corners open up. All faces are quads, wound counter-clockwise
  seen from outside.
* Narrow grooves are widened to the mesh resolution (``detail``), so coarse
  meshes do not alias them.
* UVs: the band uses (azimuth, elevation seen from ``ORIGIN``) at the same
  scale on both axes over the face (close to conformal there), with the back of
  the head squeezed into the outer 5 % of U. The crown is a separate disc
  island above the band.
"""

from functools import partial

import numpy as np

__all__ = ["make_head", "make_forehead_patch", "head_field", "LANDMARK_NAMES", "ORIGIN"]

LANDMARK_NAMES = (
    "glabella",
    "brow_inner_L", "brow_inner_R", "brow_mid_L", "brow_mid_R", "brow_outer_L", "brow_outer_R",
    "hairline_center", "hairline_L", "hairline_R",
    "eye_L", "eye_R",
    "nose_bridge", "nose_tip", "nose_ala_L", "nose_ala_R",
    "cheekbone_L", "cheekbone_R",
    "mouth_corner_L", "mouth_corner_R", "upper_lip", "lower_lip",
    "chin", "jaw_L", "jaw_R", "cheek_lateral_L", "cheek_lateral_R",
)

# Rays start here, near the middle of the head at eye level; the head is
# star-shaped with respect to this point.
ORIGIN = np.array([0.0, 0.005, 0.105])

_RAY_MAX = 0.26  # every ray leaves the head before this distance (m)
_NECK_CUT = -0.085  # z of the open neck ring
_NECK_TOP = -0.020  # below this the neck is sampled by level rays
_NECK = ((0.0, 0.016, -0.30), (0.0, 0.030, 0.080), 0.055, 0.051)  # round cone a, b, ra, rb
_EL_LOW = np.radians(-78.0)  # lowest ray from ORIGIN (at the front of the throat)
_EL_FIXED = np.radians(52.0)  # outer edge of the relaxed crown region
_EL_CAP = np.radians(64.0)  # ring where the band meets the cap grid


# --------------------------------------------------------------------------
# Implicit modelling primitives (p: (N, 3) float64; return (N,) values)
# --------------------------------------------------------------------------
def _ellipsoid(p, c, r):
    """Near-Euclidean distance bound to an axis-aligned ellipsoid."""
    q = (p - c) / r
    k0 = np.sqrt(np.einsum("ij,ij->i", q, q))
    q2 = (p - c) / (np.asarray(r) ** 2)
    k1 = np.sqrt(np.einsum("ij,ij->i", q2, q2))
    return k0 * (k0 - 1.0) / np.maximum(k1, 1e-12)


def _superellipsoid(p, c, r, e):
    """Distance estimate to the superellipsoid sum(|(p - c) / r|^e) = 1."""
    q = np.abs((p - c) / r) + 1e-12
    k = np.sum(q ** e, axis=1) ** (1.0 / e)
    grad = (q / k[:, None]) ** (e - 1.0) / np.asarray(r)
    return (k - 1.0) / np.sqrt(np.einsum("ij,ij->i", grad, grad))


def _round_cone(p, a, b, ra, rb):
    """Capsule from a (radius ra) to b (radius rb), radius interpolated linearly."""
    a = np.asarray(a, float)
    ab = np.asarray(b, float) - a
    h = np.clip((p - a) @ ab / (ab @ ab), 0.0, 1.0)
    d = p - a - h[:, None] * ab
    return np.sqrt(np.einsum("ij,ij->i", d, d)) - (ra + (rb - ra) * h)


def _smin(a, b, k):
    """Polynomial smooth minimum (union) with blend width k."""
    h = np.clip(0.5 + 0.5 * (b - a) / k, 0.0, 1.0)
    return b + (a - b) * h - k * h * (1.0 - h)


def _smax(a, b, k):
    """Smooth maximum (intersection / subtraction with -b)."""
    return -_smin(-a, -b, k)


def _gauss(p, c, s):
    q = (p - c) / s
    return np.exp(-0.5 * np.einsum("ij,ij->i", q, q))


def _smoothstep(e0, e1, x):
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _soft_abs(x, eps=0.003):
    """|x| rounded off within ``eps`` of 0, so mirrored features meet smoothly."""
    return np.sqrt(x * x + eps * eps) - eps


def _mirror(p):
    """Fold the character's right onto the left (features are symmetric)."""
    q = p.copy()
    q[:, 0] = _soft_abs(q[:, 0])
    return q


# --------------------------------------------------------------------------
# The head field
# --------------------------------------------------------------------------
def _segment_distance_2d(x, z, a, b):
    """Distance in the XZ plane from (x, z) to the segment a-b, and the segment parameter."""
    ax, az_ = a
    dx, dz = b[0] - ax, b[1] - az_
    t = np.clip(((x - ax) * dx + (z - az_) * dz) / (dx * dx + dz * dz), 0.0, 1.0)
    return np.hypot(x - ax - t * dx, z - az_ - t * dz), t


def _groove(d, sigma, detail):
    """Gaussian groove profile across distance ``d``, widened to ``detail``."""
    return np.exp(-0.5 * d * d / (sigma * sigma + detail * detail))


def _nose_relief(x, z, detail):
    """Height (m) of the nose above the face, as a function of (x, z)."""
    ax = _soft_abs(x)
    # Dorsum: straight in profile from the nasion to the supratip.
    t = np.clip((0.119 - z) / (0.119 - 0.083), 0.0, 1.0)
    height = (0.0055 + 0.0085 * t) * _smoothstep(0.124, 0.112, z)
    half_width = 0.0075 + 0.0010 * t
    ridge = height * np.exp(-((x / half_width) ** 2))
    # Tip lobule, slightly bifid; the columella under it.
    sz = np.where(z > 0.0815, 0.0095, 0.0060)
    tip = 0.0055 * np.exp(-0.5 * ((ax - 0.0015) / 0.0075) ** 2 - 0.5 * ((z - 0.0815) / sz) ** 2)
    body = (ridge + tip) * _smoothstep(0.0685, 0.0805, z)
    # Alae: rounded wings either side of the tip, bounded by the alar crease.
    c, s = np.cos(0.45), np.sin(0.45)  # the wing leans from the cheek up toward the tip
    du, dv = ax - 0.0108, z - 0.0752
    u = np.hypot((c * du + s * dv) / 0.0088, (-s * du + c * dv) / 0.0058)
    ala = 0.0092 * np.exp(-0.5 * (u / 0.62) ** 3) * _smoothstep(0.0660, 0.0745, z)
    crease = 0.0006 * _groove(u - 1.05, 0.12 * 0.0067, detail) * _smoothstep(0.006, 0.012, ax)
    h = _smax(body, ala, 0.008)
    # Nostrils: on the underside, between the columella and each ala, the surface
    # sinks up into the nose (a share of the height is taken away, so the lip under
    # them is untouched); the columella between them stays whole.
    c, s = np.cos(0.35), np.sin(0.35)  # teardrops, leaning in toward the tip
    du, dv = ax - 0.0072, z - 0.0726
    e = ((c * du + s * dv) / 0.0040) ** 2 + ((-s * du + c * dv) / 0.0024) ** 2
    nostril = np.exp(-0.5 * e * e)
    return h * (1.0 - 0.7 * nostril) - crease


def _mouth_relief(x, z, detail):
    """Lips (vermilion border, cupid's bow), philtrum, mouth line and chin as a
    height (m) over (x, z)."""
    ax = _soft_abs(x)
    s = np.clip(ax / 0.0215, 0.0, 1.6)  # 1 where the lips end, 2.5 mm inside the corners
    z_m = 0.0478 - 0.0010 * s * s - 0.0003 * np.exp(-0.5 * (x / 0.0030) ** 2)  # mouth line
    # Vermilion borders: the cupid's bow peaks at x = +-5.5 mm over a dip on the
    # midline; both borders run down to the corners.
    bow = 0.0011 * np.exp(-0.5 * ((ax - 0.0058) / 0.0030) ** 2) - 0.0005 * np.exp(-0.5 * (x / 0.0022) ** 2)
    z_ub = z_m + (0.0080 + bow) * np.clip(1.0 - s ** 2.2, 0.0, None) ** 0.55
    z_lb = z_m - 0.0100 * np.clip(1.0 - s ** 2.6, 0.0, None) ** 0.6
    w = max(0.0008, 0.9 * detail)
    # Upper lip: skin sloping forward from the nose to the border ...
    skin = 0.0012 * _smoothstep(0.0700, z_ub - 0.002, z) * np.exp(-((x / 0.024) ** 4))
    # ... and the vermilion, a roll that stands proud of it, pouting a little.
    u = np.clip((z - z_m) / np.maximum(z_ub - z_m, 1e-4), 0.0, 1.0)
    inside_up = _smoothstep(z_ub + w, z_ub - w, z) * _smoothstep(z_m - w, z_m + w, z)
    v_up = (0.0032 * np.sin(np.pi * (0.25 + 0.75 * u)) ** 0.7 + 0.0006) * inside_up
    # Lower lip: a fuller roll under the mouth line, bounded by its border.
    u2 = np.clip((z_m - z) / np.maximum(z_m - z_lb, 1e-4), 0.0, 1.0)
    inside_lo = _smoothstep(z_lb - w, z_lb + w, z) * _smoothstep(z_m + w, z_m - w, z)
    v_lo = (0.0036 * np.sin(np.pi * (0.15 + 0.85 * u2)) ** 0.6 + 0.0006) * inside_lo
    # The lower lip is two soft lobes either side of the midline.
    v_lo *= 1.0 + 0.15 * np.exp(-0.5 * ((ax - 0.009) / 0.006) ** 2)
    fade = np.clip(1.0 - s ** 2, 0.0, None) ** 0.7
    r = skin + (v_up + v_lo) * fade
    # The white roll along the upper border.
    r += 0.0004 * _groove(z - z_ub, 0.0005, detail) * fade
    # Philtrum: two columns from the columella to the bow's peaks, a dip between.
    t = _smoothstep(z_ub, z_ub + 0.004, z) * _smoothstep(0.0690, 0.0640, z)
    colx = 0.0040 + 0.0018 * _smoothstep(0.066, 0.057, z)
    r += t * (0.0009 * np.exp(-0.5 * ((ax - colx) / 0.0014) ** 2)
              - 0.0004 * np.exp(-0.5 * (x / 0.0018) ** 2))
    # Mouth line (the lips meet) and the corners of the mouth (modiolus).
    # The line fades before the corners, which are pits tucked in behind the lips;
    # the modiolus is a soft knot of muscle just outside each corner.
    r -= 0.0011 * _groove(z - z_m, 0.0006, detail) * np.exp(-((x / 0.0225) ** 4))
    r -= 0.0036 * np.exp(-0.5 * (((ax - 0.0235) / 0.0036) ** 2 + ((z - 0.0470) / 0.0045) ** 2))
    r += 0.0010 * np.exp(-0.5 * (((ax - 0.0280) / 0.0055) ** 2 + ((z - 0.0480) / 0.0090) ** 2))
    # Mentolabial sulcus and the chin.
    r -= 0.0028 * np.exp(-0.5 * ((z - 0.0330) / 0.0040) ** 2) * np.exp(-0.5 * (x / 0.016) ** 2)
    r += 0.0052 * np.exp(-0.5 * ((z - 0.0215) / 0.0085) ** 2) * np.exp(-0.5 * (x / 0.012) ** 2)
    return r


def _face_relief(p, m, detail):
    """Height (m) of the facial features above the blended base shapes."""
    x, z = p[:, 0], p[:, 2]
    ax = m[:, 0]
    r = _nose_relief(x, z, detail)
    # Brow ridge (strongest over the inner half of each brow) and the glabella.
    zb = 0.1340 + 0.030 * ax * ax
    r += 0.0048 * np.exp(-0.5 * ((z - zb) / 0.0060) ** 2) * np.exp(-0.5 * ((ax - 0.018) / 0.026) ** 2)
    r += 0.0020 * _gauss(p, (0.0, -0.095, 0.130), (0.010, 0.02, 0.008))
    # Frontal eminences and the flat of the lower forehead.
    r += 0.0035 * _gauss(p, (0.0, -0.090, 0.150), (0.035, 0.03, 0.012))
    r += 0.0035 * _gauss(m, (0.024, -0.085, 0.170), (0.022, 0.03, 0.020))
    # Eye sockets: deep enough behind the lids for the eyeballs to show; the
    # upper-lid sulcus under the brow; the temples.
    r -= 0.0125 * _gauss(m, (0.0280, -0.080, 0.1170), (0.0110, 0.02, 0.0085))
    r -= 0.0020 * _gauss(m, (0.0330, -0.080, 0.1255), (0.012, 0.02, 0.0035))
    r -= 0.0018 * _gauss(m, (0.066, -0.040, 0.128), (0.010, 0.02, 0.014))
    # Lower lid and the tear trough below it.
    ex = (ax - 0.0315) / 0.016
    lidw = np.clip(1.0 - ex * ex, 0.0, None) ** 2
    z_tear = 0.1060 - 0.0010 * ex + 0.0025 * ex * ex
    r -= 0.0008 * _groove(z - z_tear, 0.0022, detail) * lidw
    # Cheekbones and the fullness of the cheeks.
    r += 0.0045 * _gauss(m, (0.050, -0.066, 0.099), (0.015, 0.02, 0.010))
    r += 0.0030 * _gauss(m, (0.064, -0.040, 0.098), (0.010, 0.03, 0.008))  # zygomatic arch
    r += 0.0045 * _gauss(m, (0.040, -0.075, 0.074), (0.017, 0.03, 0.018))
    # Nasolabial folds: the fuller cheek lateral to a crease from the ala to the
    # side of the mouth.
    a, b = (0.0205, 0.0720), (0.0330, 0.0400)
    d_fold, t_fold = _segment_distance_2d(ax, z, a, b)
    normal = np.array([a[1] - b[1], b[0] - a[0]]) / np.hypot(a[1] - b[1], b[0] - a[0])
    side = (ax - a[0]) * normal[0] + (z - a[1]) * normal[1]  # > 0 on the cheek side
    taper = np.sin(np.pi * np.clip(0.15 + 0.85 * t_fold, 0.0, 1.0)) ** 1.5
    r -= 0.0004 * _groove(d_fold, 0.0040, detail) * taper
    r += 0.0016 * np.exp(-0.5 * (d_fold / 0.0085) ** 2) * taper * _smoothstep(-0.004, 0.008, side)
    r += _mouth_relief(x, z, detail)
    return r


_EAR_C = (0.019, 0.102)  # (y, z) of the middle of the ear


def _ear_relief(p, ax, detail):
    """Ears as relief on the side of the head: helix, scapha, antihelix, concha,
    tragus and lobe, leaning back 12 degrees."""
    y, z = p[:, 1] - _EAR_C[0], p[:, 2] - _EAR_C[1]
    c, s_ = np.cos(np.radians(12.0)), np.sin(np.radians(12.0))
    u = (c * y + s_ * z) / 0.0165  # toward the back of the head
    v = (-s_ * y + c * z) / 0.031  # up
    # Outline: an egg, narrower toward the lobe.
    half = 1.0 - 0.28 * _smoothstep(0.2, -1.0, v)
    e = np.hypot((u - 0.05) / half, v)
    outline = _smoothstep(1.04, 0.68, e)  # a rounded rim, several rays wide
    attach = _smoothstep(-1.0, -0.55, u)  # fades into the head in front
    # Standing off the head most at the back of the helix; the bottom of the lobe
    # sinks back into the cheek, so its lower edge is rounded, not a point.
    lobe_edge = 0.3 + 0.7 * _smoothstep(-1.15, -0.8, v)
    lift = (0.0065 + 0.0060 * _smoothstep(-0.6, 1.0, u)) * attach * lobe_edge
    g = max(0.10, detail / 0.0165)
    rim = np.exp(-0.5 * ((e - 0.83) / g) ** 2)  # helix
    scapha = np.exp(-0.5 * ((e - 0.66) / g) ** 2) * _smoothstep(-0.3, 0.2, u + v)
    # Antihelix: a ridge around the concha, open toward the front.
    ea = np.hypot((u - 0.10) / 0.62, (v + 0.05) / 0.72)
    anti = np.exp(-0.5 * ((ea - 0.95) / (1.2 * g)) ** 2) * _smoothstep(-0.5, 0.0, u + 0.6 * v)
    concha = np.exp(-0.5 * (np.hypot((u + 0.05) / 0.42, (v + 0.12) / 0.40) ** 4))
    lobe = _smoothstep(-0.45, -0.75, v) * _smoothstep(1.0, 0.7, e)
    h = outline * lift * (0.60 + 0.40 * rim - 0.30 * scapha + 0.25 * anti - 0.85 * concha
                          + 0.15 * lobe)
    tragus = 0.0045 * np.exp(-0.5 * (((u + 0.62) / 0.13) ** 2 + ((v + 0.15) / 0.15) ** 2))
    return (h + tragus) * _smoothstep(0.045, 0.060, ax)


# Eye geometry (left eye; the right is mirrored). Metres.
_EYE_C = np.array([0.0315, -0.0660, 0.1165])  # centre of the eyeball
_EYE_R = 0.0122  # eyeball radius (the cornea bulges 1 mm more)
_CANTHUS_IN = (0.0165, 0.1155)  # (x, z) of the inner corner of the eye
_CANTHUS_OUT = (0.0455, 0.1185)  # outer corner: a slight upward canthal tilt


def _fissure(ax, z):
    """Signed vertical distance (m) into the palpebral fissure (> 0 between the
    lid margins), and the position ``s`` (0 inner corner, 1 outer) along it."""
    (xi, zi), (xo, zo) = _CANTHUS_IN, _CANTHUS_OUT
    s = (ax - xi) / (xo - xi)
    b = np.clip(4.0 * s * (1.0 - s), 0.0, None)
    zc = zi + (zo - zi) * s
    # The upper lid peaks a little medial of the pupil, the lower lid lateral of it.
    upper = zc + 0.0056 * b ** 0.62 * (1.0 - 0.18 * (s - 0.42))
    lower = zc - 0.0046 * b ** 0.95 * (1.0 + 0.20 * (s - 0.55))
    return np.minimum(upper - z, z - lower), s


def _eyes(m, detail):
    """``m``: points with x folded by |x| (the eyes are far from the midline).
    Eyeballs with the iris and pupil carved like a sculpture's, and the lids: a
    shell over each eyeball that opens along the fissure."""
    q = m - _EYE_C
    r = np.sqrt(np.einsum("ij,ij->i", q, q))
    rho = np.hypot(q[:, 0], q[:, 2])  # distance from the visual axis
    cornea = 0.0011 * np.exp(-((rho / 0.0058) ** 4))  # the iris disc, its rim a step
    pupil = 0.0007 * np.exp(-0.5 * (rho / 0.0017) ** 2)
    ball = r - (_EYE_R + cornea - pupil)
    o, s = _fissure(m[:, 0], m[:, 2])
    w = max(0.0007, 0.7 * detail)
    # Lid thickness over the ball: 2.4 mm, less toward the corners, sinking into the
    # fissure. The shell is the lids; where it sinks the eyeball shows.
    corner = np.clip(4.0 * s * (1.0 - s), 0.0, 1.0) ** 0.25
    # Toward the corners the lids part more gently, so the rays from ORIGIN, which
    # cross the outer corner obliquely, still meet one surface.
    soft = w * (1.0 + 10.0 * (1.0 - corner))
    thick = (0.0012 + 0.0014 * corner) - 0.0060 * (0.3 + 0.7 * corner) * _smoothstep(-0.2 * w, soft, o)
    # The upper lid's skin folds up under the brow at the lid crease.
    zc = 0.1165 + 0.0080 - 0.0030 * (2.0 * s - 1.0) ** 2
    crease = _smoothstep(zc - 0.0015, zc + 0.0040, m[:, 2]) * _smoothstep(-0.1, 0.2, s) \
        * _smoothstep(1.3, 0.8, s)
    lids = r - (_EYE_R + thick + 0.0016 * crease)
    return ball, lids


def head_field(p, detail=0.0):
    """Implicit function of the head: negative inside, ~signed distance (m).

    ``detail`` (m) is the narrowest groove the mesh can show; narrower ones
    (lid margins, mouth line, creases) are widened to it so they do not alias.
    """
    p = np.asarray(p, dtype=np.float64)
    m = _mirror(p)
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    ax = m[:, 0]

    # Cranium: an egg, narrower at the forehead than over the parietals, and
    # shorter behind its middle than in front (19 cm from the glabella to the
    # back of the head): y behind the middle is stretched before evaluating it.
    widen = 1.0 + 0.07 * np.clip(y / 0.1, -1.0, 1.0)
    yc = np.where(y > 0.014, 0.014 + (y - 0.014) * (0.099 / 0.082), y)
    pc = np.stack([x / widen, yc, z], axis=1)
    f = _superellipsoid(pc, (0.0, 0.014, 0.133), (0.074, 0.099, 0.090), 2.4)

    # Mid-face (maxilla, cheeks) and the mouth region.
    f = _smin(f, _ellipsoid(p, (0.0, -0.026, 0.088), (0.067, 0.068, 0.052)), 0.02)
    f = _smin(f, _ellipsoid(p, (0.0, -0.042, 0.052), (0.038, 0.057, 0.042)), 0.035)
    # The buccal pad: fills the cheek between the mouth, the cheekbone and the jaw,
    # so no valley runs from the mouth corner down to the jaw.
    f = _smin(f, _ellipsoid(m, (0.026, -0.044, 0.058), (0.019, 0.038, 0.028)), 0.02)

    # Mandible: chin bar, bodies to the jaw angles, rami up to the ears.
    jaw = _round_cone(m, (0.0, -0.068, 0.023), (0.010, -0.066, 0.024), 0.014, 0.014)
    jaw = _smin(jaw, _round_cone(m, (0.010, -0.066, 0.024), (0.046, -0.006, 0.034),
                                 0.014, 0.012), 0.01)
    jaw = _smin(jaw, _round_cone(m, (0.046, -0.006, 0.034), (0.052, 0.010, 0.085),
                                 0.012, 0.012), 0.01)
    f = _smin(f, jaw, 0.03)

    # Neck.
    f = _smin(f, _round_cone(p, *_NECK), 0.028)

    # Relief along the normal, evaluated only where it can be non-zero.
    front = y < -0.02
    if front.any():
        pf = p[front]
        f[front] -= _face_relief(pf, m[front], detail) * _smoothstep(-0.02, -0.06, pf[:, 1])
    ear = (ax > 0.045) & (np.abs(y - _EAR_C[0]) < 0.024) & (np.abs(z - _EAR_C[1]) < 0.040)
    if ear.any():
        f[ear] -= _ear_relief(p[ear], ax[ear], detail)

    # Eyes: the lids blend into the socket, the eyeballs show between them.
    near = (np.abs(np.abs(x) - _EYE_C[0]) < 0.03) & (np.abs(z - _EYE_C[2]) < 0.03) & (y < -0.03)
    if near.any():
        pe = p[near].copy()
        pe[:, 0] = np.abs(pe[:, 0])
        ball, lids = _eyes(pe, detail)
        fe = _smin(f[near], lids, 0.0022)
        f[near] = np.minimum(fe, ball)
    return f


# --------------------------------------------------------------------------
# Ray casting
# --------------------------------------------------------------------------
def _directions(az, el):
    """Unit rays: azimuth 0 looks toward -Y, +pi/2 toward +X; elevation up."""
    ce = np.cos(el)
    return np.stack([ce * np.sin(az), -ce * np.cos(az), np.sin(el)], axis=-1)


def _cast(origins, dirs, field, t_max=_RAY_MAX):
    """Distance along each ray to the zero of ``field`` (inside at t = 0,
    outside at ``t_max``, one crossing in between)."""
    o = np.broadcast_to(origins, dirs.shape).reshape(-1, 3)
    d = dirs.reshape(-1, 3)
    lo = np.zeros(len(d))
    hi = np.full(len(d), t_max)
    for _ in range(8):  # bisection to ~1 mm
        mid = 0.5 * (lo + hi)
        inside = field(o + mid[:, None] * d) < 0.0
        lo = np.where(inside, mid, lo)
        hi = np.where(inside, hi, mid)
    f_lo = field(o + lo[:, None] * d)
    f_hi = field(o + hi[:, None] * d)
    for _ in range(5):  # Illinois false position
        t = hi - f_hi * (hi - lo) / (f_hi - f_lo)
        ft = field(o + t[:, None] * d)
        inside = ft < 0.0
        lo, hi = np.where(inside, t, lo), np.where(inside, hi, t)
        f_lo = np.where(inside, ft, 0.5 * f_lo)
        f_hi = np.where(inside, 0.5 * f_hi, ft)
    t = hi - f_hi * (hi - lo) / (f_hi - f_lo)
    return t.reshape(dirs.shape[:-1])


def _project(starts, dirs, field, length=0.3, step=2.5e-4):
    """First crossing of ``field`` marching from ``starts`` (outside) along ``dirs``."""
    ts = np.arange(0.0, length, step)
    pts = starts[:, None, :] + ts[None, :, None] * dirs[:, None, :]
    inside = (field(pts.reshape(-1, 3)) < 0.0).reshape(len(starts), len(ts))
    k = np.argmax(inside, axis=1)
    lo, hi = ts[np.maximum(k - 1, 0)], ts[k]
    for _ in range(20):
        mid = 0.5 * (lo + hi)
        inn = field(starts + mid[:, None] * dirs) < 0.0
        lo, hi = np.where(inn, lo, mid), np.where(inn, mid, hi)
    return starts + (0.5 * (lo + hi))[:, None] * dirs


# --------------------------------------------------------------------------
# Grid layout
# --------------------------------------------------------------------------
def _warp(u, lo, hi, dense_lo, dense_hi, blend, sparse, ears=0.0):
    """Map uniform samples ``u`` in [0, 1] to [lo, hi], dense inside
    [dense_lo, dense_hi] and ``sparse`` times as dense outside; with ``ears``,
    that density over the ears (azimuths of 75-120 degrees either side)."""
    a = np.linspace(lo, hi, 4097)
    w = _smoothstep(dense_lo - blend, dense_lo, a) * (1.0 - _smoothstep(dense_hi, dense_hi + blend, a))
    rho = sparse + (1.0 - sparse) * w
    if ears:
        e = _smoothstep(np.radians(62), np.radians(78), np.abs(a)) \
            * _smoothstep(np.radians(128), np.radians(114), np.abs(a))
        rho = np.maximum(rho, ears * e)
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (rho[1:] + rho[:-1]) * np.diff(a))])
    return np.interp(u * cum[-1], cum, a)


def _grid_size(target_verts):
    """Columns (multiple of 8) and rows for a vertex budget."""
    # vertices = C * R + (C/4 - 1)^2 with R = 0.8 C
    c = np.sqrt(target_verts / (0.8 + 1.0 / 16.0))
    cols = max(32, int(round(c / 8.0)) * 8)
    rows = max(16, int(round((target_verts - (cols // 4 - 1) ** 2) / cols)))
    return cols, rows


def _band_rays(cols, rows, field):
    """Ray origins and directions of the band, neck ring first, row-major."""
    s = np.linspace(-np.pi, np.pi, cols, endpoint=False)
    az0 = _warp((s + np.pi) / (2 * np.pi), -np.pi, np.pi, np.radians(-70), np.radians(70),
                np.radians(30), 0.25, ears=0.8)
    az0[0] = -np.pi
    rows_neck = max(3, int(round(0.07 * rows)))
    el = _warp(np.linspace(0.0, 1.0, rows - rows_neck), _EL_LOW, _EL_CAP,
               np.radians(-44), np.radians(48), np.radians(14), 0.45)
    az = np.broadcast_to(az0, (len(el), cols))
    # The lowest ray of each column meets the neck wall at z = _NECK_TOP ...
    flat = _directions(az0, np.zeros(cols))
    o_top = np.array([ORIGIN[0], ORIGIN[1], _NECK_TOP])
    rho = _cast(o_top, flat, field) * np.hypot(flat[:, 0], flat[:, 1])
    el_low = np.arctan2(_NECK_TOP - ORIGIN[2], rho)
    w = 1.0 - _smoothstep(_EL_LOW, np.radians(-30.0), el)
    el2 = el[:, None] + w[:, None] * np.maximum(el_low - _EL_LOW, 0.0)[None, :]
    dirs = _directions(az, el2)
    origins = np.broadcast_to(ORIGIN, dirs.shape)
    # ... and below it the neck is sampled by level rays from the axis.
    zs = _NECK_CUT + (_NECK_TOP - _NECK_CUT) * np.arange(rows_neck) / rows_neck
    neck_o = np.zeros((rows_neck, cols, 3))
    neck_o[..., 0], neck_o[..., 1], neck_o[..., 2] = ORIGIN[0], ORIGIN[1], zs[:, None]
    neck_d = np.broadcast_to(flat, (rows_neck, cols, 3))
    origins = np.concatenate([neck_o, origins]).reshape(-1, 3)
    dirs = np.concatenate([neck_d, dirs]).reshape(-1, 3)
    az_all = np.concatenate([np.broadcast_to(az0, (rows_neck, cols)), az]).ravel()
    el_row = np.concatenate([np.full(rows_neck, -0.5 * np.pi), el])
    return origins, dirs, az_all, el_row


def _cap_walk(m):
    """Boundary of an (m+1)^2 grid, in the order of the ring columns."""
    return np.concatenate([
        np.stack([np.arange(m), np.zeros(m, int)], 1),
        np.stack([np.full(m, m), np.arange(m)], 1),
        np.stack([np.arange(m, 0, -1), np.full(m, m)], 1),
        np.stack([np.zeros(m, int), np.arange(m, 0, -1)], 1),
    ])


def _topology(cols, rows):
    """Quads of the band (rows x cols, periodic) and of the cap on its top ring."""
    band = np.arange(rows * cols).reshape(rows, cols)
    nxt = np.roll(band, -1, axis=1)
    band_quads = np.stack([band[:-1], nxt[:-1], nxt[1:], band[1:]], -1).reshape(-1, 4)
    m = cols // 4
    cap = np.zeros((m + 1, m + 1), dtype=np.int64)
    walk = _cap_walk(m)
    cap[walk[:, 0], walk[:, 1]] = band[-1]
    cap[1:m, 1:m] = (rows * cols + np.arange((m - 1) ** 2)).reshape(m - 1, m - 1)
    cap_quads = np.stack([cap[:-1, :-1], cap[1:, :-1], cap[1:, 1:], cap[:-1, 1:]], -1)
    quads = np.concatenate([band_quads, cap_quads.reshape(-1, 4)]).astype(np.int32)
    return rows * cols + (m - 1) ** 2, quads, cap


def _neighbours(n_verts, quads):
    """Edge neighbours of every vertex, padded with -1."""
    e = np.concatenate([quads[:, [0, 1]], quads[:, [1, 2]], quads[:, [2, 3]], quads[:, [3, 0]]])
    e = np.unique(np.sort(e, 1), axis=0)
    e = np.concatenate([e, e[:, ::-1]])
    e = e[np.argsort(e[:, 0], kind="stable")]
    counts = np.bincount(e[:, 0], minlength=n_verts)
    start = np.concatenate([[0], np.cumsum(counts)[:-1]])
    nb = np.full((n_verts, counts.max()), -1, dtype=np.int64)
    nb[e[:, 0], np.arange(len(e)) - start[e[:, 0]]] = e[:, 1]
    return nb


def _crown(az, el, n_verts, quads, cap, polar):
    """2D azimuthal-equidistant coordinates of the crown: the cap is a Coons
    patch of its ring, then cap and the rows above _EL_FIXED are relaxed by
    umbrella smoothing so the four valence-3 corners open up."""
    q = np.zeros((n_verts, 2))
    theta = 0.5 * np.pi - el
    band = slice(0, len(az))
    q[band] = np.stack([theta * np.sin(az), -theta * np.cos(az)], 1)
    m = cap.shape[0] - 1
    qc = q[cap]  # interior rows are zero, the boundary holds the ring
    u = np.linspace(0.0, 1.0, m + 1)[:, None, None]
    v = np.linspace(0.0, 1.0, m + 1)[None, :, None]
    coons = ((1 - u) * qc[:1] + u * qc[-1:] + (1 - v) * qc[:, :1] + v * qc[:, -1:]
             - ((1 - u) * (1 - v) * qc[0, 0] + u * (1 - v) * qc[-1, 0]
                + (1 - u) * v * qc[0, -1] + u * v * qc[-1, -1]))
    q[cap[1:m, 1:m].ravel()] = coons[1:m, 1:m].reshape(-1, 2)

    idx = np.flatnonzero(polar)
    nb = _neighbours(n_verts, quads)[idx]
    valid = nb >= 0
    nb = np.where(valid, nb, 0)
    weight = valid / valid.sum(1, keepdims=True)
    for _ in range(250):
        q[idx] = np.einsum("ik,ikj->ij", weight, q[nb])
    return q


# --------------------------------------------------------------------------
# UVs
# --------------------------------------------------------------------------
_UV_AZ_FACE = np.radians(80.0)
_UV_SCALE = 0.45 / _UV_AZ_FACE  # UV units per radian on the face (both axes)
_UV_EL_MIN = np.radians(-78.0)


def _corner_uvs(positions, az, q, polar, quads, cols):
    """Band: u from the azimuth (linear over +-80 degrees, the back squeezed
    into the outer 5 %), v from the elevation seen from ORIGIN at the same
    scale. Crown (faces with every corner above _EL_FIXED): a disc island
    above the band."""
    n_band = len(az)
    rel = positions[:n_band].astype(np.float64) - ORIGIN
    el = np.arctan2(rel[:, 2], np.hypot(rel[:, 0], rel[:, 1]))
    az = np.where(np.arange(n_band) % cols == 0, -np.pi, az)  # column 0 is the seam
    a = np.abs(az)
    u = np.where(a <= _UV_AZ_FACE, _UV_SCALE * a,
                 0.45 + 0.05 * (a - _UV_AZ_FACE) / (np.pi - _UV_AZ_FACE))
    band_uv = np.stack([0.5 + np.sign(az) * u, 0.02 + _UV_SCALE * (el - _UV_EL_MIN)], axis=1)
    v_top = 0.02 + _UV_SCALE * (_EL_FIXED - _UV_EL_MIN)
    half = 0.5 * (1.0 - v_top) - 0.01
    centre = np.array([0.5, 1.0 - 0.01 - half])
    island_uv = centre + q * (half / (0.5 * np.pi - _EL_FIXED))

    crown = polar[quads].all(axis=1)
    corner = np.empty(quads.shape + (2,))
    corner[crown] = island_uv[quads[crown]]
    corner[~crown] = band_uv[quads[~crown]]
    # The last column closes on column 0 at u = 1.
    col = quads % cols
    wrap = ~crown[:, None] & (col == 0) & (col == cols - 1).any(axis=1, keepdims=True)
    corner[..., 0] = np.where(wrap, 1.0, corner[..., 0])
    return corner.astype(np.float32)


# --------------------------------------------------------------------------
# Landmarks
# --------------------------------------------------------------------------
# (x, z) seen from the front, for the left side (the right is mirrored).
_FRONT_LANDMARKS = {
    "glabella": (0.0, 0.129),
    "brow_inner_L": (0.014, 0.129),
    "brow_mid_L": (0.032, 0.1345),
    "brow_outer_L": (0.049, 0.1325),
    "hairline_center": (0.0, 0.188),
    "hairline_L": (0.032, 0.184),
    "eye_L": (0.0315, 0.1165),
    "nose_bridge": (0.0, 0.112),
    "nose_ala_L": (0.0165, 0.0755),
    "cheekbone_L": (0.052, 0.098),
    "mouth_corner_L": (0.0243, 0.0469),
    "upper_lip": (0.0, 0.0510),
    "lower_lip": (0.0, 0.0428),
    "chin": (0.0, 0.0215),
    "jaw_L": (0.029, 0.0235),
}


def _landmarks(positions, field):
    names, starts, dirs = [], [], []
    for name, (x, z) in _FRONT_LANDMARKS.items():
        sides = [(name, x)] if not name.endswith("_L") else [(name, x), (name[:-2] + "_R", -x)]
        for n, xx in sides:
            names.append(n)
            starts.append((xx, -0.3, z))
            dirs.append((0.0, 1.0, 0.0))
    for n, sign in (("cheek_lateral_L", 1.0), ("cheek_lateral_R", -1.0)):
        toward = -_directions(np.radians(60.0) * sign, 0.0)
        names.append(n)
        starts.append(np.array([ORIGIN[0], ORIGIN[1], 0.048]) - 0.2 * toward)
        dirs.append(toward)
    hits = _project(np.array(starts, float), np.array(dirs, float), field)
    pos = positions.astype(np.float64)
    out = {}
    for name, hit in zip(names, hits):
        out[name] = positions[np.argmin(np.einsum("ij,ij->i", pos - hit, pos - hit))]
    # The nose tip is the most forward vertex of the nose.
    near = (np.abs(pos[:, 0]) < 0.01) & (np.abs(pos[:, 2] - 0.082) < 0.012)
    out["nose_tip"] = positions[np.flatnonzero(near)[np.argmin(pos[near, 1])]]
    return {n: out[n].astype(np.float32).copy() for n in LANDMARK_NAMES}


# --------------------------------------------------------------------------
# Public API
# --------------------------------------------------------------------------
def make_head(target_verts=40000):
    """An all-quad human head, closed at the crown and open at the neck.

    Returns a dict: ``positions`` (N, 3) float32, ``quads`` (F, 4) int32
    wound counter-clockwise seen from outside, ``corner_uvs`` (F, 4, 2)
    float32 and ``landmarks`` (name -> (3,) float32, each a vertex position).
    ``target_verts`` sets the resolution (the count lands within 1 % of it);
    at the default 40k the forehead, brows, eyes, nose and mouth have edges of
    1.6-1.9 mm (median), at 10k about 3.5 mm, at 200k about 0.8 mm.
    Deterministic: the same target gives the same arrays.
    """
    cols, rows = _grid_size(float(target_verts))
    edge = 0.0016 * np.sqrt(40000.0 / float(target_verts))
    field = partial(head_field, detail=0.6 * edge)
    n_verts, quads, cap = _topology(cols, rows)
    origins, dirs, az, el_row = _band_rays(cols, rows, field)
    n_band = rows * cols
    polar = np.zeros(n_verts, bool)
    polar[n_band:] = True
    polar[:n_band] = np.repeat(el_row > _EL_FIXED, cols)
    el = np.arcsin(np.clip(dirs[:, 2], -1.0, 1.0))
    q = _crown(az, el, n_verts, quads, cap, polar)
    theta = np.hypot(q[:, 0], q[:, 1])
    az_all = np.concatenate([az, np.zeros(n_verts - n_band)])
    az_all[polar] = np.arctan2(q[polar, 0], -q[polar, 1])
    origins = np.concatenate([origins, np.broadcast_to(ORIGIN, (n_verts - n_band, 3))])
    all_dirs = np.concatenate([dirs, np.zeros((n_verts - n_band, 3))])
    all_dirs[polar] = _directions(az_all[polar], 0.5 * np.pi - theta[polar])
    t = _cast(origins, all_dirs, field)
    positions = (origins + t[:, None] * all_dirs).astype(np.float32)
    corner_uvs = _corner_uvs(positions, az_all[:n_band], q, polar, quads, cols)
    return {"positions": positions, "quads": quads, "corner_uvs": corner_uvs,
            "landmarks": _landmarks(positions, field)}


def make_forehead_patch(width=0.14, height=0.08, target_verts=20000, radius=0.10):
    """A forehead-like sheet: a cylinder section about the Z axis facing -Y.

    The patch spans ``width`` of arc and ``height`` in Z (from z = 0 at the
    brows up to z = height at the hairline), on a cylinder of ``radius``
    centred on the Z axis, so its middle is at (0, -radius, height/2). Square
    quads; UVs are arc length and height divided by ``width`` (isometric).
    Landmarks: ``attachment_L/R`` on the top edge (hairline), ``insertion_L/R``
    near the bottom edge (brows), at x = +-width/5.
    """
    aspect = height / width
    nx = max(2, int(round(np.sqrt(target_verts / aspect))))
    nz = max(2, int(round(target_verts / nx)))
    s = np.linspace(-0.5 * width, 0.5 * width, nx)
    zs = np.linspace(0.0, height, nz)
    phi = s / radius
    S, Z = np.meshgrid(s, zs)
    P = np.stack([radius * np.sin(phi)[None, :].repeat(nz, 0),
                  -radius * np.cos(phi)[None, :].repeat(nz, 0), Z], -1)
    positions = P.reshape(-1, 3).astype(np.float32)
    idx = np.arange(nx * nz).reshape(nz, nx)
    quads = np.stack([idx[:-1, :-1], idx[:-1, 1:], idx[1:, 1:], idx[1:, :-1]], -1)
    quads = quads.reshape(-1, 4).astype(np.int32)
    uv = np.stack([(S + 0.5 * width) / width, Z / width], -1).reshape(-1, 2)
    corner_uvs = uv[quads].astype(np.float32)

    def at(arc, zz):
        a = arc / radius
        target = np.array([radius * np.sin(a), -radius * np.cos(a), zz])
        d2 = np.einsum("ij,ij->i", positions - target, positions - target)
        return positions[np.argmin(d2)].copy()

    lx = 0.2 * width
    landmarks = {
        "attachment_L": at(lx, height),
        "attachment_R": at(-lx, height),
        "insertion_L": at(lx, 0.1 * height),
        "insertion_R": at(-lx, 0.1 * height),
    }
    return {"positions": positions, "quads": quads, "corner_uvs": corner_uvs,
            "landmarks": landmarks}
