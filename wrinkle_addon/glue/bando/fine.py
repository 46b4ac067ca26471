# SPDX-License-Identifier: GPL-3.0-or-later
"""Fine-scale wrinkles on a face (Bando, Kuratate & Nishita 2002, §5 and §7): carving the
two height images, storing the direction fields with the mesh, and wiring the ``Fine
Wrinkles`` node group into the face's material.

What the file keeps, so the result survives saving and reopening with or without the
add-on: the two height images (packed), the two fields as corner attributes of the mesh
(``FIELD_ATTRS``), the artist's directions on vertices (``GUIDE_ATTR``), the plan of the
shrinkage across the fields and the *Fine Wrinkles* modifier that measures it every frame
(``fine_tree``), and the material's nodes.
"""

import bpy
import numpy as np

from ...core import raster, skin_age
from ...core.bando import field, fine, mapped, parts
from ...core.muscles import system
from .. import curve_objects, images, landmarks, meshio, nodes, pipeline, surface
from ..errors import WrinkleError
from ..muscles import muscle_objects
from . import curves, fine_tree, shading

GUIDE_ATTR = "ewrinkles_fine_guide"  # point vectors (face space): directions on vertices
FIELD_ATTRS = ("ewrinkles_fine_field1", "ewrinkles_fine_field2")  # corner 2-D (UV) vectors
GROUP_NODE = "Fine Wrinkles"
UV_NODE = "Fine Wrinkles UV"
IMAGE_NODES = ("Fine Wrinkles Height 1", "Fine Wrinkles Height 2")
MAX_OVERLAP = 0.05  # the UV layout may cover this fraction of itself twice (rasterisation noise)
SOURCE = "fine_wrinkles"
STEPS = 5  # directions, two carvings, storing, the material


class FineError(WrinkleError):
    """Bad input for the fine wrinkles; the message is meant for the user."""


def settings(face):
    return face.ewrinkles_face.fine_wrinkles


# --------------------------------------------------------------------------- the fields
def _muscle_poses(face, s):
    """The rest face pulled by each of its pulling muscles contracted alone (Waters' pull,
    no wrinkles)."""
    pulling = [m for m in muscle_objects.live_muscles(face) if not m.ewrinkles_muscle.wrinkles_only]
    if not pulling:
        return []
    core = [muscle_objects.to_core(m, face) for m in pulling]
    plan = system.build_plan(s.rest, s.edges, s.tris, core, keep_out=landmarks.keep_out(face, s.rest))
    rest = s.rest.astype(np.float32)
    poses = []
    for i in range(len(core)):  # a few dozen muscles
        contraction = np.zeros(len(core))
        contraction[i] = 1.0
        poses.append(rest + system.evaluate(plan, rest, contraction, 0.0))
    return poses


def _poses(face, s):
    """The face's deformations: each shape key at full value, each muscle contracted alone,
    and the current pose."""
    rest = s.rest
    poses = list(meshio.shape_keys(face.data, len(rest)).values()) + _muscle_poses(face, s)
    skin = surface.evaluated_skin(face, len(rest))
    if skin is not None:
        poses.append(skin)
    return [p for p in poses if np.abs(p - rest).max() > 1e-7]


def _strokes_uv(context, face, s, snapper):
    """The guide strokes as UV polylines: annotation strokes and selected curve objects
    (not wrinkle curves), snapped to the skin."""
    inv = np.array(face.matrix_world.inverted_safe(), np.float64)
    local = [pts @ inv[:3, :3].T + inv[:3, 3] for pts in curves.annotation_strokes(context.scene)]
    for ob in context.selected_objects:
        if ob.type == "CURVE" and not ob.ewrinkles_curve.is_curve:
            local.extend(curve_objects.face_space_samples(ob, face))
    out = []
    for pts in local:
        if len(pts) < 2:
            continue
        tri, bary, _dist, _loc = snapper.nearest(pts)
        if (tri < 0).any():
            continue
        out.append(np.einsum("kc,kcj->kj", bary, s.uv[tri]))
    return out


def _uv_per_metre(m, rest):
    """The typical UV length of one scene unit on the skin (median over the triangles)."""
    pos = m.positions(rest)
    e_uv = np.linalg.norm(m.uv[m.tris[:, 1]] - m.uv[m.tris[:, 0]], axis=1)
    e_3d = np.linalg.norm(pos[m.tris[:, 1]] - pos[m.tris[:, 0]], axis=1)
    ok = e_3d > 1e-12
    return float(np.median(e_uv[ok] / e_3d[ok])) if ok.any() else 1.0


def direction_field(context, face, s, m, step, held=None):
    """Field 1 (U, 2) on the mapped mesh ``m`` of the surface ``s``, from the settings'
    source; ``step(message)`` reports progress.  ``held`` = (vertices (K,), vectors (K, 2)):
    directions copied from another part (§5.4), kept as they are.  Raises FineError."""
    fs = settings(face)
    pos = m.positions(s.rest)
    if fs.field_source == "FACE":
        poses = _poses(face, s)
        if not poses:
            raise FineError(f'Nothing deforms "{face.name}": add shape keys, muscles or a pose (bones), '
                            "or give the directions yourself (Directions: From Guides)")
        step(f"Directions from {len(poses)} pose(s)")
        out = field.deformation_field(pos, [m.positions(p) for p in poses], m.uv, m.tris,
                                      fill_threshold=0.05, floor=fs.base_magnitude)
        if held is not None:
            out[held[0]] = held[1]
        return out
    fixed, vectors = ([held[0]], [held[1]]) if held is not None else ([], [])
    guide = face.data.attributes.get(GUIDE_ATTR)
    if guide is not None and guide.domain == "POINT" and guide.data_type == "FLOAT_VECTOR":
        g = meshio.read_vectors(face.data, GUIDE_ATTR).astype(np.float64)[m.vert_of]
        has = np.linalg.norm(g, axis=1) > 1e-9
        if has.any():
            uvd = fine.uv_directions(pos, m.uv, m.tris, np.where(has[:, None], g, 0.0))
            fixed.append(np.flatnonzero(has))
            vectors.append(np.clip(np.linalg.norm(g[has], axis=1), 0, 1)[:, None]
                           * uvd[has] / np.maximum(np.linalg.norm(uvd[has], axis=1), 1e-12)[:, None])
    snapper = surface.Snapper(s.rest, s.tris)
    strokes = _strokes_uv(context, face, s, snapper)
    if strokes:
        ref = fs.reference_length * _uv_per_metre(m, s.rest)
        f, v = field.stroke_constraints(m.uv, m.tris, strokes, ref)
        fixed.append(f)
        vectors.append(v)
    if not fixed or sum(len(f) for f in fixed) == 0:
        raise FineError(f'No guides on "{face.name}": draw annotation strokes on the face, select guide '
                        "curves, or Set Direction on selected vertices (or use Directions: From the Face)")
    fixed, vectors = np.concatenate(fixed), np.concatenate(vectors)
    fixed, first = np.unique(fixed, return_index=True)  # the copied directions come first
    step(f"Interpolating the directions from {len(fixed)} guide vertices")
    return field.direction_field(pos, m.uv, m.tris, fixed, vectors[first], tol=1e-6)


def _write_fields(face, s, m, fields):
    me = face.data
    for name, f in zip(FIELD_ATTRS, fields):
        att = me.attributes.get(name)
        if att is not None and (att.domain != "CORNER" or att.data_type != "FLOAT2"):
            me.attributes.remove(att)
            att = None
        if att is None:
            att = me.attributes.new(name, "FLOAT2", "CORNER")
        per_corner = np.zeros((len(me.loops), 2), np.float32)
        per_corner[s.corner_tris.ravel()] = f[m.tris.ravel()]
        att.data.foreach_set("vector", per_corner.ravel())


def read_fields(face, s, m):
    """The stored fields (2, U, 2) on the mapped mesh, or None if the face has none."""
    me = face.data
    out = []
    for name in FIELD_ATTRS:
        att = me.attributes.get(name)
        if att is None or att.domain != "CORNER" or att.data_type != "FLOAT2":
            return None
        per_corner = np.empty(len(me.loops) * 2, np.float32)
        att.data.foreach_get("vector", per_corner)
        f = np.zeros((len(m.uv), 2))
        f[m.tris.ravel()] = per_corner.reshape(-1, 2)[s.corner_tris.ravel()]
        out.append(f)
    return np.stack(out)


def set_guides(face, verts, vector):
    """Set the guide direction ``vector`` (face space; its length is the magnitude m, at
    most 1) on vertices ``verts``, projected onto the skin's tangent plane."""
    me = face.data
    att = meshio.point_attribute(me, GUIDE_ATTR, "FLOAT_VECTOR")
    g = np.zeros((len(me.vertices), 3), np.float32)
    att.data.foreach_get("vector", g.ravel())
    normals = np.empty(len(me.vertices) * 3, np.float32)
    me.vertices.foreach_get("normal", normals)
    n = normals.reshape(-1, 3)[verts]
    v = np.asarray(vector, np.float32)[None, :] - np.einsum("ij,j->i", n, vector)[:, None] * n
    length = np.linalg.norm(v, axis=1, keepdims=True)
    g[verts] = v / np.maximum(length, 1e-12) * min(float(np.linalg.norm(vector)), 1.0)
    att.data.foreach_set("vector", g.ravel())


# --------------------------------------------------------------------------- several parts
def _per_vertex(m, tris, corner_values):
    """Values at the corners of the mapped triangles ``tris`` (S,) as (vertices (K,),
    values (K, 2)): averaged over the corners of each mapped vertex."""
    v = m.tris[tris].ravel()
    flat = corner_values.reshape(-1, 2)
    verts, inverse = np.unique(v, return_inverse=True)
    count = np.bincount(inverse, minlength=len(verts))
    out = np.stack([np.bincount(inverse, weights=flat[:, k], minlength=len(verts)) for k in range(2)], 1)
    return verts, out / count[:, None]


def continued(face, s, m, resolution):
    """What a part carved on from another (``continue_from``, Bando 2002 §5.4) starts with:
    ``(held1, held2, initial)`` - both fields' directions on the shared vertices of the
    mapped mesh ``m`` and both images' initial states - or None without one.  The two
    parts share the faces whose corners lie at the same places in the scene.  Raises
    FineError."""
    other = settings(face).continue_from
    if other is None:
        return None
    os_ = settings(other)
    if other.type != "MESH" or os_.image_1 is None or os_.image_2 is None:
        raise FineError(f'"{other.name}" has no fine wrinkles to continue from: carve it first')
    so = surface.Surface(other, os_.uv_map or None)
    mo = mapped.mapped_mesh(so.tris, so.uv, len(so.rest))
    fields = read_fields(other, so, mo)
    if fields is None:
        raise FineError(f'"{other.name}" has lost its direction fields: carve it again')

    def world(ob, rest):
        mw = np.array(ob.matrix_world, np.float64)
        return rest @ mw[:3, :3].T + mw[:3, 3]

    pa, pb = world(other, so.rest), world(face, s.rest)
    size = float(max(np.ptp(pa, axis=0).max(), np.ptp(pb, axis=0).max(), 1e-9))
    ta, tb, corner = parts.shared_portion(pa, so.tris, pb, s.tris, 1e-5 * size)
    if len(ta) == 0:
        raise FineError(f'"{face.name}" and "{other.name}" share no faces: the two parts must both have '
                        "the faces of a band along their border, at the same place in the scene")
    rows = np.arange(len(ta))[:, None]
    src_uv, dst_uv = so.uv[ta][rows, corner], s.uv[tb]
    held = [_per_vertex(m, tb, parts.copy_field(src_uv, dst_uv, f[mo.tris[ta]][rows, corner]))
            for f in fields]
    states = []
    for image in (os_.image_1, os_.image_2):
        try:
            height = images.read(image)[:, :, 0]
        except images.ImageError as exc:
            raise FineError(f'The fine wrinkles of "{other.name}" cannot be read: {exc}') from None
        states.append(parts.copy_heights(height, src_uv, dst_uv, resolution))
    return held[0], held[1], tuple(states)


# --------------------------------------------------------------------------- carving
def check_resolution(resolution):
    if not 1 <= int(resolution) <= 8192:
        raise FineError(f"An image size of {resolution} pixels is not possible: use 1 to 8192")


def carve(context, face, progress):
    """Carve the fine wrinkles of ``face`` with its settings: the field, both height images,
    the stored fields and the material.  Everything is computed before anything is
    changed, so bad input changes nothing.  ``progress``: a ``glue.progress.Progress`` of
    ``STEPS`` steps.  Raises FineError (or another WrinkleError)."""
    fs = settings(face)
    done = [0]

    def step(message):
        done[0] += 1
        progress(min(done[0], STEPS), message)

    check_resolution(fs.resolution)
    s = surface.Surface(face, fs.uv_map or None)
    why = surface.layout_problem(face, s)
    if why:
        raise FineError(why)
    overlap = raster.uv_overlap(s.uv)
    if overlap > MAX_OVERLAP:
        raise FineError(f'The UV map "{s.uv_name}" of "{face.name}" has overlapping islands '
                        f"({overlap:.0%} of the layout is covered twice, as mirrored UVs are): fine "
                        "wrinkles need one place in the images per point of the skin. Unwrap without "
                        "overlaps, or pick another UV map")
    m = mapped.mapped_mesh(s.tris, s.uv, len(s.rest))
    R = int(fs.resolution)
    before = continued(face, s, m, R)
    held1, held2, initial = before if before is not None else (None, None, (None, None))
    field1 = direction_field(context, face, s, m, step, held1)
    keep = landmarks.keep_out(face, s.rest)  # with the landmarks placed: no furrow on lids and lips
    if keep is not None:
        field1 = field1 * keep[m.vert_of][:, None]
    results, field2 = fine.carve_pair(
        m.uv, m.tris, field1, fs.angle, R, fs.seed,
        progress=lambda i: step(f"Carving the furrows of field {i + 1}"), held2=held2, initial=initial)
    step("Storing the images")
    imgs = []
    for k, res in enumerate(results):
        h = np.repeat(res.height[:, :, None], 3, axis=2)
        imgs.append(images.store(f"{face.name} Fine Wrinkles {k + 1}", h, float_buffer=True,
                                 image=getattr(fs, f"image_{k + 1}")))
    _write_fields(face, s, m, (field1, field2))
    fs.image_1, fs.image_2 = imgs
    fs.uv_map = s.uv_name
    fs.furrows = int(sum(r.furrows for r in results))
    fs.coverage = float(results[0].coverage)
    step("Wiring the material")
    setup_material(face)
    store_plan(face, s, m, read_fields(face, s, m))  # as stored: what the frame stage plans from
    fine_tree.ensure_modifier(face)
    pipeline.forget(face, SOURCE)
    return results


# --------------------------------------------------------------------------- the modifier's plan
def store_plan(face, s, m, fields):
    """Plan the shrinkage of both ``fields`` on the face's surface ``s`` and mapped mesh ``m``
    and store it for the *Fine Wrinkles* modifier (only if the mesh holds another).  Returns
    the plan (``core.bando.fine.plan``)."""
    plan = fine.plan(m, s.rest, fields[0], fields[1])
    fine_tree.write_slots(face.data, fine.vertex_slots(plan))
    return plan


# Before the modifier (version 0.x of this file's layout): the frame stage wrote the shrinkage
# as these point attributes every frame, and Bake for Farm an OpenEXR image sequence that
# the material read through this node.
LEGACY_ATTRS = ("ewrinkles_fine_s1", "ewrinkles_fine_s2")
LEGACY_BAKE_NODE = "Fine Wrinkles Baked Shrinkage"


def upgrade(face):
    """A face carved before the *Fine Wrinkles* modifier existed gets it, with its plan; the
    shader group is brought up to date in place (its links stay), the image sequence's node
    of a farm bake goes (the files on disk are kept), and the per-frame attributes too.
    Returns a line for the console, or "" when there was nothing to do."""
    fs = settings(face)
    if fs.image_1 is None:
        return ""
    if fine_tree.find_modifier(face) is not None:
        return fine_tree.upgrade_group(face)
    shading.ensure_fine_group()
    said = "its fine wrinkles' shrinkage is computed by a new Fine Wrinkles modifier"
    nt, _group = _group_node(face)
    tex = nt.nodes.get(LEGACY_BAKE_NODE) if nt is not None else None
    if tex is not None:
        image = tex.image
        nt.nodes.remove(tex)
        if image is not None and image.users == 0:
            bpy.data.images.remove(image)
        said += "; the image sequence of its farm bake is no longer needed (its files are kept)"
    s = surface.Surface(face, fs.uv_map or None)
    m = mapped.mapped_mesh(s.tris, s.uv, len(s.rest))
    fields = read_fields(face, s, m)
    if fields is None:
        return "its fine wrinkles' direction fields are missing: carve them again"
    store_plan(face, s, m, fields)
    fine_tree.ensure_modifier(face)
    me = face.data
    for name in LEGACY_ATTRS:
        att = me.attributes.get(name)
        if att is not None:
            me.attributes.remove(att)
    return said


def _group_node(face):
    mat = settings(face).material
    nt = mat.node_tree if mat is not None else None
    return (nt, nt.nodes.get(GROUP_NODE)) if nt is not None else (None, None)


# --------------------------------------------------------------------------- the material
def _material(face):
    fs = settings(face)
    mat = fs.material or face.active_material
    if mat is None:
        mat = bpy.data.materials.new(f"{face.name} Skin")
        face.data.materials.append(mat)
    if mat.library is not None:
        raise FineError(f'The material "{mat.name}" is linked and read-only: make it local')
    nodes.use_nodes(mat)
    if nodes.principled(mat.node_tree) is None:
        raise FineError(f'The material "{mat.name}" has no Principled BSDF for the fine wrinkles to bump')
    return mat


def setup_material(face):
    """Wire the ``Fine Wrinkles`` group into the face's material, on top of its normal chain
    (the wrinkle maps' normal, or a normal map of the artist's, stays underneath)."""
    fs = settings(face)
    mat = _material(face)
    nt = mat.node_tree
    bsdf = nodes.principled(nt)
    group = shading.ensure_fine_group()
    x, y = bsdf.location.x, bsdf.location.y
    node = nt.nodes.get(GROUP_NODE)
    fresh = node is None
    node = nodes.ensure_node(nt, GROUP_NODE, "ShaderNodeGroup", (x - 250, y - 650))
    node.node_tree = group
    shading.tag_layer(node)
    if fresh or not node.outputs["Normal"].links:
        target = nodes.normal_input(nt, bsdf)
        below = target.links[0].from_socket if target.links else None
        if below is not None and below.node != node:
            nt.links.new(below, node.inputs["Normal"])
        nt.links.new(node.outputs["Normal"], target)
    uv = nodes.ensure_node(nt, UV_NODE, "ShaderNodeUVMap", (x - 900, y - 650))
    uv.uv_map = fs.uv_map
    for k, name in enumerate(IMAGE_NODES):
        tex = nodes.ensure_node(nt, name, "ShaderNodeTexImage", (x - 650, y - 550 - 280 * k))
        tex.image = getattr(fs, f"image_{k + 1}")
        tex.interpolation = "Cubic"  # a smooth bump from the carved pixels
        nt.links.new(uv.outputs["UV"], tex.inputs["Vector"])
        nt.links.new(tex.outputs["Color"], node.inputs[f"Height {k + 1}"])
    fs.material = mat
    sync(face)
    return mat


def sync(face):
    """The group node's inputs from the face's settings: its Depth and Rest Height as the
    face's Skin Age makes them (``core.skin_age``), so a farm renders them with no add-on."""
    fs = settings(face)
    mat = fs.material
    node = mat.node_tree.nodes.get(GROUP_NODE) if mat is not None and mat.node_tree else None
    if node is None:
        return
    age = face.ewrinkles_face.skin_age
    node.inputs["Strength"].default_value = fs.strength
    node.inputs["Distance"].default_value = fs.distance * skin_age.depth_factor(age)
    node.inputs["Rest Height"].default_value = skin_age.rest_height(fs.rest_height, age)


def remove(face):
    """Take the fine wrinkles out of the material (the layer below goes back to the BSDF)
    and forget the images, the fields and the modifier."""
    fs = settings(face)
    mat = fs.material
    if mat is not None and mat.node_tree is not None:
        nt = mat.node_tree
        node = nt.nodes.get(GROUP_NODE)
        if node is not None:
            below = node.inputs["Normal"].links[0].from_socket if node.inputs["Normal"].links else None
            above = [lk.to_socket for lk in node.outputs["Normal"].links]
            for name in (GROUP_NODE, UV_NODE) + IMAGE_NODES:
                n = nt.nodes.get(name)
                if n is not None:
                    nt.nodes.remove(n)
            if below is not None:
                for sock in above:
                    nt.links.new(below, sock)
    me = face.data
    for name in FIELD_ATTRS:
        att = me.attributes.get(name)
        if att is not None:
            me.attributes.remove(att)
    fine_tree.remove(face)
    fs.image_1 = fs.image_2 = fs.material = None
    fs.furrows = 0
    fs.coverage = 0.0
    pipeline.forget(face, SOURCE)
