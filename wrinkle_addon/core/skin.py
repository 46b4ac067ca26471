# SPDX-License-Identifier: GPL-3.0-or-later
"""Where a face's skin differs, from its landmarks: the weights a skin material reads.

Skin is not one material over the face. The T-zone (the forehead, the nose and the chin)
has the most sebaceous glands, so it is oilier: a sharper, stronger highlight. Where the
skin is thin or well supplied with blood (the apples of the cheeks, the nose's tip and
wings, the eyelids, the ears), it is redder. The red of the lips is a tissue of its own.
:func:`regions` gives the three weights per point, each in [0, 1], with soft C¹ edges, so
that a material can blend its colour, roughness and specular by them with no image.

Every size is in units of E, the distance between the eyes (about 63 mm on an adult), so
the regions fit any head; the face looks toward -Y with Z up and the character's left at
+X, the right side the left mirrored about the glabella's x (landmark names as
``core.zones``). The lips' weight is the lip zone of :func:`core.zones.face_zones`, which
keeps wrinkles off the lips too, so the two agree.

:func:`eye_directions` gives each point of an eyeball its direction in the eye's own frame
(its gaze +Z), from which a material draws the pupil, the iris and the limbus.

Pure NumPy, no loop over points.
"""

import numpy as np

from .mesh import smoothstep
from .zones import face_zones

__all__ = ["regions", "components", "sphere_centre", "cornea_apex", "eye_directions", "moving"]


def _blob(p, centre, radius):
    """1 at ``centre``, falling smoothly to 0 at ``radius`` (C¹), per point."""
    d = np.linalg.norm(p - centre, axis=1) / max(radius, 1e-9)
    return smoothstep(1.0 - d)


def regions(rest, landmarks):
    """(N, 3) float32 weights of the points ``rest`` (N, 3): oil (the T-zone), red (thin,
    flushed skin) and lip (the red of the lips), each in [0, 1] (see the module doc)."""
    p = np.asarray(rest, np.float64).reshape(-1, 3)
    lm = {k: np.asarray(v, np.float64) for k, v in landmarks.items()}
    g, eye, nose = lm["glabella"], lm["eye_L"], lm["nose_tip"]
    mouth, chin, cheek = lm["mouth_corner_L"], lm["chin"], lm["cheekbone_L"]
    e = max(2.0 * abs(eye[0] - g[0]), 1e-6)
    top = lm.get("hairline_center", g + (0.0, 0.0, 0.9 * e))

    def mirrored(q):
        return (q, q * (-1.0, 1.0, 1.0) + (2.0 * g[0], 0.0, 0.0))

    # Only the front of the face: no more than 0.6 E behind the eyes.
    front = smoothstep((eye[1] + 0.6 * e - p[:, 1]) / (0.2 * e))
    x = np.abs(p[:, 0] - g[0])
    forehead = smoothstep((p[:, 2] - (eye[2] + 0.45 * e)) / (0.25 * e)) \
        * smoothstep((top[2] + 0.15 * e - p[:, 2]) / (0.2 * e)) * smoothstep((0.85 * e - x) / (0.3 * e))
    nose_band = smoothstep((0.22 * e - x) / (0.12 * e)) \
        * smoothstep((p[:, 2] - (nose[2] - 0.12 * e)) / (0.1 * e)) * smoothstep((g[2] - p[:, 2]) / (0.2 * e))
    chin_blob = _blob(p, chin + (0.0, 0.0, 0.1 * e), 0.4 * e)
    oil = np.maximum.reduce([forehead, nose_band, 0.6 * chin_blob]) * front

    apple = 0.55 * cheek + 0.45 * mouth  # the cheek's apple: below the cheekbone, toward the mouth
    apple = apple + (0.0, 0.0, 0.1 * e)
    red = np.zeros(len(p))
    for a in mirrored(apple):
        red = np.maximum(red, 0.7 * _blob(p, a, 0.45 * e))
    red = np.maximum(red, _blob(p, nose + (0.0, 0.0, -0.04 * e), 0.35 * e))
    for c in mirrored(eye):
        red = np.maximum(red, 0.45 * _blob(p, c, 0.38 * e))  # the lids' thin skin
    ears = smoothstep((x - 1.05 * e) / (0.2 * e)) * smoothstep((0.5 * e - np.abs(p[:, 2] - eye[2] + 0.2 * e))
                                                              / (0.3 * e))
    red = np.maximum(red * front, 0.5 * ears)

    z = face_zones(p, landmarks)
    lip = smoothstep((1.08 - z.lip_radius) / 0.16)
    return np.stack([oil, red, lip], axis=1).astype(np.float32)


def sphere_centre(points):
    """The centre of the sphere that fits ``points`` (N, 3) best (linear least squares on
    ``|p|^2 = 2 p.c + k``): an eyeball's centre, however its vertices crowd toward the front."""
    p = np.asarray(points, np.float64).reshape(-1, 3)
    a = np.concatenate([2.0 * p, np.ones((len(p), 1))], axis=1)
    sol, *_ = np.linalg.lstsq(a, (p * p).sum(axis=1), rcond=None)
    return sol[:3]


def cornea_apex(shell):
    """The front of the cornea on an eye's outer shell (N, 3): the point farthest from the
    shell's own best-fit centre, the top of the cornea's bulge."""
    p = np.asarray(shell, np.float64).reshape(-1, 3)
    return p[np.argmax(np.linalg.norm(p - sphere_centre(p), axis=1))]


def eye_directions(points, apex):
    """(N, 3) float32: each point's unit direction from the eyeball's centre, in the eye's
    frame (+Z the gaze, toward ``apex``, the front of the cornea; +X and +Y across it).

    The centre is the best-fit sphere's (:func:`sphere_centre`) of ``points``, an eyeball's
    vertices. A material reads the angle from the gaze, ``acos(z)``, for the pupil and the iris."""
    p = np.asarray(points, np.float64).reshape(-1, 3)
    centre = sphere_centre(p)
    gaze = np.asarray(apex, np.float64) - centre
    gaze /= max(np.linalg.norm(gaze), 1e-12)
    side = np.cross(gaze, (0.0, 0.0, 1.0) if abs(gaze[2]) < 0.9 else (1.0, 0.0, 0.0))
    side /= np.linalg.norm(side)
    up = np.cross(gaze, side)
    d = p - centre
    d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)
    return np.stack([d @ side, d @ up, d @ gaze], axis=1).astype(np.float32)


def components(count, sizes, corner_verts):
    """Each of ``count`` vertices' connected component, numbered 0, 1, ... in the order of
    their lowest vertex, for polygons given as ``sizes`` (F,) and ``corner_verts``: the least
    index is propagated over the polygons until it settles (as many passes as the widest
    component is across, vectorised over the polygons)."""
    sizes = np.asarray(sizes, np.int64)
    corner_verts = np.asarray(corner_verts, np.int64)
    face = np.repeat(np.arange(len(sizes)), sizes)
    label = np.arange(count)
    while True:
        low = np.full(len(sizes), count)
        np.minimum.at(low, face, label[corner_verts])
        new = label.copy()
        np.minimum.at(new, corner_verts, low[face])
        if np.array_equal(new, label):
            return np.unique(label, return_inverse=True)[1].reshape(-1)
        label = new


def moving(deltas, tolerance):
    """The indices of the expressions (rows of ``deltas``, (E, N, 3)) that move some point by
    more than ``tolerance``."""
    d = np.asarray(deltas, np.float32)
    if d.shape[1] == 0:
        return np.zeros(0, np.int64)
    return np.flatnonzero(np.abs(d).reshape(len(d), -1).max(axis=1) > tolerance)
