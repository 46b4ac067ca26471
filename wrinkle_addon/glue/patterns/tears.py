# SPDX-License-Identifier: GPL-3.0-or-later
"""Tears' water and dripping tears ("Pattern functions and tears", §4.1) as objects: the
teardrop surface of ``core.patterns.tears`` built by a Geometry Nodes group from the scene time,
so a drop animates, falls along the world's gravity, repeats and renders with no Python (and on
a farm with no add-on), in a water material; and the thin water film of shedding tears
(:func:`film_material`)."""

import math

import bpy

from ...core.patterns import tears
from ..errors import WrinkleError
from ..faces import collections_for
from ..nodes import Builder, float_inputs, principled, use_nodes
from ..nodes import ensure_group as ensure_group_of

GROUP_NAME = "Teardrop"
MODIFIER_NAME = "Teardrop"
MATERIAL_NAME = "Tear Water"
VERSION = 2
NU, NV = 24, 32  # rows from the top to the bottom of the drop, columns around it
REACH = 1.6  # the drop's widest radius at its birth is 1.51 Width: a drop this far out touches the skin
INPUTS = (  # name, default, min, max, tooltip
    ("Width", 0.0025, 0.0, 0.05, "The drop's size across (the formula's alpha), in scene units"),
    ("Length", 0.0016, 0.0, 0.05, "The drop's size along its fall (the formula's beta), in scene units; "
     "the drop is 2 x Length x t long"),
    ("Speed", 0.02, 0.0, 1.0, "How fast the drop falls (the formula's lambda), in scene units per second"),
    ("Start", 0.0, -1e6, 1e6, "When the first drop forms, in seconds of scene time"),
    ("Every", 2.0, 0.01, 1e6, "How often a new drop falls, in seconds"),
    ("Lasts", 1.2, 0.0, 1e6, "How long each drop shows, in seconds"),
)


class TearError(WrinkleError):
    """Bad input for a tear; the message is meant for the user."""


def _build(ng):
    ng.interface.clear()
    ng.nodes.clear()
    ng.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    float_inputs(ng, INPUTS)
    mat = ng.interface.new_socket("Material", in_out="INPUT", socket_type="NodeSocketMaterial")
    mat.description = "The tear's material (water)"
    b = Builder(ng)
    gin = b.node("NodeGroupInput")
    i = gin.outputs
    b.x = 200
    grid = b.node("GeometryNodeMeshGrid")
    grid.inputs["Size X"].default_value = math.pi
    grid.inputs["Size Y"].default_value = 2.0 * math.pi
    grid.inputs["Vertices X"].default_value = NU
    grid.inputs["Vertices Y"].default_value = NV
    sep = b.node("ShaderNodeSeparateXYZ")
    b.link(b.node("GeometryNodeInputPosition").outputs[0], sep.inputs[0])
    u = b.math("ADD", sep.outputs["X"], 0.5 * math.pi)  # 0 at the top, pi at the bottom
    v = b.math("ADD", sep.outputs["Y"], math.pi)  # around
    b.x = 400
    since = b.math("SUBTRACT", b.node("GeometryNodeInputSceneTime").outputs["Seconds"], i["Start"])
    tau = b.math("FLOORED_MODULO", since, i["Every"])  # the drop's age
    t = b.math("ADD", tau, tears.T0)
    cos_u = b.math("COSINE", u)
    r = b.math("DIVIDE", b.math("MULTIPLY", i["Width"], b.math("SINE", u)), b.math("ADD", t, cos_u))
    b.x = 600
    z = b.math("SUBTRACT", b.math("MULTIPLY", b.math("MULTIPLY", i["Length"], t), cos_u),
               b.math("MULTIPLY_ADD", i["Length"], tears.T0, b.math("MULTIPLY", i["Speed"], tau)))
    xyz = b.node("ShaderNodeCombineXYZ")
    b.link(b.math("MULTIPLY", r, b.math("COSINE", v)), xyz.inputs["X"])
    b.link(b.math("MULTIPLY", r, b.math("SINE", v)), xyz.inputs["Y"])
    b.link(z, xyz.inputs["Z"])
    b.x = 800
    # the formula's z is the world's up: the drop falls along the world's gravity however the
    # head (its parent) is turned; its points, offsets from its origin in the world, are
    # taken into its own space by the inverse of its world matrix (no Python per frame)
    me = b.node("GeometryNodeObjectInfo", transform_space="ORIGINAL")
    b.link(b.node("GeometryNodeSelfObject").outputs[0], me.inputs["Object"])
    to_local = b.node("FunctionNodeInvertMatrix")
    b.link(me.outputs["Transform"], to_local.inputs["Matrix"])
    local = b.node("FunctionNodeTransformDirection")
    b.link(xyz.outputs[0], local.inputs["Direction"])
    b.link(to_local.outputs["Matrix"], local.inputs["Transform"])
    setpos = b.node("GeometryNodeSetPosition")
    b.link(grid.outputs["Mesh"], setpos.inputs["Geometry"])
    b.link(local.outputs[0], setpos.inputs["Position"])
    merge = b.node("GeometryNodeMergeByDistance")  # the seam around and the two tips
    merge.inputs["Distance"].default_value = 1e-7
    b.link(setpos.outputs[0], merge.inputs["Geometry"])
    # no drop before Start or past its lifetime in its cycle
    hidden = b.node("FunctionNodeBooleanMath", operation="OR")
    before = b.node("FunctionNodeCompare", data_type="FLOAT", operation="LESS_THAN")
    b.link(since, before.inputs[0])
    before.inputs[1].default_value = 0.0
    late = b.node("FunctionNodeCompare", data_type="FLOAT", operation="GREATER_EQUAL")
    b.link(tau, late.inputs[0])
    b.link(i["Lasts"], late.inputs[1])
    b.link(before.outputs["Result"], hidden.inputs[0])
    b.link(late.outputs["Result"], hidden.inputs[1])
    b.x = 1000
    delete = b.node("GeometryNodeDeleteGeometry")
    b.link(merge.outputs[0], delete.inputs["Geometry"])
    b.link(hidden.outputs[0], delete.inputs["Selection"])
    setmat = b.node("GeometryNodeSetMaterial")
    b.link(delete.outputs[0], setmat.inputs["Geometry"])
    b.link(i["Material"], setmat.inputs["Material"])
    smooth = b.node("GeometryNodeSetShadeSmooth")
    b.link(setmat.outputs[0], smooth.inputs["Geometry"])
    gout = b.node("NodeGroupOutput")
    b.link(smooth.outputs[0], gout.inputs["Geometry"])


def ensure_group():
    return ensure_group_of(GROUP_NAME, "GeometryNodeTree", VERSION, _build, TearError)


def water_material():
    """A falling drop's water: a solid lens of clear water (full transmission, IOR 1.33, low
    roughness), refracting what is behind it.  EEVEE refracts by ray tracing through a
    sphere-like thickness (the material's own settings; the scene's Raytracing sharpens it)."""
    mat = bpy.data.materials.get(MATERIAL_NAME) or bpy.data.materials.new(MATERIAL_NAME)
    use_nodes(mat)
    bsdf = principled(mat.node_tree)
    bsdf.inputs["Base Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    bsdf.inputs["Transmission Weight"].default_value = 1.0
    bsdf.inputs["IOR"].default_value = 1.33
    bsdf.inputs["Roughness"].default_value = 0.03
    mat.diffuse_color = (0.8, 0.9, 1.0, 0.3)
    mat.use_raytrace_refraction = True  # EEVEE: refract what is behind, not only the world
    mat.thickness_mode = "SPHERE"
    mat.use_transparent_shadow = True
    return mat


FILM_NAME = "Tear Film"
FILM_VERSION = 2
FILM_IOR = 1.33  # water
FILM_ROUGHNESS = 0.08  # the tear's fine ripples, below the mesh and the ripple texture
SURFACE_ATTR = "tear_surface"  # a shedding tear's (along, across) in tear widths, for its ripples
RIPPLE_SCALE = 8.0  # ripples per tear width
RIPPLE_TILT = 1.0  # how far the ripples tilt the film's normal


def film_material():
    """A shedding tear's water: a thin film on the skin.  Its two surfaces are almost parallel
    and a fraction of a millimetre apart, so the skin seen through it is not displaced and
    light crosses it nearly whole: what reaches the eye is the skin behind, plus a
    mirror-like reflection weighted by the Fresnel factor ``F`` (IOR 1.33, 2 % face-on,
    rising toward grazing angles, so the film's curved edges and its rounded head catch the
    lights).  That is a Transparent BSDF plus ``F`` times a sharp Glossy BSDF.  The skin is
    not dimmed by ``1 - F``: the film lies on the skin, and what it reflects away at its
    grazing edges is the skin's light coming back out of it, so taking ``1 - F`` off there
    (with a reflection of the dark room in its place) draws a dark outline, a tube, that real
    tears do not show.
    The film's inner surfaces (seen from inside the closed shell: Backfacing) are left fully
    transparent, so it is one interface, not a mirror inside.  Transparent lets shadow rays
    through in Cycles and EEVEE (transparent shadows), so the skin under the tear stays lit:
    a refracting (transmission) shell blocks them, and its skin shows as a dark cut."""
    mat = bpy.data.materials.get(FILM_NAME)
    if mat is not None and mat.get("ewrinkles_version") == FILM_VERSION:
        return mat
    mat = mat or bpy.data.materials.new(FILM_NAME)
    use_nodes(mat)
    nt = mat.node_tree
    nt.nodes.clear()
    b = Builder(nt)
    geometry = b.node("ShaderNodeNewGeometry")
    facing, normal = geometry.outputs["Backfacing"], geometry.outputs["Normal"]
    where = b.node("ShaderNodeAttribute", attribute_name=SURFACE_ATTR)
    noise = b.node("ShaderNodeTexNoise", noise_dimensions="3D")
    b.link(where.outputs["Vector"], noise.inputs["Vector"])
    noise.inputs["Scale"].default_value = RIPPLE_SCALE
    noise.inputs["Detail"].default_value = 2.0
    b.x = 200
    # the ripples: a random tangent tilt of the normal, t - (t . n) n, scaled and added
    tilt = b.decode(noise.outputs["Color"])
    tilt = b.vmath("SUBTRACT", tilt, b.vmath("SCALE", normal, scale=b.vmath("DOT_PRODUCT", tilt, normal)))
    rippled = b.vmath("NORMALIZE", b.vmath("MULTIPLY_ADD", tilt, (RIPPLE_TILT,) * 3, normal))
    b.x = 400
    fresnel = b.node("ShaderNodeFresnel")
    fresnel.inputs["IOR"].default_value = FILM_IOR  # on the film's smooth normal: no dark mottling
    fac = b.math("MULTIPLY", fresnel.outputs["Fac"], b.math("SUBTRACT", 1.0, facing))
    clear = b.node("ShaderNodeBsdfTransparent")
    clear.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    gloss = b.node("ShaderNodeBsdfGlossy", distribution="GGX")
    gloss.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    gloss.inputs["Roughness"].default_value = FILM_ROUGHNESS
    b.link(rippled, gloss.inputs["Normal"])
    b.x = 600
    wet = b.node("ShaderNodeAddShader")  # the skin seen through, plus the film's reflection
    b.link(clear.outputs[0], wet.inputs[0])
    b.link(gloss.outputs[0], wet.inputs[1])
    mix = b.node("ShaderNodeMixShader")  # clear + F gloss (fully clear from inside)
    b.link(fac, mix.inputs["Fac"])
    b.link(clear.outputs[0], mix.inputs[1])
    b.link(wet.outputs[0], mix.inputs[2])
    b.x = 800
    out = b.node("ShaderNodeOutputMaterial")
    b.link(mix.outputs[0], out.inputs["Surface"])
    mat.diffuse_color = (0.9, 0.95, 1.0, 0.15)
    mat.roughness = FILM_ROUGHNESS
    mat.use_transparent_shadow = True  # EEVEE: the skin under the film stays lit
    # EEVEE: blended, a smooth see-through film (dithered needs many samples not to speckle);
    # the film's highlights are the lights' own, which blended surfaces keep
    mat.surface_render_method = "BLENDED"
    mat["ewrinkles_version"] = FILM_VERSION
    return mat


def _input(mod, name):
    """The modifier's value of the group input ``name``: ``(holder, key)``.  Blender 5 keeps
    a Geometry Nodes modifier's inputs in ``properties.inputs`` (each with a ``value``);
    Blender 4 as ID properties of the modifier keyed by the socket's identifier."""
    ident = next(s.identifier for s in mod.node_group.interface.items_tree
                 if getattr(s, "in_out", "") == "INPUT" and s.name == name)
    props = getattr(mod, "properties", None)
    if props is not None and hasattr(props, "inputs"):
        return getattr(props.inputs, ident), "value"
    return mod, ident


def set_input(mod, name, value):
    holder, key = _input(mod, name)
    if key == "value":
        holder.value = value
    else:
        holder[key] = value


def get_input(mod, name):
    holder, key = _input(mod, name)
    return holder.value if key == "value" else holder[key]


def reach_down(ob):
    """How far below its origin the teardrop object ``ob``'s drop reaches over its life
    (scene units): its fall, ``Speed x Lasts``, and its length then, ``2 Length t``."""
    mod = ob.modifiers[MODIFIER_NAME]
    speed, length, lasts = (float(get_input(mod, n)) for n in ("Speed", "Length", "Lasts"))
    return speed * lasts + 2.0 * length * (tears.T0 + lasts)


def falls_into(context, face, start, distance):
    """Whether a drop falling from ``start`` (world) along the world's -Z meets the skin of
    ``face`` (evaluated) within ``distance`` (scene units)."""
    from mathutils import Vector

    inverse = face.matrix_world.inverted_safe()
    begin = Vector(start) - Vector((0.0, 0.0, 1e-3 * distance))
    down = inverse.to_3x3() @ Vector((0.0, 0.0, -1.0))
    scale = down.length
    if scale <= 0.0:
        return False
    hit, where, _n, _i = face.ray_cast(inverse @ begin, down / scale, distance=distance * scale,
                                       depsgraph=context.evaluated_depsgraph_get())
    return bool(hit)


def add_teardrop(context, face, location, **values):
    """A new teardrop object at ``location`` (world), parented to ``face`` so it follows it;
    ``values``: the group's inputs by name (Width, Length, Speed, Start, Every, Lasts)."""
    if values.get("Every", 1.0) <= 0.0:
        raise TearError("A tear must fall every so many seconds: Every must be above 0")
    me = bpy.data.meshes.new("Teardrop")
    ob = bpy.data.objects.new(f"{face.name} Teardrop", me)
    for coll in collections_for(face, context.scene):
        coll.objects.link(ob)
    ob.location = location
    ob.parent = face
    ob.matrix_parent_inverse = face.matrix_world.inverted_safe()
    mod = ob.modifiers.new(MODIFIER_NAME, "NODES")
    mod.node_group = ensure_group()
    mat = water_material()
    me.materials.append(mat)
    set_input(mod, "Material", mat)
    for name, value in values.items():
        set_input(mod, name, float(value))
    return ob
