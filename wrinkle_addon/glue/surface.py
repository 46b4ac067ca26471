# SPDX-License-Identifier: GPL-3.0-or-later
"""The face's rest surface as arrays, with its UVs: what every method that works in UV space
(the wrinkle-map bakes, the wrinkle curves, the fine wrinkles) reads from the mesh."""

import zlib

import bpy
import numpy as np
from mathutils.bvhtree import BVHTree

from ..core import mesh
from ..core.bando import mapped
from . import faces, meshio, stage
from .errors import WrinkleError


class SurfaceError(WrinkleError):
    """The face's mesh or UV map cannot be used; the message is meant for the user."""


def uv_layer(face, uv_map=None):
    """The UV map named ``uv_map``; empty or None: the face's wrinkle-map UV map if set,
    else the active render UV map.  Raises SurfaceError."""
    me = face.data
    if len(me.uv_layers) == 0:
        raise SurfaceError(f'"{face.name}" has no UV map: unwrap it first (UV > Unwrap)')
    name = uv_map or ""
    if not name:
        maps = getattr(face.ewrinkles_face, "maps", None)
        name = getattr(maps, "uv_map", "") or ""
    if name:
        layer = me.uv_layers.get(name)
        if layer is None:
            names = ", ".join(f'"{lay.name}"' for lay in me.uv_layers)
            raise SurfaceError(f'"{face.name}" has no UV map named "{name}" (it has {names})')
        return layer
    for layer in me.uv_layers:
        if layer.active_render:
            return layer
    return me.uv_layers[0]


class Surface:
    """The face's rest mesh as arrays: ``rest`` (N, 3), ``edges``, the fan triangles
    ``tris`` (T, 3) of vertices and ``corner_tris`` (T, 3) of corners, and with
    ``need_uv`` the UVs ``uv`` (T, 3, 2) of those corners.  Raises SurfaceError."""

    def __init__(self, face, uv_map=None, need_uv=True):
        why = faces.problem(face, local=False, object_mode=True)
        if why:
            raise SurfaceError(why)
        me = face.data
        self.rest = meshio.read_vectors(me, "position")
        self.edges = meshio.read_edges(me)
        corner_vert, starts, sizes = meshio.read_polygons(me)
        # (T, 3) corner indices: the UVs are per corner
        self.corner_tris = mesh.fan_triangles(np.arange(len(corner_vert)), starts, sizes)
        self.tris = corner_vert[self.corner_tris]  # (T, 3) vertices
        if len(self.tris) == 0:
            raise SurfaceError(f'"{face.name}" has no faces with 3 or more corners')
        self.uv = None
        if need_uv:
            layer = uv_layer(face, uv_map)
            self.uv_name = layer.name
            corner_uv = np.empty(len(corner_vert) * 2, np.float32)
            layer.uv.foreach_get("vector", corner_uv)
            self.uv = corner_uv.reshape(-1, 2)[self.corner_tris]  # (T, 3, 2)
            inside = np.all((self.uv >= 0.0) & (self.uv <= 1.0), axis=(1, 2))
            if not inside.any():
                raise SurfaceError(f'The UV map "{layer.name}" of "{face.name}" has no face inside the '
                                   "0-1 UV square: the maps cover only that square")


MAX_DEGENERATE = 0.05  # the UV map may leave this fraction of its triangles without area


def layout_problem(face, s):
    """Why the UV layout of the :class:`Surface` ``s`` of ``face`` cannot carry the UV-space
    wrinkles (the fine wrinkles, the wrinkle curves), or "": a collapsed UV map, too many
    triangles without area in UV, or bow-tie vertices (``core.bando.mapped``).  On each,
    the shrinkage across a wrinkle (Bando 2002, eq. 4) has no direction to be measured in."""
    bad = mapped.degenerate_uv(s.uv)
    where = f'The UV map "{s.uv_name}" of "{face.name}"'
    if bad.all():
        return (f"{where} is collapsed: none of its faces has an area in UV (a new UV map is like "
                "that until it is unwrapped). Unwrap it (UV > Unwrap), or pick another UV map")
    if bad.mean() > MAX_DEGENERATE:
        return (f"{where} has {int(bad.sum())} of its {len(bad)} triangles without area in UV (their "
                "corners lie at one point or on a line), so no wrinkle can be placed there. Unwrap "
                "those faces again")
    bow = mapped.bowtie_vertices(s.tris, len(s.rest))
    if len(bow):
        return (f'"{face.name}" has {len(bow)} bow-tie vertices (vertex {bow[0]} is one), where faces '
                "meet at a corner without sharing an edge: the skin has no single surface there. "
                "Select them (Select > Select All by Trait > Non Manifold, Vertices) and pull the "
                "faces apart (Vertex > Rip Vertices) or join them with a face")
    return ""


def uv_key(face, uv_map=None):
    """The UV map that ``Surface(face, uv_map)`` reads, by name and content: a CRC-32 of its
    float32 coordinates, so a static key changes when the UVs are edited, not only when a
    map is renamed or picked.  0.5 ms at 50k vertices (200k corners; measured, bpy 4.5 and
    5.2: 0.1-0.2 ms the read, 0.4 ms the CRC).  The message instead when there is no such
    map."""
    try:
        layer = uv_layer(face, uv_map)
    except SurfaceError as exc:
        return str(exc)
    buf = np.empty(len(face.data.loops) * 2, np.float32)
    layer.uv.foreach_get("vector", buf)
    return layer.name, zlib.crc32(buf)


def evaluated_skin(face, n, depsgraph=None):
    """The deformed skin before wrinkles (n, 3) float32: ``wrinkle_skin`` of the evaluated
    mesh when the Wrinkles stage exists, else the evaluated positions (the first ``n``
    vertices), from ``depsgraph`` (default: the context's).  None when the modifiers
    leave fewer than ``n`` vertices."""
    dg = depsgraph or bpy.context.evaluated_depsgraph_get()
    ev = face.evaluated_get(dg).data
    staged = stage.find_modifier(face) is not None and meshio.attribute(ev, stage.SKIN_ATTR, "FLOAT_VECTOR")
    name = stage.SKIN_ATTR if staged else "position"
    if len(ev.vertices) < n:
        return None
    return meshio.read_vector_prefix(ev, name, n, np.empty((n, 3), np.float32))


def triangles(me):
    """The mesh's positions (N, 3) float64 and its fan triangles (T, 3): what a
    :class:`Snapper` is built on."""
    corner_vert, starts, sizes = meshio.read_polygons(me)
    return (meshio.read_vectors(me, "position").astype(np.float64),
            mesh.fan_triangles(corner_vert, starts, sizes))


class Snapper:
    """Closest points on a face's rest surface: ``(T, 3)`` triangles of ``rest``."""

    def __init__(self, rest, tris):
        self.rest = np.asarray(rest, np.float64)
        self.tris = np.asarray(tris, np.int64)
        self.bvh = BVHTree.FromPolygons(self.rest.tolist(), self.tris.tolist(), all_triangles=True)

    def nearest(self, points):
        """For (k, 3) points: the triangle index (k,), the barycentric coordinates (k, 3)
        of the closest surface point, the distance (k,) and the point itself (k, 3).  -1
        where none was found."""
        points = np.asarray(points, np.float64)
        tri = np.full(len(points), -1, np.int64)
        loc = np.zeros_like(points)
        dist = np.full(len(points), np.inf)
        for i, co in enumerate(points):  # one query per curve sample (not per vertex)
            hit = self.bvh.find_nearest(co)
            if hit[0] is not None:
                loc[i], tri[i], dist[i] = hit[0], hit[2], hit[3]
        ok = tri >= 0
        bary = np.zeros((len(points), 3))
        if ok.any():
            a, b, c = (self.rest[self.tris[tri[ok], k]] for k in range(3))
            bary[ok] = _barycentric(loc[ok], a, b, c)
        return tri, bary, dist, loc


def _barycentric(p, a, b, c):
    v0, v1, v2 = b - a, c - a, p - a
    d00 = np.einsum("ij,ij->i", v0, v0)
    d01 = np.einsum("ij,ij->i", v0, v1)
    d11 = np.einsum("ij,ij->i", v1, v1)
    d20 = np.einsum("ij,ij->i", v2, v0)
    d21 = np.einsum("ij,ij->i", v2, v1)
    den = d00 * d11 - d01 * d01
    den = np.where(np.abs(den) > 1e-30, den, 1.0)
    v = (d11 * d20 - d01 * d21) / den
    w = (d00 * d21 - d01 * d20) / den
    return np.clip(np.stack([1.0 - v - w, v, w], 1), 0.0, 1.0)
