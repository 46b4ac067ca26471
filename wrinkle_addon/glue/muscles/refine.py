# SPDX-License-Identifier: GPL-3.0-or-later
"""Adaptive refinement of the wrinkling regions (Zhang 2005 §3, Fig. 11).

Zhang refines where the wrinkles need resolution.  Here the criterion is the
one the wrinkle model sets: every half cycle ``u`` (eq. 6) must span at least
``factor`` edge lengths.  The edges that violate it are chosen in NumPy
(``core.muscles.system.refine_edges``); bmesh splits the faces around them, which
interpolates UVs, shape keys, vertex groups and every other attribute, and
keeps material indices.
"""

from dataclasses import dataclass

import bmesh
import numpy as np

from ...core.muscles import system
from .. import meshio
from . import objects as muscle_objects

MAX_PASSES = 6


@dataclass
class Result:
    passes: int
    message: str = ""


def refine(face, muscles, factor=4.0, max_vertices=1_000_000, progress=None):
    me = face.data
    for i in range(MAX_PASSES):
        if progress:
            progress(i)
        rest = meshio.read_vectors(me, "position")
        edges = meshio.read_edges(me)
        core_muscles = [muscle_objects.to_core(m, face) for m in muscles]
        split = system.refine_edges(rest, edges, core_muscles, factor)
        if len(split) == 0:
            return Result(i)
        # whole faces around the offending edges, so interior faces split into clean quads
        corner, starts, sizes = meshio.read_polygons(me)
        bad_vert = np.zeros(len(rest), bool)
        bad_vert[edges[split].ravel()] = True
        face_of_corner = np.repeat(np.arange(len(sizes)), sizes)
        bad_face = np.zeros(len(sizes), bool)
        bad_face[face_of_corner[bad_vert[corner]]] = True
        grow = int(bad_face.sum()) * 5
        if len(rest) + grow > max_vertices:
            return Result(i, f"Stopped: refining further would exceed {max_vertices} vertices")
        bm = bmesh.new()
        try:
            bm.from_mesh(me)
            bm.faces.ensure_lookup_table()
            chosen = {e for f in np.flatnonzero(bad_face) for e in bm.faces[int(f)].edges}
            bmesh.ops.subdivide_edges(bm, edges=list(chosen), cuts=1, use_grid_fill=True)
            bm.to_mesh(me)
        finally:
            bm.free()
        me.update()
    return Result(MAX_PASSES, "Stopped after the maximum number of passes")
