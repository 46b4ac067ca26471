# SPDX-License-Identifier: GPL-3.0-or-later
"""Drawing helpers the panels share."""

from ..glue import faces


def panel_face(context):
    """The face the panels show: the active mesh, or the face of the active muscle."""
    ob = faces.active(context)
    if ob is None or ob.type != "MESH" or ob.ewrinkles_muscle.is_muscle:
        return None
    return ob


def status_box(layout, msg):
    """A problem message in a box: an error icon on the first line, wrapped to the panel."""
    if msg:
        box = layout.box()
        for i, line in enumerate(wrap(msg, 48)):
            box.label(text=line, icon="ERROR" if i == 0 else "BLANK1")


def wrap(text, width):
    words, lines, cur = text.split(), [], ""
    for w in words:
        if len(cur) + len(w) + 1 > width and cur:
            lines.append(cur)
            cur = w
        else:
            cur = f"{cur} {w}".strip()
    return lines + [cur] if cur else lines
