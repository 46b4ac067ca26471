# SPDX-License-Identifier: GPL-3.0-or-later
"""Zhang 2005 Fig. 1 muscle layout from a few facial landmarks, and the §3 expressions; with
the sphincters round the eyes and the mouth, and the Procerus (``sphincter``).

All coordinates are the face's local space with the face looking toward -Y and
Z up (Blender's front view); the character's left is +X.  The layout only
fixes each muscle's end points in the (x, z) plane of the face; the caller
projects them onto the skin (a ray cast from the front) so the muscles sit on
the surface of any head.

The landmarks are ``core.landmark_finder.LANDMARKS``, all of the character's left side
except the midline ones; the right side is mirrored about the plane through the glabella.
"""

import numpy as np

# (role, display name, type)
MUSCLES = (
    ("FRONTALIS_INNER", "Frontalis Inner", "SHEET"),
    ("FRONTALIS_MAJOR", "Frontalis Major", "SHEET"),
    ("FRONTALIS_OUTER", "Frontalis Outer", "SHEET"),
    ("CORRUGATOR", "Corrugator Supercilii", "SHEET"),
    ("NASALIS", "Nasalis", "LINEAR"),
    ("ZYGOMATICUS_MINOR", "Zygomaticus Minor", "LINEAR"),
    ("ZYGOMATICUS_MAJOR", "Zygomaticus Major", "LINEAR"),
    ("RISORIUS", "Risorius", "LINEAR"),
    ("DEPRESSOR_ANGULI", "Depressor Anguli Oris", "LINEAR"),
    ("MENTALIS", "Mentalis", "LINEAR"),
    # beyond Zhang's ten: the sphincters he names as future work, and the Procerus
    ("ORBICULARIS_OCULI", "Orbicularis Oculi", "SPHINCTER"),
    ("ORBICULARIS_ORIS", "Orbicularis Oris", "SPHINCTER"),
    ("PROCERUS", "Procerus", "SHEET"),
)
MIDLINE = ("ORBICULARIS_ORIS", "PROCERUS")  # one muscle on the midline, not a mirrored pair

# Zhang §3: which muscles each expression contracts, and how much.
EXPRESSIONS = {
    "NEUTRAL": {},
    "SURPRISE": {"FRONTALIS_INNER": 1.0, "FRONTALIS_MAJOR": 1.0, "FRONTALIS_OUTER": 0.8},
    "FROWN": {"CORRUGATOR": 1.0},
    "FEAR": {"FRONTALIS_INNER": 1.0, "CORRUGATOR": 0.8},
}
# The one list of those expressions as the interface shows them: (key, label, tooltip).
EXPRESSION_ITEMS = (
    ("SURPRISE", "Surprise", "Frontalis inner, major and outer contract: raised brows, forehead wrinkles"),
    ("FROWN", "Frowning", "Corrugators contract: lowered brows, vertical wrinkles between them"),
    ("FEAR", "Fear", "Frontalis inner and corrugators contract"),
    ("NEUTRAL", "Neutral", "Every muscle relaxed"),
)

# Parameters per role that differ from the defaults (angles in degrees; ``reach`` is the
# area of influence as a multiple of the attachment-insertion distance, ``depth_factor``
# the furrow depth k0 as a fraction of the half cycle u).
ROLE_PARAMS = {
    # the forehead from the hairline to below the brows in six cycles: four furrows on the forehead
    "FRONTALIS_INNER": {"lambda_w": 0.0, "n_wrinkles": 6, "pull": 0.18},
    "FRONTALIS_MAJOR": {"lambda_w": 0.0, "n_wrinkles": 6, "pull": 0.18},
    "FRONTALIS_OUTER": {"lambda_w": 0.0, "n_wrinkles": 6, "pull": 0.18},
    # frown lines ("the elevens") and bunny lines are deep for their spacing
    # a wide fan, so the furrows near the glabella run 10-20 mm up and down.  The Corrugator's
    # region starts on the midline (lambda_w 0), so the skin between the two lines bunches over
    # a whole half cycle each side; begun 2 mm out (0.08), its fade ended on a steep ridge: a knot
    "CORRUGATOR": {"lambda_w": 0.0, "n_wrinkles": 2, "depth_factor": 0.6, "reach": 1.3},
    # bunny lines on the sides of the nose, soft: the region ends at the insertion beside the
    # bridge (a longer reach ran its arcs round the bridge into the other side's)
    "NASALIS": {"lambda_w": 0.3, "n_wrinkles": 2, "angle": 30.0, "depth_factor": 0.25, "reach": 1.0},
    "ZYGOMATICUS_MINOR": {"lambda_w": 0.5, "n_wrinkles": 2},
    # the mouth muscles end at the mouth corner: a short reach and a narrow cone keep
    # their regions from running across the lips to the other side of the face
    "ZYGOMATICUS_MAJOR": {"lambda_w": 0.5, "n_wrinkles": 2, "angle": 20.0, "reach": 1.05},
    "RISORIUS": {"lambda_w": 0.5, "n_wrinkles": 2, "angle": 20.0, "reach": 1.05},
    "DEPRESSOR_ANGULI": {"lambda_w": 0.5, "n_wrinkles": 2, "reach": 1.1},
    "MENTALIS": {"lambda_w": 0.2, "n_wrinkles": 3, "angle": 40.0},
    # sphincters: ``reach`` is the outer extent in ring radii, ``angle`` the half-angle of the
    # wrinkling sector round the axis a.  The eye's: crow's feet from just beside the outer
    # corner (rho 0.7 of a ring 0.4 E wide) out to 1.45 rings, fanning over about 90 degrees
    "ORBICULARIS_OCULI": {"lambda_w": 0.48, "n_wrinkles": 6, "angle": 50.0, "angle_c": 35.0,
                          "reach": 1.45, "depth_factor": 0.8},
    # the mouth's: the vertical lines of the upper lip, between the red of the lip and the nose
    "ORBICULARIS_ORIS": {"lambda_w": 0.45, "n_wrinkles": 5, "angle": 45.0, "angle_c": 20.0,
                         "reach": 1.15, "depth_factor": 0.4},
    # the horizontal lines at the root of the nose: fine and shallow (a deep one reads as a tube)
    # one soft line across the root of the nose between two bulges (three read as a bellows)
    "PROCERUS": {"lambda_w": 0.5, "n_wrinkles": 2, "reach": 1.3, "depth_factor": 0.25},
}


# The Corrugator's frown line, out from the midline in eyes' distances E: at the inner end
# of the brow (0.18-0.22 E on the heads measured: ICT's own landmarks on its sample head and
# a variant of it, and the procedural head's brows); its fibres' droop below horizontal, so
# the two lines part slightly upward; and the Procerus' half width in E (the nose's root)
CORRUGATOR_LINE = 0.2
CORRUGATOR_DROOP = np.radians(8.0)
PROCERUS_HALF_WIDTH = 0.17


def _corrugator(g, ey, sign, e):
    """The Corrugator sheet's corners ``[m_A1, m_A2, m_I2, m_I1]`` (x, z) for the side
    ``sign``: its attachment line on the midline from 0.4 to 0.9 of the glabella's height
    over the eyes, below and above the glabella; its length ``Ls`` (``reach`` times the
    attachment-insertion distance, as ``glue.muscles.muscle_objects`` sizes a sheet) such that
    eq. 7's middle furrow of two (``n_w = 2``, ``lambda_w`` 0: at ``(1 + lambda_w) Ls / 2
    = Ls / 2``) lies ``CORRUGATOR_LINE`` E out; the fibres drooping by ``CORRUGATOR_DROOP``."""
    lam, reach = ROLE_PARAMS["CORRUGATOR"]["lambda_w"], ROLE_PARAMS["CORRUGATOR"]["reach"]
    ls = 2.0 * CORRUGATOR_LINE * e / (1.0 + lam)
    span = ls / reach
    top, bottom = g[1] + 0.7 * (g[1] - ey), g[1] - 0.6 * (g[1] - ey)
    dx, dz = sign * span * np.cos(CORRUGATOR_DROOP), -span * np.sin(CORRUGATOR_DROOP)
    return [(g[0], top), (g[0], bottom), (g[0] + dx, bottom + dz), (g[0] + dx, top + dz)]


FOREHEAD = ("FRONTALIS_INNER", "FRONTALIS_MAJOR", "FRONTALIS_OUTER")  # one phase, one convergence
CONVERGENCE = 0.61  # the Frontalis' line of convergence, as a fraction of the forehead's height
SHEET_LENGTH = 1.5  # a sheet's Ls over its attachment-insertion distance: the pull fades below the brows


def _forehead(lm):
    """The Frontalis sheets' insertion and attachment heights (z) from the (x, z) landmarks
    ``lm``: the insertion on the top of the brow's arch, the attachment on the line of
    convergence (see :func:`layout`)."""
    g, bo, hair = lm["glabella"], lm["brow_outer_L"], lm["hairline_center"]
    insert_z = g[1] + 0.5 * (bo[1] - g[1]) + 0.12 * abs(bo[0] - g[0])  # brow_z(0.5) in layout
    return insert_z, insert_z + CONVERGENCE * (hair[1] - insert_z)


def _front(landmarks):
    return {k: np.asarray(v, float)[[0, 2]] for k, v in landmarks.items()}


def sheet_reach(landmarks):
    """How far the Frontalis sheets reach behind their attachment line (up to the hairline),
    in the landmarks' units; ``build_muscle_set`` divides it by the sheets' length Ls."""
    lm = _front(landmarks)
    _insert_z, attach_z = _forehead(lm)
    return lm["hairline_center"][1] - attach_z


def layout(landmarks):
    """End points in the (x, z) plane for every muscle and side.

    Returns a list of ``(role, side, kind, points)`` where ``points`` is an
    (n, 2) array of (x, z): ``[m_A, m_I]`` for linear muscles and
    ``[m_A1, m_A2, m_I2, m_I1]`` for sheets.  Side ``'L'`` is +X.
    """
    lm = _front(landmarks)
    g, bo, eye = lm["glabella"], lm["brow_outer_L"], lm["eye_L"]
    nose, mouth, chin = lm["nose_tip"], lm["mouth_corner_L"], lm["chin"]
    cheek = lm["cheekbone_L"]
    bw = abs(bo[0] - g[0])  # half brow width
    sign = 1.0 if bo[0] >= g[0] else -1.0

    def x(f):
        return g[0] + sign * f * bw

    def brow_z(f):  # a gently arched brow line from the glabella to the outer brow
        return g[1] + (bo[1] - g[1]) * f + 0.12 * bw * np.sin(np.pi * min(f, 1.0))

    # Raised brows move the lower forehead up and the upper forehead down; the two meet on
    # a horizontal line at 61 % of the forehead's height above the brows (3D skin
    # displacement studies of the Frontalis).  The sheets' attachment line is that line of
    # convergence, and they reach behind it to the hairline (``sheet_reach``), so the skin
    # converges on it from both sides.  The three sheets of a side share one attachment
    # line, one insertion height and one length, so eq. 7 puts their furrows in phase and
    # a furrow runs across the whole forehead.  Their centres are D = bw/3 apart and each
    # is 1.5 D wide with h_c = D/4: the smoothstep ramps of neighbours (and of the two
    # inner sheets at the midline) coincide exactly, so their pulls add up to a uniform
    # lift and their furrows keep one depth across the borders.
    insert_z, attach_z = _forehead(lm)

    def sheet(i):
        c0, c1 = (i - 0.25) / 3.0, (i + 1.25) / 3.0
        return [(x(c0), attach_z), (x(c1), attach_z), (x(c1), insert_z), (x(c0), insert_z)]

    ey = eye[1]
    e = 2.0 * abs(eye[0] - g[0])  # the distance between the eyes
    mid = abs(mouth[0] - g[0])
    out = {
        "FRONTALIS_INNER": sheet(0),
        "FRONTALIS_MAJOR": sheet(1),
        "FRONTALIS_OUTER": sheet(2),
        # a sheet from the midline outward, its fibres a little below horizontal: it draws
        # the brows' heads together and down, so its frown line (one of "the elevens") runs
        # up and down at the inner end of the brow, the two parting slightly upward.  The
        # line sits mid-region (``CORRUGATOR_LINE`` E out, between a bulge each side), where
        # the skin between the brows bunches; the region's inner end is on the midline
        "CORRUGATOR": _corrugator(g, ey, sign, e),
        "NASALIS": [(x(0.30), nose[1] + 0.25 * (ey - nose[1])), (x(0.06), ey - 0.05 * (ey - nose[1]))],
        "ZYGOMATICUS_MINOR": [
            (cheek[0] - sign * 0.25 * bw, cheek[1] - 0.1 * (ey - nose[1])),
            (g[0] + sign * 0.75 * mid, mouth[1] + 0.45 * (nose[1] - mouth[1])),
        ],
        "ZYGOMATICUS_MAJOR": [(cheek[0] + sign * 0.15 * bw, cheek[1]), (mouth[0], mouth[1])],
        "RISORIUS": [(mouth[0] + sign * 1.1 * mid, mouth[1] + 0.1 * (nose[1] - mouth[1])),
                     (mouth[0], mouth[1])],
        "DEPRESSOR_ANGULI": [(mouth[0] + sign * 0.25 * mid, chin[1] + 0.1 * (mouth[1] - chin[1])),
                             (mouth[0], mouth[1])],
        "MENTALIS": [(g[0] + sign * 0.3 * mid, mouth[1] - 0.35 * (mouth[1] - chin[1])),
                     (g[0] + sign * 0.3 * mid, chin[1] + 0.05 * (mouth[1] - chin[1]))],
        # sphincters: [centre, end of the axis a (the wrinkling sector's middle), end of b].
        # The eye's ring is 0.4 E across sideways (E: the eyes' distance) and 0.33 E up, its
        # axis a toward the outer corner
        "ORBICULARIS_OCULI": [(eye[0], ey), (eye[0] + sign * 0.4 * e, ey), (eye[0], ey + 0.33 * e)],
        # the mouth's round the mouth line's middle, its axis a up to below the nose
        "ORBICULARIS_ORIS": [(g[0], mouth[1]), (g[0], mouth[1] + 0.8 * (nose[1] - mouth[1])),
                             (g[0] + sign * 1.2 * mid, mouth[1])],
        # the Procerus, a thin sheet from the nasal bone up into the skin between the brows: it
        # draws that skin straight down, so the lines at the root of the nose run straight
        # across it (a linear muscle's furrows are arcs round its attachment, and rang the
        # bridge); its sides fade over most of its width, so the bunching is soft
        "PROCERUS": [(g[0] - PROCERUS_HALF_WIDTH * e, ey - 0.6 * (g[1] - ey)),
                     (g[0] + PROCERUS_HALF_WIDTH * e, ey - 0.6 * (g[1] - ey)),
                     (g[0] + PROCERUS_HALF_WIDTH * e, ey + 0.5 * (g[1] - ey)),
                     (g[0] - PROCERUS_HALF_WIDTH * e, ey + 0.5 * (g[1] - ey))],
    }
    result = []
    for role, _name, kind in MUSCLES:
        pts = np.array(out[role], float)
        if role in MIDLINE:
            result.append((role, "C", kind, pts))
            continue
        result.append((role, "L", kind, pts))
        mirrored = pts.copy()
        mirrored[:, 0] = 2.0 * g[0] - mirrored[:, 0]
        if kind == "SHEET":  # keep the winding: swap the two ends of each line
            mirrored = mirrored[[1, 0, 3, 2]]
        result.append((role, "R", kind, mirrored))
    return result
