# SPDX-License-Identifier: GPL-3.0-or-later
"""The sample head's materials, with no image textures (the ICT model ships none), for
Cycles and EEVEE.

* **Skin** (:func:`skin`): a Principled BSDF with random-walk subsurface scattering at a
  skin's radii (red scatters furthest: 3.7, 1.4 and 0.7 mm for red, green and blue, the
  order of Jensen et al.'s measured skin), its colour, roughness and specular varied over
  the face by the point attribute ``ewrinkles_skin`` (oil, red, lip: ``core.skin.regions``):
  an oilier, sharper highlight on the forehead, nose and chin, a flush where the skin is
  thin, the red of the lips. A faint mottle breaks the colour up, and a fine bump of pores
  and micro-relief, in the skin's rest coordinates (``ewrinkles_rest``, so it stays on the
  skin as it moves), is kept well below the wrinkles: its slopes are a few percent. The
  bump node is a normal layer (``nodes.LAYER_TAG``), so wrinkle maps and fine wrinkles chain
  through it.
* **Eye** (:func:`eye`): the eyeball under the cornea: the sclera, the iris with radial
  fibres and a dark limbal ring, the pupil, drawn from the angle to the gaze
  (``ewrinkles_eye``: ``core.skin.eye_directions``).
* **Cornea** and **lacrimal fluid** (:func:`cornea`, :func:`lacrimal`): clear wet films, a
  Transparent BSDF plus the Fresnel share of a sharp Glossy BSDF, which put the wet highlight
  on the eye and let the eyeball show through and cast no shadow.
* **Lashes**, **teeth** and **mouth** (gums and tongue): plain Principled BSDFs.
"""

import bpy

from .nodes import LAYER_TAG, Builder, use_nodes

VERSION = 1
KEY = "ewrinkles_sample_material"

SKIN_RGB = (0.56, 0.34, 0.26)  # linear base colour
FLUSH_RGB = (0.62, 0.24, 0.19)
LIP_RGB = (0.46, 0.16, 0.14)
SSS_RADIUS = (3.7, 1.4, 0.7)  # mm
SSS_SCALE = 0.001  # the radii are in millimetres
PORE_SCALE = 1400.0  # pores per metre (about 0.7 mm apart)
PORE_DEPTH = 0.00012  # m: a pore's depth in the bump
MOTTLE_SCALE = 45.0  # per metre: blotches about 2 cm across


def _material(name, build):
    """The material ``name``: reused when it is ours at this version, else (re)built."""
    mat = bpy.data.materials.get(name)
    if mat is not None and mat.get(KEY) == VERSION:
        return mat
    mat = mat or bpy.data.materials.new(name)
    use_nodes(mat)
    mat.node_tree.nodes.clear()
    b = Builder(mat.node_tree)
    out = b.node("ShaderNodeOutputMaterial")
    out.location = (1400, 0)
    build(mat, b, out)
    mat[KEY] = VERSION
    return mat


def _principled(b, color, roughness, **inputs):
    bsdf = b.node("ShaderNodeBsdfPrincipled")
    bsdf.location = (1100, 0)
    bsdf.inputs["Base Color"].default_value = (*color, 1.0)
    bsdf.inputs["Roughness"].default_value = roughness
    for key, value in inputs.items():
        bsdf.inputs[key].default_value = value
    return bsdf


def _attribute(b, name):
    return b.node("ShaderNodeAttribute", attribute_name=name, attribute_type="GEOMETRY")


def _mix_color(b, fac, a, c):
    """(1 - fac) a + fac c, on colours (sockets or RGB tuples)."""
    n = b.node("ShaderNodeMix", data_type="RGBA", blend_type="MIX")
    b.link(fac, n.inputs["Factor"])
    for sock, v in ((n.inputs[6], a), (n.inputs[7], c)):
        if isinstance(v, tuple):
            sock.default_value = (*v, 1.0)
        else:
            b.link(v, sock)
    return n.outputs[2]


def _build_skin(mat, b, out):
    regions = b.separate(_attribute(b, "ewrinkles_skin").outputs["Vector"])
    oil, red, lip = regions[0], regions[1], regions[2]
    rest = _attribute(b, "ewrinkles_rest").outputs["Vector"]
    b.x, b.y = 200, 0
    mottle = b.node("ShaderNodeTexNoise", noise_dimensions="3D")
    b.link(rest, mottle.inputs["Vector"])
    mottle.inputs["Scale"].default_value = MOTTLE_SCALE
    mottle.inputs["Detail"].default_value = 3.0
    color = _mix_color(b, b.math("MULTIPLY", red, 0.75), SKIN_RGB, FLUSH_RGB)
    color = _mix_color(b, lip, color, LIP_RGB)
    blotch = b.math("MULTIPLY_ADD", mottle.outputs["Fac"], 0.5, 0.0)  # about 0.25 +- 0.1
    color = _mix_color(b, blotch, color, FLUSH_RGB)
    b.x, b.y = 500, 0
    # Roughness: 0.55 on dry skin, 0.4 on the T-zone, 0.42 on the lips; specular up with oil.
    rough = b.math("MULTIPLY_ADD", oil, -0.15, 0.55)
    rough = b.math("MULTIPLY_ADD", lip, -0.13, rough)
    specular = b.math("MULTIPLY_ADD", oil, 0.2, 0.38)
    # Pores (pits at Voronoi points) and micro-relief, fewer on the lips.
    pores = b.node("ShaderNodeTexVoronoi", feature="F1", distance="EUCLIDEAN")
    b.link(rest, pores.inputs["Vector"])
    pores.inputs["Scale"].default_value = PORE_SCALE
    pores.inputs["Randomness"].default_value = 0.9
    pit = b.math("POWER", b.math("MINIMUM", b.math("MULTIPLY", pores.outputs["Distance"], 2.2), 1.0), 0.5)
    micro = b.node("ShaderNodeTexNoise", noise_dimensions="3D")
    b.link(rest, micro.inputs["Vector"])
    micro.inputs["Scale"].default_value = 600.0
    micro.inputs["Detail"].default_value = 4.0
    height = b.math("MULTIPLY_ADD", micro.outputs["Fac"], 0.6, pit)
    b.x, b.y = 800, -300
    bump = b.node("ShaderNodeBump")
    bump.name = bump.label = "Skin Pores"
    bump[LAYER_TAG] = True
    b.link(height, bump.inputs["Height"])
    bump.inputs["Distance"].default_value = PORE_DEPTH
    b.link(b.math("MULTIPLY_ADD", lip, -0.7, b.math("MULTIPLY_ADD", oil, 0.4, 0.6)), bump.inputs["Strength"])
    bsdf = _principled(b, SKIN_RGB, 0.5, **{"Subsurface Weight": 1.0, "Subsurface Radius": SSS_RADIUS,
                                            "Subsurface Scale": SSS_SCALE})
    bsdf.subsurface_method = "RANDOM_WALK"
    b.link(color, bsdf.inputs["Base Color"])
    b.link(rough, bsdf.inputs["Roughness"])
    b.link(specular, bsdf.inputs["Specular IOR Level"])
    b.link(bump.outputs["Normal"], bsdf.inputs["Normal"])
    b.link(bsdf.outputs[0], out.inputs["Surface"])
    mat.diffuse_color = (*SKIN_RGB, 1.0)
    mat.roughness = 0.45


def skin():
    """The sample head's skin (see the module doc)."""
    return _material("Sample Skin", _build_skin)


def _build_eye(mat, b, out):
    d = _attribute(b, "ewrinkles_eye").outputs["Vector"]
    b.x, b.y = 200, 0
    x, y, z = b.separate(d)
    angle = b.math("ARCCOSINE", b.math("MINIMUM", b.math("MAXIMUM", z, -1.0), 1.0))  # from the gaze
    # Radial fibres: noise over the direction around the gaze, stretched along the radius.
    around = b.vmath("NORMALIZE", b.combine(x, y, 0.0))
    along = b.combine(0.0, 0.0, b.math("MULTIPLY", angle, 4.0))
    fibre_at = b.vmath("MULTIPLY_ADD", around, (7.0, 7.0, 7.0), along)
    fibres = b.node("ShaderNodeTexNoise", noise_dimensions="3D")
    b.link(fibre_at, fibres.inputs["Vector"])
    fibres.inputs["Scale"].default_value = 3.0
    fibres.inputs["Detail"].default_value = 6.0
    b.x, b.y = 500, 0
    iris = _mix_color(b, fibres.outputs["Fac"], (0.10, 0.05, 0.02), (0.42, 0.27, 0.10))
    ramp = b.node("ShaderNodeValToRGB")
    b.link(angle, ramp.inputs["Fac"])
    el = ramp.color_ramp.elements
    # the angle from the gaze (radians) -> 0 on the iris, 1 on the sclera
    el[0].position, el[0].color = 0.40, (0.0, 0.0, 0.0, 1.0)
    el[1].position, el[1].color = 0.44, (1.0, 1.0, 1.0, 1.0)
    limbus = b.math("MULTIPLY", b.math("SUBTRACT", 1.0, b.math("ABSOLUTE", b.math("MULTIPLY", b.math(
        "SUBTRACT", angle, 0.41), 28.0), clamp=True)), 0.8)
    pupil = b.math("SUBTRACT", 1.0, b.math("MULTIPLY", b.math("SUBTRACT", angle, 0.11), 40.0, clamp=True))
    color = _mix_color(b, ramp.outputs["Color"], iris, (0.78, 0.72, 0.66))
    color = _mix_color(b, b.math("MINIMUM", limbus, 1.0), color, (0.02, 0.015, 0.01))
    color = _mix_color(b, b.math("MAXIMUM", pupil, 0.0), color, (0.005, 0.005, 0.005))
    # The sclera reddens a little toward the corners of the eye.
    corner = b.math("MULTIPLY", b.math("SUBTRACT", angle, 0.9), 1.5, clamp=True)
    color = _mix_color(b, b.math("MULTIPLY", corner, 0.35), color, (0.7, 0.42, 0.38))
    bsdf = _principled(b, (0.78, 0.72, 0.66), 0.35, **{"Subsurface Weight": 0.25,
                                                       "Subsurface Radius": (1.0, 0.6, 0.5),
                                                       "Subsurface Scale": 0.001})
    b.link(color, bsdf.inputs["Base Color"])
    b.link(bsdf.outputs[0], out.inputs["Surface"])
    mat.diffuse_color = (0.78, 0.72, 0.66, 1.0)


def eye():
    """The eyeball: sclera, iris, limbus and pupil (see the module doc)."""
    return _material("Sample Eye", _build_eye)


def _film(ior, roughness, tint):
    def build(mat, b, out):
        fresnel = b.node("ShaderNodeFresnel")
        fresnel.inputs["IOR"].default_value = ior
        clear = b.node("ShaderNodeBsdfTransparent")
        clear.inputs["Color"].default_value = (*tint, 1.0)
        gloss = b.node("ShaderNodeBsdfGlossy", distribution="GGX")
        gloss.inputs["Roughness"].default_value = roughness
        b.link(fresnel.outputs["Fac"], gloss.inputs["Color"])
        b.x = 400
        wet = b.node("ShaderNodeAddShader")  # what is behind, plus the film's reflection
        b.link(clear.outputs[0], wet.inputs[0])
        b.link(gloss.outputs[0], wet.inputs[1])
        b.link(wet.outputs[0], out.inputs["Surface"])
        mat.diffuse_color = (0.9, 0.9, 0.9, 0.1)
        mat.use_transparent_shadow = True
        mat.surface_render_method = "BLENDED"
    return build


def cornea():
    """The eye's clear outer shell: the wet highlight over the iris and the sclera."""
    return _material("Sample Cornea", _film(1.376, 0.02, (1.0, 1.0, 1.0)))


def lacrimal():
    """The wet line where the lids meet the eye."""
    return _material("Sample Lacrimal Fluid", _film(1.336, 0.05, (0.97, 0.93, 0.92)))


def _plain(color, roughness, **inputs):
    def build(mat, b, out):
        bsdf = _principled(b, color, roughness, **inputs)
        b.link(bsdf.outputs[0], out.inputs["Surface"])
        mat.diffuse_color = (*color, 1.0)
    return build


LASHES_PER_UV = 260.0  # hairs per unit of the lash cards' U (along the lid)
LASH_BANDS = 6  # ICT's lash cards each take one sixth of V, from 0.01 to 0.15 of it


def _lash_builder(per_uv, root, tip_at_low_v):
    return lambda mat, b, out: _build_lashes(mat, b, out, per_uv, root, tip_at_low_v)


def _build_lashes(mat, b, out, per_uv, root, tip_at_low_v):
    """The lash cards cut into hairs: thin strands across each card (its U runs along the
    lid, its V along the hairs, each card in its own band of V), ``per_uv`` of them per unit
    of U, a little irregularly spaced, ``root`` hair spacings wide at the lid and tapering to
    nothing at the tip (at the band's low V for the lower lashes, which hang down); clear
    between."""
    uv = b.separate(b.node("ShaderNodeUVMap", uv_map="UVMap").outputs["UV"])
    jitter = b.node("ShaderNodeTexNoise", noise_dimensions="1D")
    b.link(b.math("MULTIPLY", uv[0], 40.0), jitter.inputs["W"])
    b.x = 200
    shift = b.math("MULTIPLY", jitter.outputs["Fac"], 1.5)
    phase = b.math("FRACT", b.math("MULTIPLY_ADD", uv[0], per_uv, shift))
    off = b.math("ABSOLUTE", b.math("SUBTRACT", phase, 0.5))
    band = b.math("FRACT", b.math("MULTIPLY", uv[1], float(LASH_BANDS)))  # 0.06 .. 0.9 on a card
    along = b.math("MULTIPLY", b.math("SUBTRACT", band, 0.06), 1.0 / 0.84, clamp=True)  # 0 .. 1
    if tip_at_low_v:
        along = b.math("SUBTRACT", 1.0, along)
    width = b.math("MULTIPLY", b.math("SUBTRACT", 1.0, along), root)  # from the root to the tip
    hair = b.math("SUBTRACT", 1.0, b.math("MULTIPLY", b.math("SUBTRACT", off, width), 30.0, clamp=True))
    b.x = 600
    bsdf = _principled(b, (0.012, 0.008, 0.006), 0.45)
    clear = b.node("ShaderNodeBsdfTransparent")
    mix = b.node("ShaderNodeMixShader")
    b.link(hair, mix.inputs["Fac"])
    b.link(clear.outputs[0], mix.inputs[1])
    b.link(bsdf.outputs[0], mix.inputs[2])
    b.link(mix.outputs[0], out.inputs["Surface"])
    mat.diffuse_color = (0.012, 0.008, 0.006, 1.0)
    mat.use_transparent_shadow = True


def lashes():
    """The upper lashes."""
    return _material("Sample Lashes", _lash_builder(LASHES_PER_UV, 0.22, False))


def lower_lashes():
    """The lower lashes: sparse, fine, hanging down from the lid."""
    return _material("Sample Lower Lashes", _lash_builder(0.12 * LASHES_PER_UV, 0.12, True))


def teeth():
    return _material("Sample Teeth", _plain((0.72, 0.66, 0.55), 0.25, **{
        "Subsurface Weight": 0.3, "Subsurface Radius": (1.0, 0.8, 0.6), "Subsurface Scale": 0.0005}))


def mouth():
    return _material("Sample Gums and Tongue", _plain((0.45, 0.11, 0.10), 0.3, **{
        "Subsurface Weight": 0.6, "Subsurface Radius": (2.0, 0.8, 0.5), "Subsurface Scale": 0.001}))
