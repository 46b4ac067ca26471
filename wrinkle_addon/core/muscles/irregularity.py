# SPDX-License-Identifier: GPL-3.0-or-later
"""Natural irregularity of the muscle wrinkles: not in Zhang, Sim & Tan 2005, whose eq. 7
makes every furrow of a muscle a copy of the next (docs/model.md, "Irregularity").

:func:`apply` perturbs a muscle's wrinkles with seeded smooth functions of the rest
position ``p`` (the face's local space) and of the phase coordinate ``l`` (the distance
along the fibre that eq. 7 turns into the cycle position ``w``), in units of the muscle's
half cycle ``u``.  With the irregularity ``a`` (0 to :data:`MAX_AMOUNT`)::

    l' = l + u [ S_l/2 sum_j sin(kappa_j l/u + psi_j) / kappa_j                  spacing
               + c S_p sqrt(3)/4 sum_i sin(k_i d_i . p~/u + phi_i) / k_i         course: placement
               + (1 - c) S_p sqrt(3)/4 sum_i sin(k'_i d'_i . p/u + phi'_i) / k'_i ]   and wander
    f  = soft(1 + DEPTH a n(p~)),  n(p~) = sqrt(1/2) sum_i sin(q_i e_i . p~/u + chi_i)  depth

with ``p~`` the point mirrored onto the face's +x side (:func:`mirrored`) and
``c`` = :data:`PLACEMENT_SHARE`.

    S(a) = MAX_SLOPE tanh(a SLOPE / MAX_SLOPE),  S_l = SPACING_SHARE S,  S_p = S - S_l

``l'`` takes the place of ``l`` in eq. 7, so the furrows (``w = 0``) move: the *spacing*
term (two sinusoids in ``l``, wavelengths :data:`SPACING_WAVELENGTHS`) makes one furrow
further from the next than another, the *course* terms (four sinusoids in space each) bend
each furrow into gentle waves: the long waves (:data:`PLACEMENT_WAVELENGTHS`), which shift a
whole furrow, read at the mirrored point, and the short ones (:data:`WANDER_WAVELENGTHS`),
which make it wander, at the point itself.  ``f`` multiplies the
amplitude: the depth changes along every furrow (:data:`DEPTH_WAVELENGTHS`), and a furrow
fades out smoothly where ``1 + DEPTH a n`` falls below 1/4 (``n`` is never below -2.83, so
at the default hardly anywhere; from about ``a = 1.5`` some furrows end partway).

* **Neighbours join.**  Nothing depends on the muscle but ``u``, ``l`` and the seed (the
  face's): two neighbouring muscles with the same half cycle and the same ``l`` where they
  meet (the Frontalis sheets, which share their attachment line, and the two sides at the
  midline) get the same warp and depth there, so a furrow still runs across both.
* **Both sides alike in strength.**  The depth field and the course's long waves are read
  at the point mirrored onto the face's +x side (:func:`mirrored`: the face's local x = 0
  is its plane of symmetry, as for Blender's Mirror modifier), and the spacing is a function
  of ``l``, which a mirrored pair of muscles shares at mirrored points; so on a symmetric
  face the left and the right furrows lie at the same place on the compression and are as
  deep and as many as each other.  (Read at the point itself, the long waves moved a whole
  furrow by up to 0.8 u on one side and not on the other, off the compression's peak or
  onto it: the left frown line and nasolabial fold were 1.2 times as deep as the right.)
  Only the wander, the short waves with an L/R difference of about 0.05 u (at most 0.17 u),
  is each side's own, so each side's furrows take their own path.
* **Static.**  Evaluated once on the rest mesh and baked into the static amplitude
  ``H(w') At f``; only ``A(eps)`` changes per frame, so a furrow stays where it is as it
  deepens.
* **Never folds.**  ``d_i`` (and ``e_i``) are the four diagonals of a cube turned by a
  seeded rotation.  For any unit vector ``t``, ``sum_i |d_i . t| <= 4/sqrt(3)``, so the
  course's slope along any direction is at most ``S_p`` (the mirror map's slope is at most
  1, so the long waves read at ``p~`` keep their share of it); the spacing term's derivative in
  ``l`` is at most ``S_l``.  Along a fibre (``|grad l| = 1`` for Waters' linear and sheet
  muscles) ``dl'/dl >= 1 - S > 1 - MAX_SLOPE > 0``: furrows never fold or cross.  The four
  diagonals are also a tight frame (``sum_i (d_i . t)² = 4/3``), so the course looks the
  same in every direction and for every seed.
* **Wavelengths** are spread log-evenly over their range (in ``u``), each jittered within
  its share, and given to the directions in a seeded order.  The spacing term is a
  function of ``l``, not of the position: a field in space averages out along a furrow
  (a forehead furrow is 17 half cycles long), and the furrows' mean spacing barely varied.
* ``soft`` is a C¹ ramp: ``x`` above 1/4, ``(x + 1/4)²`` down to 0 at -1/4, 0 below; so
  ``f >= 0`` and its mean is about 1.
* **The same on every machine.**  The random numbers come from SplitMix64 on Python
  integers, not from NumPy's generators, whose streams may change between versions.

``a = 0`` returns ``l`` itself and ``f = 1`` exactly, so the wrinkles are Zhang's (and the
add-on's earlier ones) to the bit.
"""

import numpy as np

MAX_AMOUNT = 4.0  # the largest irregularity the core uses (the muscle's value is clamped to it)
DEFAULT = 1.0  # the natural look: the face's default (docs/model.md, "Irregularity")
MAX_SLOPE = 0.85  # the warp's largest slope, whatever the amount: dl'/dl >= 0.15
SLOPE = 1.5  # the warp's slope bound per unit of amount, for small amounts
DEPTH = 0.3  # the depth field's standard deviation per unit of amount (s(a) = DEPTH a)
SPACING_SHARE = 0.7  # the share of the slope bound S that goes to the spacing term
SPACING_WAVELENGTHS = (4.0, 10.0)  # the spacing term's wavelengths along l, in half cycles u
PLACEMENT_WAVELENGTHS = (10.0, 20.0)  # the course's long waves in space, in half cycles u
WANDER_WAVELENGTHS = (5.0, 10.0)  # its short waves, in half cycles u
PLACEMENT_SHARE = 0.8  # the share of the course's slope bound S_p that goes to the long waves
DEPTH_WAVELENGTHS = (5.0, 14.0)  # the depth field's wavelengths, in half cycles u
_SOFT = 0.25  # where the depth factor's ramp to 0 starts (see soft)

_MASK = (1 << 64) - 1
_GOLDEN = 0x9E3779B97F4A7C15
# the four diagonals of a cube: a tight frame, sum (d . t)² = 4/3 for every unit t
_DIAGONALS = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=np.float64) / np.sqrt(3.0)
_DIAGONAL_BOUND = 4.0 / np.sqrt(3.0)  # max over unit t of sum |d_i . t| (t along a cube axis)


def uniforms(seed, stream, n):
    """``n`` floats in [0, 1) from SplitMix64, for the integer ``seed`` and ``stream``: the
    same on every machine and NumPy version (a loop over ``n`` numbers, not vertices)."""
    x = (int(seed) * _GOLDEN + int(stream) * 0xD1B54A32D192ED03 + 0x632BE59BD9B4E019) & _MASK
    out = np.empty(n)
    for i in range(n):
        x = (x + _GOLDEN) & _MASK
        z = ((x ^ (x >> 30)) * 0xBF58476D1CE4E5B9) & _MASK
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & _MASK
        out[i] = ((z ^ (z >> 31)) >> 11) * 2.0**-53
    return out


def _rotation(r):
    """A uniformly random rotation from three uniforms (Shoemake's quaternion)."""
    a, b = np.sqrt(1.0 - r[0]), np.sqrt(r[0])
    x, y = a * np.sin(2.0 * np.pi * r[1]), a * np.cos(2.0 * np.pi * r[1])
    z, w = b * np.sin(2.0 * np.pi * r[2]), b * np.cos(2.0 * np.pi * r[2])
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def components(seed, stream, wavelengths):
    """One field's four sinusoids: wave vectors (3, 4) in units of 1/u and phases (4,).
    The directions are the cube's diagonals turned by a seeded rotation; the wavelengths
    are log-evenly spread over ``wavelengths`` (in u), each jittered within its quarter and
    given to the directions in a seeded order."""
    r = uniforms(seed, stream, 3 + 4 + 4 + 4)
    dirs = _DIAGONALS @ _rotation(r[:3]).T
    lo, hi = np.log(wavelengths[0]), np.log(wavelengths[1])
    lam = np.exp(lo + (hi - lo) * (np.arange(4) + r[3:7]) / 4.0)
    lam = lam[np.argsort(r[7:11])]
    k = 2.0 * np.pi / lam
    return (dirs * k[:, None]).T, 2.0 * np.pi * r[11:15]


def soft(x):
    """The depth factor's C¹ ramp: ``x`` above ``1/4``, ``(x + 1/4)²`` down to 0 at ``-1/4``,
    0 below (value and slope match at both joints)."""
    x = np.asarray(x, dtype=np.float64)
    ramp = (x + _SOFT) ** 2 / (4.0 * _SOFT)
    return np.where(x >= _SOFT, x, np.where(x > -_SOFT, ramp, 0.0))


def slope(amount):
    """``S(a)``: the largest slope of the warp ``l' - l`` along any direction (< 1)."""
    a = _amount(amount)
    return MAX_SLOPE * float(np.tanh(a * SLOPE / MAX_SLOPE))


def _amount(amount):
    a = float(amount)
    return min(max(a, 0.0), MAX_AMOUNT) if np.isfinite(a) else 0.0


def _spacing_components(seed, stream, wavelengths, n=2):
    """The spacing term's ``n`` sinusoids in ``along``: wavenumbers (n,) in 1/u, log-evenly
    spread over ``wavelengths`` (in u) with a seeded jitter, and phases (n,)."""
    r = uniforms(seed, stream, 2 * n)
    lo, hi = np.log(wavelengths[0]), np.log(wavelengths[1])
    lam = np.exp(lo + (hi - lo) * (np.arange(n) + r[:n]) / n)
    return 2.0 * np.pi / lam, 2.0 * np.pi * r[n:]


def mirrored(p):
    """``p`` (K, 3), in half cycles, with x replaced by ``sqrt(x² + 1)``: the same at a point
    and at its mirror image across the face's plane of symmetry x = 0 (Blender's: the
    Mirror modifier's and symmetric sculpting's), smooth across it, and ``|x|`` a few half
    cycles out.  The depth field is read there, so the two sides of a face get equally deep
    furrows; the course's short waves are read at ``p`` itself, so their lines differ."""
    q = np.array(p, dtype=np.float64, copy=True)
    q[:, 0] = np.sqrt(q[:, 0] * q[:, 0] + 1.0)
    return q


def apply(points, along, u, seed, amount):
    """The irregular phase and depth of a muscle's wrinkles (see the module doc).

    ``points`` (K, 3): the region's rest positions in the face's local space; ``along``
    (K,): the coordinate that eq. 7 turns into the cycle position (``l``, the distance
    along the fibre); ``u``: the muscle's half cycle (eq. 6), the fields' unit of length;
    ``seed``: any integer (the face's); ``amount``: the irregularity, clamped to
    [0, :data:`MAX_AMOUNT`] (NaN is 0).

    Returns ``(along_warped, depth_factor)``, both (K,) float64: ``along`` plus a smooth
    warp, and a smooth factor >= 0 of mean about 1 to multiply the amplitude by.  The
    warp's derivative along ``along`` is at least ``-SPACING_SHARE S`` and its slope in
    space at most ``(1 - SPACING_SHARE) S`` (``S`` = :func:`slope` < 1), so wherever
    ``along`` grows by 1 per unit length (a distance along a fibre does) the warped one
    still grows by at least ``1 - S``: furrows never fold or cross.  With ``amount`` 0,
    or no points, or ``u <= 0``, ``along`` is returned as it is and the factor is exactly 1.

    Any muscle kind can use it: pass the coordinate whose level sets are its furrows
    (a sphincter's distance across its band, say) and its half cycle.  Muscles whose
    furrows should join must get the same ``u``, ``seed`` and ``amount``, and the same
    ``along`` where they meet (the Frontalis sheets, which share one attachment line)."""
    along = np.asarray(along, dtype=np.float64)
    a = _amount(amount)
    u = float(u)
    if a == 0.0 or along.size == 0 or not (np.isfinite(u) and u > 0.0):
        return along, np.ones_like(along)
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3) / u
    seed = int(seed) & _MASK
    total = slope(a)
    # the spacing: a few sinusoids in along, each of slope amplitude S_l / n
    kappa, psi = _spacing_components(seed, 3, SPACING_WAVELENGTHS)
    spacing = np.sin(np.multiply.outer(along / u, kappa) + psi) @ (SPACING_SHARE * total / len(kappa) / kappa)
    # the course: two fields in space, each sinusoid's slope amplitude its share of S_p over
    # 4/sqrt(3); the long waves (a furrow's placement) read mirrored, the short ones (its wander) not
    course = 0.0
    for stream, wavelengths, share, at in ((1, PLACEMENT_WAVELENGTHS, PLACEMENT_SHARE, mirrored(p)),
                                           (4, WANDER_WAVELENGTHS, 1.0 - PLACEMENT_SHARE, p)):
        waves, phases = components(seed, stream, wavelengths)
        k = np.linalg.norm(waves, axis=0)
        course = course + np.sin(at @ waves + phases) @ (
            ((1.0 - SPACING_SHARE) * share * total / _DIAGONAL_BOUND) / k)
    waves, phases = components(seed, 2, DEPTH_WAVELENGTHS)
    noise = np.sin(mirrored(p) @ waves + phases).sum(axis=1) * np.sqrt(0.5)  # standard deviation 1
    return along + u * (spacing + course), soft(1.0 + DEPTH * a * noise)
