# SPDX-License-Identifier: GPL-3.0-or-later
"""Scene construction for the benchmarks: an animated head rigged like a real face.

* The head comes from ``sample_scenes/lib/headgen.py`` (falls back to a
  subdivided sphere facing -Y, landmarks by proportion, if it cannot be used).
* A "BrowsUp" shape key raises the brows and compresses the forehead
  vertically (the brows move up ~6 mm, the hairline does not move).
* An armature with a "Jaw" bone, weighted to the lower face by distance from
  the chin, opens the jaw.
* ``add_arkit_keys`` (``--rig arkit``): a production-like face with 52 shape
  keys (the ARKit blendshape count): "BrowsUp" plus 51 regional keys, each a
  smooth Gaussian bump of 2-5 mm over a different region of the face front,
  all animated with smooth curves that never reach 0 (Blender skips keys whose
  value is 0, so every frame blends all 52).
* ``build_tension_group`` is the native Geometry Nodes edge-length-ratio setup
  users build today to drive wrinkle maps.
* ``build_displace_group`` is what users build today for geometric wrinkles
  from that tension: the same tension, then Set Position moving every point
  along its normal by ``height * max(0, 1 - tension)``, the height sampled from
  a 1024^2 float image at the point's UV (``make_height_image``), or a constant.
* ``ensure_uv_map`` gives the head a UV map when it has none (headgen's head
  has one, "UVMap"; the sphere fallback gets a cylindrical projection).

Frame layout (the same for every benchmark): BrowsUp 0 -> 1 -> 0 -> 1 at
frames 1, 21, 41, 61 (0.05 instead of 0 in the arkit rig); the jaw 0 -> 15
deg -> 0 -> 15 deg at 1, 16, 31, 46; the arkit regional keys keyed every 10
frames from 1 to 61 on 0.55 + 0.45 sin(2 pi (f - 1) / P + phase), a different
period P (30-50 frames) and phase per key.
"""

import math
import sys
from pathlib import Path

import bpy
import numpy as np

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

REST_ATTR = "rest_position"
TENSION_ATTR = "tension"
TENSION_GROUP = "Bench Edge Tension"


def _smoothstep(e0, e1, x):
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


# ---------------------------------------------------------------------------
# Head geometry
# ---------------------------------------------------------------------------
def _sphere_head(target_verts):
    """Fallback: a lat-long sphere of radius 0.1 centred at z = 0.1, face toward -Y."""
    rows = max(8, int(round(math.sqrt(target_verts / 2.0))))
    cols = 2 * rows
    el = np.linspace(-0.5 * np.pi, 0.5 * np.pi, rows + 2)[1:-1]
    az = np.linspace(0.0, 2.0 * np.pi, cols, endpoint=False)
    E, A = np.meshgrid(el, az, indexing="ij")
    pos = np.stack([np.cos(E) * np.sin(A), -np.cos(E) * np.cos(A), np.sin(E)], -1).reshape(-1, 3)
    pos = (0.1 * pos + [0.0, 0.0, 0.1]).astype(np.float32)
    idx = np.arange(rows * cols).reshape(rows, cols)
    nxt = np.roll(idx, -1, axis=1)
    quads = np.stack([idx[:-1], nxt[:-1], nxt[1:], idx[1:]], -1).reshape(-1, 4).astype(np.int32)

    def front(x, z):
        y = -math.sqrt(max(0.1 ** 2 - x * x - (z - 0.1) ** 2, 0.0))
        return np.array([x, y, z], np.float32)

    lm = {
        "hairline_center": front(0.0, 0.175), "glabella": front(0.0, 0.13),
        "brow_outer_L": front(0.045, 0.132), "eye_L": front(0.032, 0.117),
        "nose_tip": front(0.0, 0.08), "mouth_corner_L": front(0.026, 0.048),
        "chin": front(0.0, 0.02), "cheekbone_L": front(0.05, 0.098),
    }
    return {"positions": pos, "quads": quads, "corner_uvs": None, "landmarks": lm}


def make_head_data(target_verts):
    """(head dict, source string)."""
    try:
        from sample_scenes.lib import headgen

        return headgen.make_head(target_verts), "headgen"
    except Exception as exc:  # noqa: BLE001 - benchmark fallback, reported
        print(f"  headgen unavailable ({exc!r}); using a sphere head", flush=True)
        return _sphere_head(target_verts), "sphere"


def make_face_object(name, head):
    try:
        from sample_scenes.lib import scene_setup

        return scene_setup.mesh_object_from_arrays(name, head["positions"], head["quads"],
                                                   head["corner_uvs"])
    except Exception as exc:  # noqa: BLE001
        print(f"  scene_setup unavailable ({exc!r}); building the mesh directly", flush=True)
        pos, quads = head["positions"], head["quads"]
        me = bpy.data.meshes.new(name)
        me.from_pydata(pos.tolist(), [], quads.tolist())
        ob = bpy.data.objects.new(name, me)
        bpy.context.scene.collection.objects.link(ob)
        return ob


# ---------------------------------------------------------------------------
# Rig: shape key + jaw bone
# ---------------------------------------------------------------------------
def add_brows_up(ob, lm, amount=0.006, low=0.0):
    """Shape key "BrowsUp": brows up by ``amount``, forehead compressed, hairline fixed.

    Keyed low -> 1 -> low -> 1 at frames 1, 21, 41, 61.
    """
    me = ob.data
    n = len(me.vertices)
    rest = np.empty(n * 3, np.float32)
    me.attributes["position"].data.foreach_get("vector", rest)
    rest = rest.reshape(-1, 3)
    ob.shape_key_add(name="Basis", from_mix=False)
    kb = ob.shape_key_add(name="BrowsUp", from_mix=False)
    x, y, z = rest[:, 0].astype(np.float64), rest[:, 1].astype(np.float64), rest[:, 2].astype(np.float64)
    brow = float(lm["glabella"][2])
    eye = float(lm["eye_L"][2])
    hair = float(lm["hairline_center"][2])
    half_w = 1.45 * abs(float(lm["brow_outer_L"][0]) - float(lm["glabella"][0]))
    fy = float(lm["glabella"][1])
    # vertical profile: 0 at the eyes, 1 at the brows, back to 0 at the hairline
    up = _smoothstep(eye, brow, z) * (1.0 - _smoothstep(brow, hair, z))
    side = 1.0 - _smoothstep(0.6 * half_w, half_w, np.abs(x - float(lm["glabella"][0])))
    front = 1.0 - _smoothstep(fy + 0.025, fy + 0.05, y)
    dz = amount * up * side * front
    co = rest.copy()
    co[:, 2] += dz.astype(np.float32)
    _set_key_co(kb, co)
    kb.value = 0.0
    for f, v in ((1, low), (21, 1.0), (41, low), (61, 1.0)):
        kb.value = v
        kb.keyframe_insert("value", frame=f)
    return kb, int(np.count_nonzero(dz))


ARKIT_KEYS = 52  # ARKit's blendshape count
_AXES = np.array([(0.0, -1.0, 0.0), (0.0, 0.0, 1.0), (1.0, 0.0, 0.0),
                  (0.0, 1.0, 0.0), (0.0, 0.0, -1.0), (-1.0, 0.0, 0.0)])


def _set_key_co(kb, co):
    if hasattr(kb, "points"):  # the fast path (docs/architecture.md, "Measured Blender facts")
        kb.points.foreach_set("co", co.ravel())
    else:
        kb.data.foreach_set("co", co.ravel())


def add_arkit_keys(ob, lm, n_keys=ARKIT_KEYS, seed=52):
    """A production-like facial rig: ``n_keys`` shape keys, all animated, none ever 0.

    Key 0 is "BrowsUp" (as in the light rig, keyed 0.05 -> 1 -> 0.05 -> 1 so it
    never drops out).  Keys 1.. are "Region_NN": a Gaussian bump
    ``a * exp(-d^2 / 2 sigma^2)`` (cut to 0 below 1e-3 of its peak) around a
    centre on the face front, with ``a`` 2-5 mm and ``sigma`` 6-9 mm, moving
    along a direction that cycles out, up, sideways, in, down, the other way.
    Centres are spread over the face front (|x| up to the cheekbones, chin to
    hairline, front half of the head) by farthest-point sampling from a seeded
    start; everything comes from ``np.random.default_rng(seed)``, so the rig
    is deterministic.  Returns (key blocks, vertices moved by each key).
    """
    kb0, n0 = add_brows_up(ob, lm, low=0.05)
    me = ob.data
    n = len(me.vertices)
    rest = np.empty(n * 3, np.float32)
    me.attributes["position"].data.foreach_get("vector", rest)
    rest = rest.reshape(-1, 3)
    pos = rest.astype(np.float64)
    rng = np.random.default_rng(seed)
    half_w = abs(float(lm["cheekbone_L"][0]))
    z_lo, z_hi = float(lm["chin"][2]) + 0.004, float(lm["hairline_center"][2]) - 0.008
    y_front = float(lm["cheekbone_L"][1]) + 0.03
    cand = np.flatnonzero((np.abs(pos[:, 0]) <= half_w) & (pos[:, 2] >= z_lo) & (pos[:, 2] <= z_hi)
                          & (pos[:, 1] <= y_front))
    if len(cand) < n_keys:
        raise RuntimeError(f"face front has {len(cand)} vertices, need {n_keys - 1} bump centres")
    cpos = pos[cand]
    first = int(rng.integers(len(cand)))
    centres = [first]
    d2 = np.einsum("ij,ij->i", cpos - cpos[first], cpos - cpos[first])
    for _ in range(n_keys - 2):  # farthest-point sampling: evenly spread centres
        nxt = int(np.argmax(d2))
        centres.append(nxt)
        d2 = np.minimum(d2, np.einsum("ij,ij->i", cpos - cpos[nxt], cpos - cpos[nxt]))
    keys, moved = [kb0], [n0]
    frames = np.arange(1, 62, 10)
    for i, c in enumerate(centres, start=1):
        amp = rng.uniform(0.002, 0.005)
        sigma = rng.uniform(0.006, 0.009)
        period = rng.uniform(30.0, 50.0)
        phase = 2.0 * np.pi * i / (n_keys - 1) + rng.uniform(-0.3, 0.3)
        diff = pos - cpos[c]
        w = np.exp(-np.einsum("ij,ij->i", diff, diff) / (2.0 * sigma * sigma))
        w[w < 1e-3] = 0.0
        kb = ob.shape_key_add(name=f"Region_{i:02d}", from_mix=False)
        co = rest + (amp * w[:, None] * _AXES[(i - 1) % len(_AXES)]).astype(np.float32)
        _set_key_co(kb, co)
        for f in frames:
            kb.value = float(0.55 + 0.45 * np.sin(2.0 * np.pi * (f - 1) / period + phase))
            kb.keyframe_insert("value", frame=int(f))
        keys.append(kb)
        moved.append(int(np.count_nonzero(w)))
    return keys, moved


def add_jaw_rig(ob, lm, scene):
    """An armature with a Jaw bone rotating open, weighted to the lower face by distance."""
    arm = bpy.data.armatures.new(ob.name + "_Rig")
    rig = bpy.data.objects.new(ob.name + "_Rig", arm)
    scene.collection.objects.link(rig)
    chin = np.asarray(lm["chin"], float)
    mouth = np.asarray(lm["mouth_corner_L"], float)
    eye = np.asarray(lm["eye_L"], float)
    pivot = np.array([0.0, chin[1] + 0.09, 0.5 * (mouth[2] + eye[2])])  # near the jaw joint
    vl = bpy.context.view_layer
    vl.objects.active = rig
    bpy.ops.object.mode_set(mode="EDIT")
    eb = arm.edit_bones.new("Jaw")
    eb.head = pivot.tolist()
    eb.tail = chin.tolist()
    bpy.ops.object.mode_set(mode="OBJECT")

    me = ob.data
    n = len(me.vertices)
    rest = np.empty(n * 3, np.float32)
    me.attributes["position"].data.foreach_get("vector", rest)
    rest = rest.reshape(-1, 3).astype(np.float64)
    c = np.array([0.0, chin[1] + 0.02, chin[2] + 0.005])
    d = np.linalg.norm(rest - c, axis=1)
    w = 1.0 - _smoothstep(0.035, 0.065, d)
    w *= 1.0 - _smoothstep(mouth[2] - 0.012, mouth[2] + 0.002, rest[:, 2])  # below the mouth line
    w *= _smoothstep(chin[2] - 0.06, chin[2] - 0.03, rest[:, 2])  # fade out down the neck
    vg = ob.vertex_groups.new(name="Jaw")
    levels = np.round(w * 32.0).astype(int)
    for lv in np.unique(levels):
        if lv == 0:
            continue
        vg.add(np.flatnonzero(levels == lv).tolist(), lv / 32.0, "REPLACE")
    mod = ob.modifiers.new("Armature", "ARMATURE")
    mod.object = rig
    mod.use_vertex_groups = True

    pb = rig.pose.bones["Jaw"]
    pb.rotation_mode = "XYZ"
    for f, deg in ((1, 0.0), (16, 15.0), (31, 0.0), (46, 15.0)):
        pb.rotation_euler = (math.radians(deg), 0.0, 0.0)
        pb.keyframe_insert("rotation_euler", frame=f)
    vl.objects.active = ob
    return rig, int(np.count_nonzero(levels))


# ---------------------------------------------------------------------------
# Native Geometry Nodes tension (edge length / rest length, averaged to points)
# ---------------------------------------------------------------------------
def store_rest_position(ob):
    me = ob.data
    n = len(me.vertices)
    rest = np.empty(n * 3, np.float32)
    me.attributes["position"].data.foreach_get("vector", rest)
    att = me.attributes.get(REST_ATTR) or me.attributes.new(REST_ATTR, "FLOAT_VECTOR", "POINT")
    att.data.foreach_set("vector", rest)


def _tension_field(ng):
    """The tension nodes in ``ng``: (group input, group output, the socket of the field
    current edge length / rest length, evaluated on EDGE; read on POINT it is the mean
    of the incident edges)."""
    N, L = ng.nodes, ng.links
    gin, gout = N.new("NodeGroupInput"), N.new("NodeGroupOutput")
    ev = N.new("GeometryNodeInputMeshEdgeVertices")
    rest = N.new("GeometryNodeInputNamedAttribute")
    rest.data_type = "FLOAT_VECTOR"
    rest.inputs["Name"].default_value = REST_ATTR
    at1, at2 = N.new("GeometryNodeFieldAtIndex"), N.new("GeometryNodeFieldAtIndex")
    for at, idx in ((at1, "Vertex Index 1"), (at2, "Vertex Index 2")):
        at.domain = "POINT"
        at.data_type = "FLOAT_VECTOR"
        L.new(rest.outputs["Attribute"], at.inputs["Value"])
        L.new(ev.outputs[idx], at.inputs["Index"])
    cur = N.new("ShaderNodeVectorMath")
    cur.operation = "DISTANCE"
    L.new(ev.outputs["Position 1"], cur.inputs[0])
    L.new(ev.outputs["Position 2"], cur.inputs[1])
    rl = N.new("ShaderNodeVectorMath")
    rl.operation = "DISTANCE"
    L.new(at1.outputs["Value"], rl.inputs[0])
    L.new(at2.outputs["Value"], rl.inputs[1])
    div = N.new("ShaderNodeMath")
    div.operation = "DIVIDE"  # GN's divide returns 0 for a zero rest length
    L.new(cur.outputs["Value"], div.inputs[0])
    L.new(rl.outputs["Value"], div.inputs[1])
    on_edge = N.new("GeometryNodeFieldOnDomain")
    on_edge.domain = "EDGE"
    on_edge.data_type = "FLOAT"
    L.new(div.outputs["Value"], on_edge.inputs["Value"])
    return gin, gout, on_edge.outputs["Value"]


def _new_group(name):
    ng = bpy.data.node_groups.new(name, "GeometryNodeTree")
    ng.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    ng.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    return ng


def build_tension_group():
    ng = bpy.data.node_groups.get(TENSION_GROUP)
    if ng is not None:
        return ng
    ng = _new_group(TENSION_GROUP)
    gin, gout, tension = _tension_field(ng)
    store = ng.nodes.new("GeometryNodeStoreNamedAttribute")
    store.data_type = "FLOAT"
    store.domain = "POINT"  # edge -> point adaptation averages the incident edges
    store.inputs["Name"].default_value = TENSION_ATTR
    ng.links.new(gin.outputs[0], store.inputs["Geometry"])
    ng.links.new(tension, store.inputs["Value"])
    ng.links.new(store.outputs[0], gout.inputs[0])
    return ng


def add_tension_modifier(ob):
    store_rest_position(ob)
    mod = ob.modifiers.new("Tension", "NODES")
    mod.node_group = build_tension_group()
    return mod


# ---------------------------------------------------------------------------
# Native Geometry Nodes displacement by tension (what users build for geometric wrinkles)
# ---------------------------------------------------------------------------
DISPLACE_GROUP = "Bench Tension Displace"
DISPLACE_CONST_GROUP = "Bench Tension Displace Constant"
HEIGHT_IMAGE = "Bench Wrinkle Height"
HEIGHT_RES = 1024
HEIGHT_MAX = 0.01  # m: the image's heights are 0..HEIGHT_MAX
HEIGHT_CONST = 0.005  # m: the constant height of the untextured variant


def ensure_uv_map(ob):
    """The name of ``ob``'s active UV map; a cylindrical one is made if it has none.

    Cylindrical about the Z axis through the bounding-box centre, u = 0.5 at the
    front (-Y), v from the lowest to the highest vertex; per vertex (the seam at
    the back is smeared, which a timing does not mind).  Returns (name, made).
    """
    me = ob.data
    if len(me.uv_layers):
        return (me.uv_layers.active or me.uv_layers[0]).name, False
    n = len(me.vertices)
    pos = np.empty(n * 3, np.float32)
    me.attributes["position"].data.foreach_get("vector", pos)
    pos = pos.reshape(-1, 3).astype(np.float64)
    centre = 0.5 * (pos.min(0) + pos.max(0))
    rel = pos - centre
    u = 0.5 + np.arctan2(rel[:, 0], -rel[:, 1]) / (2.0 * np.pi)
    span = max(float(np.ptp(pos[:, 2])), 1e-9)
    v = (pos[:, 2] - pos[:, 2].min()) / span
    corner_vert = np.empty(len(me.loops), np.int32)
    me.loops.foreach_get("vertex_index", corner_vert)
    uv = np.stack([u, v], -1).astype(np.float32)[corner_vert]
    layer = me.uv_layers.new(name="UVMap")
    layer.uv.foreach_set("vector", uv.ravel())
    return layer.name, True


def make_height_image(res=HEIGHT_RES):
    """A ``res`` x ``res`` float, Non-Color image of wrinkle-like heights in metres.

    Horizontal furrows (48 per unit of v) bent by a slow wave in u, modulated by a
    broad bump: values 0..HEIGHT_MAX in R, G and B, alpha 1.  The colour space is
    set before the pixels are written (changing it afterwards would regenerate an
    unsaved generated image and lose them).
    """
    img = bpy.data.images.get(HEIGHT_IMAGE)
    if img is not None:
        bpy.data.images.remove(img)
    img = bpy.data.images.new(HEIGHT_IMAGE, res, res, alpha=False, float_buffer=True)
    img.colorspace_settings.name = "Non-Color"
    c = (np.arange(res, dtype=np.float64) + 0.5) / res
    u, v = np.meshgrid(c, c)  # rows are v (Blender's pixel order: bottom row first)
    furrows = 0.5 + 0.5 * np.sin(2.0 * np.pi * (48.0 * v + 1.5 * np.sin(2.0 * np.pi * 3.0 * u)))
    bump = np.exp(-((u - 0.5) ** 2 + (v - 0.6) ** 2) / (2.0 * 0.2 ** 2))
    h = (HEIGHT_MAX * furrows * bump).astype(np.float32)
    px = np.ones((res, res, 4), np.float32)
    px[..., :3] = h[..., None]
    img.pixels.foreach_set(px.ravel())
    img.update()
    return img


def build_displace_group(uv_name, image=None):
    """Tension, then Set Position: offset = normal * height * max(0, 1 - tension).

    ``image``: the height is that image's red channel sampled (Image Texture node,
    linear, repeat) at the point's UV (the corner UV map ``uv_name`` read on POINT,
    i.e. averaged over the point's corners); None: the constant HEIGHT_CONST.
    """
    name = DISPLACE_GROUP if image is not None else DISPLACE_CONST_GROUP
    ng = bpy.data.node_groups.get(name)
    if ng is not None:
        bpy.data.node_groups.remove(ng)
    ng = _new_group(name)
    N, L = ng.nodes, ng.links
    gin, gout, tension = _tension_field(ng)
    slack = N.new("ShaderNodeMath")
    slack.operation = "SUBTRACT"
    slack.inputs[0].default_value = 1.0
    L.new(tension, slack.inputs[1])
    comp = N.new("ShaderNodeMath")
    comp.operation = "MAXIMUM"
    L.new(slack.outputs["Value"], comp.inputs[0])
    comp.inputs[1].default_value = 0.0
    amount = N.new("ShaderNodeMath")
    amount.operation = "MULTIPLY"
    L.new(comp.outputs["Value"], amount.inputs[0])
    if image is not None:
        uv = N.new("GeometryNodeInputNamedAttribute")
        uv.data_type = "FLOAT_VECTOR"
        uv.inputs["Name"].default_value = uv_name
        tex = N.new("GeometryNodeImageTexture")
        tex.interpolation = "Linear"
        tex.extension = "REPEAT"
        tex.inputs["Image"].default_value = image
        L.new(uv.outputs["Attribute"], tex.inputs["Vector"])
        sep = N.new("FunctionNodeSeparateColor")
        L.new(tex.outputs["Color"], sep.inputs["Color"])
        L.new(sep.outputs["Red"], amount.inputs[1])
    else:
        amount.inputs[1].default_value = HEIGHT_CONST
    normal = N.new("GeometryNodeInputNormal")
    scale = N.new("ShaderNodeVectorMath")
    scale.operation = "SCALE"
    L.new(normal.outputs["Normal"], scale.inputs[0])
    L.new(amount.outputs["Value"], scale.inputs["Scale"])
    setpos = N.new("GeometryNodeSetPosition")
    L.new(gin.outputs[0], setpos.inputs["Geometry"])
    L.new(scale.outputs["Vector"], setpos.inputs["Offset"])
    L.new(setpos.outputs[0], gout.inputs[0])
    return ng


def add_displace_modifier(ob, uv_name, image=None):
    """A Geometry Nodes modifier (at the end of the stack) running ``build_displace_group``;
    needs the ``rest_position`` attribute (``store_rest_position``)."""
    mod = ob.modifiers.new("Displace by Tension" + ("" if image is not None else " (constant)"), "NODES")
    mod.node_group = build_displace_group(uv_name, image)
    return mod


# ---------------------------------------------------------------------------
def clear_scene():
    for ob in list(bpy.data.objects):
        bpy.data.objects.remove(ob)
    for coll in (bpy.data.meshes, bpy.data.armatures, bpy.data.actions, bpy.data.node_groups,
                 bpy.data.shape_keys, bpy.data.collections, bpy.data.images):
        for block in list(coll):
            try:
                coll.remove(block)
            except Exception:  # noqa: BLE001 - shape keys cannot be removed directly
                pass
