# SPDX-License-Identifier: GPL-3.0-or-later
"""The face's no-wrinkle zones: the eyelids and the lips, from the facial landmarks.

Real skin does not fold into expression lines on the eyelids (thin skin that slides over
the eye) or on the red of the lips, and the eye and mouth openings are where a muscle's
pull and its wrinkles must stop.  Every wrinkle source multiplies its heights (and the
muscles their pull) by :func:`keep_out`, which is 0 inside those zones and rises to 1
with a C¹ smoothstep over a margin around them.

The zones are ellipses in the face's front plane (x, z), sized from the landmarks so that
they fit any head (landmark names as ``core.landmark_finder.LANDMARKS``; face-local
coordinates, the face looking toward -Y, Z up, the character's left +X; the right side is
the left mirrored about the glabella's x):

* **eyelid**: centred on the eye; half-width 0.235 of the distance E between the eyes (about
  63 mm on an adult, so 15 mm: the palpebral fissure's half width, 14-15 mm, to the eye's
  corners, so that crow's feet, which start at the outer corner, stay free; the margin ramp
  then reaches 20 mm; E, not the brow, whose outer end lies a varying way beyond the eye);
  upwards the whole eye-to-glabella height (the upper lid, its fold and the skin up to the
  brow, which does not fold when the brows move), downwards 0.6 of it (the lower lid);
* **lip**: centred on the mouth line between the corners; half-width the
  corner-to-midline distance; upwards 0.4 of the mouth-to-nose-tip height (the upper
  vermilion, not the philtrum above it), downwards 0.3 of the mouth-to-chin height.

Only points in front are concerned (no more than a half brow width behind the eye or
the mouth corner), so the back of the head never matches.  Pure NumPy, no loop over
vertices.
"""

from dataclasses import dataclass

import numpy as np

from .mesh import smoothstep

# each zone's ``margin``: its keep-out ramp, in units of the ellipse's own radius; the lips'
# is short, so the nasolabial fold beside the mouth corner keeps its depth
EYELID = {"half_width": 0.235, "up": 1.0, "down": 0.6, "margin": 0.35}  # half-width in E
LIP = {"half_width": 1.0, "up": 0.4, "down": 0.3, "margin": 0.15}


@dataclass
class Zones:
    eyelid: np.ndarray  # (N,) bool: inside an eyelid zone (either side)
    lip: np.ndarray  # (N,) bool: inside the lip zone
    eyelid_radius: np.ndarray  # (N,) float64: elliptic radius to the nearer eyelid zone (<= 1 inside)
    lip_radius: np.ndarray  # (N,) float64: elliptic radius to the lip zone (<= 1 inside)

    @property
    def inside(self):
        return self.eyelid | self.lip


def _radius(p, centre, half_width, up, down, depth):
    """Elliptic radius (N,) of the points ``p`` around ``centre`` in the (x, z) plane; inf
    for points more than ``depth`` behind the centre (+Y is backwards)."""
    dx = (p[:, 0] - centre[0]) / max(half_width, 1e-9)
    dz = p[:, 2] - centre[2]
    dz = dz / np.where(dz >= 0.0, max(up, 1e-9), max(down, 1e-9))
    r = np.sqrt(dx * dx + dz * dz)
    return np.where(p[:, 1] - centre[1] <= depth, r, np.inf)


def face_zones(rest, landmarks):
    """The eyelid and lip zones of the points ``rest`` (N, 3) (see the module doc)."""
    p = np.asarray(rest, np.float64).reshape(-1, 3)
    lm = {k: np.asarray(v, np.float64) for k, v in landmarks.items()}
    g, bo, eye = lm["glabella"], lm["brow_outer_L"], lm["eye_L"]
    mouth, nose, chin = lm["mouth_corner_L"], lm["nose_tip"], lm["chin"]
    bw = abs(bo[0] - g[0])
    lid_h = max(g[2] - eye[2], 0.2 * bw)
    lids = []
    for sx in (1.0, -1.0):
        c = eye.copy()
        c[0] = g[0] + sx * (eye[0] - g[0])
        e = 2.0 * abs(eye[0] - g[0])  # the distance between the eyes
        lids.append(_radius(p, c, EYELID["half_width"] * e, EYELID["up"] * lid_h,
                            EYELID["down"] * lid_h, bw))
    eyelid_r = np.minimum(*lids)
    c = mouth.copy()
    c[0] = g[0]
    hw = abs(mouth[0] - g[0])
    lip_r = _radius(p, c, LIP["half_width"] * hw, LIP["up"] * max(nose[2] - mouth[2], 0.0),
                    LIP["down"] * max(mouth[2] - chin[2], 0.0), bw)
    return Zones(eyelid=eyelid_r <= 1.0, lip=lip_r <= 1.0, eyelid_radius=eyelid_r, lip_radius=lip_r)


def keep_out(rest, landmarks):
    """Per-point weight (N,) float32: 0 inside the eyelid and lip zones, rising with a C¹
    smoothstep to 1 at each zone's ``margin`` (in units of its radius) outside it."""
    z = face_zones(rest, landmarks)
    lid = smoothstep((z.eyelid_radius - 1.0) / EYELID["margin"])
    lip = smoothstep((z.lip_radius - 1.0) / LIP["margin"])
    return (lid * lip).astype(np.float32)
