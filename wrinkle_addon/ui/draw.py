# SPDX-License-Identifier: GPL-3.0-or-later
"""Viewport drawing of each muscle's area of influence and wrinkling region.

The outlines come from ``core.muscles.outline`` (pure NumPy) in the muscle's face
space and are drawn with the ``gpu`` module in a POST_VIEW handler.  Nothing is
drawn in background mode.
"""

import bpy
import numpy as np

from ..core.muscles import outline
from ..glue.muscles import muscle_objects

_handle = None
_COLORS = {"aoi": (0.3, 0.7, 1.0, 0.8), "region": (1.0, 0.55, 0.1, 1.0)}


def _segments(context):
    """World-space line segments for every muscle with Show Region on."""
    out = {"aoi": [], "region": []}
    for ob in context.visible_objects:
        s = ob.ewrinkles_muscle
        if not (ob.type == "MESH" and s.is_muscle and s.show_region):
            continue
        face = ob.parent if ob.parent is not None and ob.parent.type == "MESH" else None
        frame = face.matrix_world if face is not None else None
        m = muscle_objects.to_core(ob, face) if face is not None else None
        if m is None or m.problem():
            continue
        mw = np.array(frame, dtype=np.float64)
        for kind, pts in outline.muscle_outline(m).items():
            if len(pts):
                out[kind].append(pts @ mw[:3, :3].T + mw[:3, 3])
    return {k: np.concatenate(v) if v else np.zeros((0, 3)) for k, v in out.items()}


def _draw():
    import gpu
    from gpu_extras.batch import batch_for_shader

    context = bpy.context
    try:
        segs = _segments(context)
    except (ReferenceError, AttributeError):
        return
    shader = gpu.shader.from_builtin("POLYLINE_UNIFORM_COLOR")
    region = context.region
    gpu.state.blend_set("ALPHA")
    for kind, pts in segs.items():
        if not len(pts):
            continue
        batch = batch_for_shader(shader, "LINES", {"pos": pts.astype(np.float32)})
        shader.bind()
        shader.uniform_float("viewportSize", (region.width, region.height))
        shader.uniform_float("lineWidth", 2.0 if kind == "region" else 1.0)
        shader.uniform_float("color", _COLORS[kind])
        batch.draw(shader)
    gpu.state.blend_set("NONE")


def register():
    global _handle
    if not bpy.app.background and _handle is None:
        _handle = bpy.types.SpaceView3D.draw_handler_add(_draw, (), "WINDOW", "POST_VIEW")


def unregister():
    global _handle
    if _handle is not None:
        bpy.types.SpaceView3D.draw_handler_remove(_handle, "WINDOW")
        _handle = None
