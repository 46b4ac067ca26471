# SPDX-License-Identifier: GPL-3.0-or-later
"""Bulk reads and writes between Blender meshes and contiguous float32/int32 arrays.

Uses the attribute fast paths measured for this project (docs/architecture.md): ``attributes[...]
.data.foreach_get/set`` on contiguous float32 is ~50x faster than
``vertices.foreach_get('co')``.
"""

import numpy as np


def _attr(me, name):
    return me.attributes.get(name)


def read_vectors(me, name, out=None):
    """A (N, 3) float32 copy of a point vector attribute (``position`` included)."""
    n = len(me.vertices)
    if out is None or out.shape != (n, 3):
        out = np.empty((n, 3), dtype=np.float32)
    _attr(me, name).data.foreach_get("vector", out.reshape(-1))
    return out


def read_vector_prefix(me, name, n, out):
    """The first ``n`` values of a point vector attribute into ``out`` (n, 3).

    Subdivision Surface keeps the original vertices first and copies their
    attribute values exactly (measured on bpy 4.5 and 5.2), so the skin of the
    original vertices can be read after it.
    """
    if len(me.vertices) == n:
        return read_vectors(me, name, out)
    full = read_vectors(me, name)
    out[:] = full[:n]
    return out


def write_vectors(me, name, values):
    _attr(me, name).data.foreach_set("vector", np.ascontiguousarray(values, dtype=np.float32).reshape(-1))


def attribute(me, name, data_type):
    """The point attribute ``name`` if it has the type ``data_type``, else None.  A file, a
    script or another add-on may have left anything under one of our names (a float on the
    faces, say): every read of our attributes checks it first."""
    att = me.attributes.get(name)
    if att is None or att.data_type != data_type or att.domain != "POINT":
        return None
    return att


def point_attribute(me, name, data_type):
    """The point attribute ``name`` of type ``data_type`` ("FLOAT", "FLOAT_VECTOR"), created,
    or replacing an attribute of that name with another type or domain."""
    att = attribute(me, name, data_type)
    if att is None:
        wrong = me.attributes.get(name)
        if wrong is not None:
            me.attributes.remove(wrong)
        att = me.attributes.new(name, data_type, "POINT")
    return att


def write_floats(me, name, values):
    """Write a point float attribute, creating it if needed."""
    att = point_attribute(me, name, "FLOAT")
    att.data.foreach_set("value", np.ascontiguousarray(values, dtype=np.float32).reshape(-1))


def read_edges(me):
    edges = np.empty(len(me.edges) * 2, dtype=np.int32)
    att = _attr(me, ".edge_verts")
    if att is not None:
        att.data.foreach_get("value", edges)
    else:  # pragma: no cover - older layouts
        me.edges.foreach_get("vertices", edges)
    return edges.reshape(-1, 2)


def read_polygons(me):
    """``(corner_verts, face_starts, face_sizes)`` as int32/int64 arrays."""
    corner = np.empty(len(me.loops), dtype=np.int32)
    att = _attr(me, ".corner_vert")
    if att is not None:
        att.data.foreach_get("value", corner)
    else:  # pragma: no cover
        me.loops.foreach_get("vertex_index", corner)
    starts = np.empty(len(me.polygons), dtype=np.int32)
    sizes = np.empty(len(me.polygons), dtype=np.int32)
    me.polygons.foreach_get("loop_start", starts)
    me.polygons.foreach_get("loop_total", sizes)
    return corner, starts, sizes


def topology_key(me):
    """Counts that change with any topology edit (cheap, checked every frame)."""
    return (len(me.vertices), len(me.edges), len(me.loops), len(me.polygons))


def shape_keys(me, n):
    """``{name: (n, 3) float32}`` of the mesh's shape keys other than the reference key
    (their ``points``: the fast path)."""
    keys = me.shape_keys
    if keys is None:
        return {}
    out = {}
    for kb in keys.key_blocks:  # a few dozen keys
        if kb == keys.reference_key:
            continue
        co = np.empty(n * 3, np.float32)
        kb.points.foreach_get("co", co)
        out[kb.name] = co.reshape(n, 3)
    return out


def vertex_group_weights(me, groups):
    """The weights of the vertex groups with the indices ``groups`` (a set): ``(vert, group,
    weight)`` arrays, one entry per vertex in one of them.  Vertex group weights have no bulk
    accessor: one pass over the vertices (at build or bake time only)."""
    pairs = [(v.index, g.group, g.weight) for v in me.vertices for g in v.groups if g.group in groups]
    arr = np.array(pairs, np.float64).reshape(-1, 3)
    return arr[:, 0].astype(np.int64), arr[:, 1].astype(np.int64), arr[:, 2]
