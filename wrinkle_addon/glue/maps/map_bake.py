# SPDX-License-Identifier: GPL-3.0-or-later
"""Wrinkle maps and zone masks generated from the face itself.

* **Bake Wrinkle Map**: the wrinkle height W of the foundation's muscle model (Zhang 2005
  eq. 4, ``core.muscles.system.heights``) per vertex, rasterised in UV space and turned into a
  partial-derivative (PD) wrinkle map (Jimenez et al. 2011, §1.2) by ``core.raster``.
* **Generate Masks**: the 8 zone masks of §1.1 (Table 1.1's zones) from the muscles'
  wrinkling regions or from vertex groups, with soft borders, packed into two RGBA images.

Thin glue: the maths is in ``core/raster.py``.  Everything is computed and checked
before any image is created, so bad input creates nothing.
"""


import numpy as np

from ...core import mesh as core_mesh
from ...core import raster
from ...core.maps import jimenez, uvmaps
from ...core.muscles import system
from ...core.muscles.fields import muscle_field
from .. import faces, landmarks, meshio, registry, surface
from ..errors import WrinkleError
from ..muscles import muscle_objects

MODES = (
    ("MUSCLES", "Each Muscle Contracted",
     "Every muscle's wrinkles fully formed, on the rest face, joined as the face joins them: "
     "a catalogue of every wrinkle the muscles can make, each at full depth over its whole "
     "region, stronger than any one pose (bake a pose to match its geometric wrinkles)"),
    ("POSE", "Current Pose",
     "The wrinkles of the current frame: the deformed skin (shape keys, bones) and the "
     "muscles' current contractions, with slopes measured on the posed skin, so the map "
     "shades like the geometric wrinkles in this pose"),
)
MAP_RESOLUTIONS = tuple((str(r), f"{r} x {r}", f"Bake a {r} x {r} pixel map")
                        for r in (256, 512, 1024, 2048, 4096))
MASK_RESOLUTIONS = tuple((str(r), f"{r} x {r}", f"Masks of {r} x {r} pixels")
                         for r in (64, 128, 256, 512, 1024))
SOURCES = (
    ("MUSCLES", "Muscle Regions",
     "Each zone is the wrinkling region of the muscles of its role (Frontalis, Corrugator, "
     "Nasalis, Mentalis), on their side of the face"),
    ("VERTEX_GROUPS", "Vertex Groups",
     "Each zone is a vertex group of the face: by default 'Wrinkle Zone 1' to 'Wrinkle Zone 8'"),
)
DEFAULT_SOFTNESS = 0.01  # zone border width on the skin, in world units
DEFAULT_GROUPS = tuple(f"Wrinkle Zone {z + 1}" for z in range(jimenez.N_ZONES))


class MapBakeError(WrinkleError):
    """Bad input for a bake; the message is meant for the user."""


# --------------------------------------------------------------------------- reading the face
def _check_face(face):
    why = faces.problem(face, local=False, object_mode=True)
    if why:
        raise MapBakeError(why)


Surface, uv_layer = surface.Surface, surface.uv_layer  # the maps' callers use these names


def evaluated_skin(face, n, depsgraph=None):
    """:func:`glue.surface.evaluated_skin`, or MapBakeError when the modifiers remove vertices."""
    skin = surface.evaluated_skin(face, n, depsgraph)
    if skin is None:
        raise MapBakeError(f'The modifiers of "{face.name}" remove vertices: bake the current pose '
                        "with them disabled, or use Each Muscle Contracted")
    return skin


def _muscles(face, muscles):
    muscles = muscle_objects.live_muscles(face) if muscles is None else list(muscles)
    if not muscles:
        raise MapBakeError(f'"{face.name}" has no muscles: add muscles (Add Facial Muscle Set) first')
    return muscles


def bake_height(face, mode, muscles=None, surface=None):
    """Eq. 4's wrinkle height W (N,) float32 per vertex of ``face``, along the normal, in
    the face's local units; 0 outside the wrinkling regions.

    ``mode`` "MUSCLES": each muscle's fully formed wrinkle, ``H(w) At`` with ``A(eps) = 1``
    (``core.muscles.system.formed_together``): a wrinkle map holds the expression's
    wrinkles at full strength, and its animated zone weight plays the part of ``A(eps)``.  (Baking them from
    each muscle's own pull at full contraction gave ``A`` of only 0.15-0.3: the Frontalis
    pulls 8 %, while the ICT head's shape keys compress the forehead by up to 40 %.)  The
    muscles of one zone are joined as the face joins them, summed where their folds are one
    family's and blended where folds of two families cross, and each vertex keeps only the
    wrinkles of the muscles of its mask zone (:func:`bake_layers`).  Such a map holds every
    wrinkle the muscles can make, each at full depth over its whole region: stronger than
    any one pose, whose compression forms them only in part.  A map meant to look like an
    expression's geometric wrinkles is baked from that expression's pose ("POSE").
    "POSE": the current frame, the deformed skin (shape keys, bones) and the current
    contractions, exactly as the geometric wrinkles are evaluated (``A(eps)`` included).
    ``muscles``: the muscle objects, by default all the face's muscles.  The face's
    Strength scales both.  Raises MapBakeError.
    """
    fields, layer, _zone_of_layer = bake_layers(face, mode, muscles, surface)
    return np.take_along_axis(fields, layer[:, None], axis=1)[:, 0]


def bake_layers(face, mode, muscles=None, surface=None):
    """The heights of :func:`bake_height` as fields (V, L) float32, the field each vertex
    follows, ``layer`` (V,) int, and the mask zone of each field (L,) int (-1: none).

    "MUSCLES": one field per mask zone that occurs (:func:`muscle_zones`; vertices outside
    every zone form one more), the summed wrinkles of that zone's muscles over the whole
    face; each vertex follows its zone's.  So the map agrees with the generated masks and
    one expression's zone does not show another muscle's wrinkles (the Corrugator's
    furrows reach into the inner Frontalis' zone, where Surprise would show them).
    :func:`bake_wrinkle_map` joins the fields with :func:`layer_weights`.  "POSE": one
    field.
    """
    return _layers(face, mode, muscles, surface)[:3]


def _layers(face, mode, muscles=None, surface=None):
    """:func:`bake_layers` and the skin (V, 3) float32 to take the slopes on, in face-local
    units: the rest mesh for "MUSCLES" (its wrinkles belong to no one pose); for "POSE"
    the posed skin the geometric wrinkles are displaced from, the deformed skin plus the
    muscles' pull when the face shows it (Enable Wrinkles on)."""
    if mode not in ("MUSCLES", "POSE"):
        raise MapBakeError(f"Unknown bake mode {mode!r}")
    surface = surface or Surface(face, need_uv=False)
    rest = surface.rest
    muscles = muscle_objects.live_muscles(face) if muscles is None else list(muscles)
    skin = evaluated_skin(face, len(rest)) if mode == "POSE" else rest
    extra = _other_heights(face, surface, skin, formed=mode == "MUSCLES")
    if not muscles and extra is None:
        raise MapBakeError(f'"{face.name}" has no muscles and no wrinkle curves: add muscles (Add Facial '
                        "Muscle Set) or wrinkle curves first")
    core = [muscle_objects.to_core(m, face) for m in muscles]
    strength = float(face.ewrinkles_face.strength)
    plan = system.build_plan(rest, surface.edges, surface.tris, core,
                             keep_out=landmarks.keep_out(face, rest)) if muscles else None
    extra = np.zeros(len(rest), np.float32) if extra is None else extra
    if mode == "POSE":
        contraction = np.array([m.ewrinkles_muscle.contraction for m in muscles], np.float64)
        h = system.heights(plan, skin, contraction, strength) + extra if muscles else extra
        if face.ewrinkles_face.enabled and muscles:  # the face shows the pull (strength 0: the pull alone)
            skin = skin + system.evaluate(plan, skin, contraction, 0.0)
        skin = np.where(np.isfinite(skin), skin, rest).astype(np.float32)
        return np.asarray(h, np.float32)[:, None], np.zeros(len(rest), np.int64), np.array([-1]), skin
    zone = _vertex_zone(face, surface, muscles) if muscles else np.full(len(rest), -1)
    present, layer = np.unique(zone, return_inverse=True)
    layer = layer.ravel()
    fields = np.zeros((len(rest), len(present)), np.float32)
    for k, z in enumerate(present):  # each zone's muscles together: crossing folds blended
        own = [i for i, ob in enumerate(muscles) if z in _zones_of(ob)]
        if own:
            fields[:, k] = system.formed_together(plan, own, strength)
    fields[np.arange(len(rest)), layer] += extra  # the other sources' wrinkles, in each vertex's zone
    return fields, layer, present, rest


def _other_heights(face, surface, skin, formed):
    """The summed heights (N,) of the other geometric wrinkle sources (the wrinkle curves),
    or None if none has any (``WrinkleSource.map_heights``)."""
    mesh = registry.MeshArrays(surface.rest, surface.edges, surface.tris)
    total = None
    for source in registry.sources():
        if not source.geometric or not source.active(face):
            continue
        try:
            h = source.map_heights(face, mesh, skin, formed)
        except WrinkleError as exc:
            raise MapBakeError(str(exc)) from None
        if h is not None:
            total = h if total is None else total + h
    return total


def layer_weights(surface, layer, zone_of_layer, softness):
    """Soft weights (V, L) of the fields of :func:`bake_layers`, rows summing to 1, so the
    smooth slopes pass from one zone's wrinkles to the next over the masks' soft border
    (cutting the heights at the zone border put a streak of steep slopes along it).

    Each vertex's layer is softened over ``softness`` (face-local units) exactly as
    Generate Masks softens the zones, giving memberships ``m_l`` (rows summing to 1:
    ``soften`` divides rows summing to more than 1 by their sum, and the diffusion keeps
    rows summing to 1 and only scales each layer up).  The weights are ``m_l^2 / sum m^2``.
    Where two zones' masks overlap, one map must serve both: an expression that lights
    zone l alone shows ``m_l M`` where it wants ``m_l g_l``, and the map ``M`` that makes
    ``sum_l (m_l |M - g_l|)^2`` least is ``sum_l m_l^2 g_l / sum_l m_l^2``.  Weights ``m_l``
    themselves let the Corrugator's frown lines show through Surprise on the inner
    forehead, and the Frontalis' furrows through Anger between the brows: on the ICT head
    the shown slopes were 16 % off the zones' own for Surprise and 47 % for Anger, against
    14 % and 38 % with these weights (Joy 19 % and 12 %; Fear 19 % and 20 %).
    """
    if len(zone_of_layer) == 1:
        return np.ones((len(layer), 1))
    one_hot = (layer[:, None] == np.arange(len(zone_of_layer))).astype(np.float64)
    m = np.asarray(_soften(surface, one_hot, zone_of_layer[layer] >= 0, softness), np.float64) ** 2
    total = m.sum(axis=1, keepdims=True)
    return np.where(total > 0, m / np.where(total > 0, total, 1.0), one_hot)


def _soften(surface, memberships, inside, softness):
    """``core.raster.soften`` of per-vertex memberships over ``softness`` (face-local
    units), the diffusion measured by the median edge among the ``inside`` vertices."""
    edge = _median_edge(surface.rest, surface.edges, inside)
    try:
        t = raster.diffusion_time(float(softness), edge)
    except ValueError as exc:  # a softness of NaN, or of a million edges
        raise MapBakeError(f"The zone borders cannot be softened: {exc}") from None
    return raster.soften(memberships, surface.edges, t)


def _zones_of(ob):
    """The mask zones a muscle object wrinkles ((-1,): none, like the vertices outside)."""
    s = ob.ewrinkles_muscle
    pair = jimenez.ZONE_OF_ROLE.get(s.role)
    if pair is None:
        return (-1,)
    return {"L": (pair[0],), "R": (pair[1],)}.get(s.side, pair)


def _vertex_zone(face, surface, muscles):
    """The mask zone of every vertex (V,) int, -1 outside every zone."""
    try:
        zones = muscle_zones(face, surface, muscles)
    except MapBakeError:  # no muscle has a zone: nothing to keep apart
        return np.full(len(surface.rest), -1)
    return np.where(zones.max(axis=1) > 0, zones.argmax(axis=1), -1)


def _padding(resolution):
    """Edge padding in pixels: 1/128 of the width, at least 2."""
    return max(2, int(resolution) // 128)


def _start(face, resolution, uv_map, progress):
    """The checked resolution, the progress callback and the face's :class:`Surface`."""
    R = int(resolution)
    if not 1 <= R <= 16384:
        raise MapBakeError(f"Resolution {R} is out of range (1-16384)")
    step = progress or (lambda _f, _m: None)
    step(0.0, "reading the mesh")
    return R, step, Surface(face, uv_map)


def bake_wrinkle_map(face, resolution, mode, uv_map=None, muscles=None, progress=None, smooth=True):
    """The PD wrinkle map (R, R, 4) float32 of ``face`` (see :func:`bake_height` for
    ``mode`` and ``muscles``; ``core.raster.slopes`` for the formula).  The slopes are in
    the tangent space of ``uv_map`` (empty: see :func:`uv_layer`) on the rest mesh for
    "MUSCLES" and on the posed skin for "POSE" (:func:`_layers`), in world lengths
    (``core.raster.to_world``: the object's scale, even non-uniform).  The Normal Map
    node takes its tangents from the mesh it shades, the posed one: slopes of the rest
    layout came out turned and too small where the pose compresses the skin (38 % too small
    and turned by 14 degrees on the test patch squashed to 70 %).
    ``smooth``: slopes from vertex gradients interpolated over the triangles, like smooth
    shading of the geometric wrinkles; else finite differences per pixel, which show the
    triangles as facets.  ``progress(fraction, message)`` is called between the steps.
    Raises MapBakeError."""
    R, step, surface = _start(face, resolution, uv_map, progress)
    step(0.05, "wrinkle heights")
    fields, layer, zone_of_layer, skin = _layers(face, mode, muscles, surface)
    try:  # in world lengths: a non-uniform object scale changes the slopes
        rest, fields = raster.to_world(skin, surface.tris, fields, face.matrix_world.to_3x3())
    except ValueError as exc:
        raise MapBakeError(f'"{face.name}": {exc}; give it a scale to bake') from None
    step(0.3, f"rasterising {R} x {R}")
    uv, tris = surface.uv, surface.tris
    if smooth:  # the masks' default border, converted to face-local units like the operator's
        softness = DEFAULT_SOFTNESS / muscle_objects.face_scale(face)
        weights = layer_weights(surface, layer, zone_of_layer, softness)
        pd = uvmaps.pd_map(uv, rest[tris], fields[tris], R, smooth=True, verts=tris, padding=_padding(R),
                           weights=weights)
    else:  # per-pixel differences need one height: the zones' fields cut together
        h = np.take_along_axis(fields, layer[:, None], axis=1)[:, 0]
        pd = uvmaps.pd_map(uv, rest[tris], h[tris], R, islands=raster.uv_islands(uv, tris),
                           padding=_padding(R))
    step(0.9, "storing the image")
    return pd


# --------------------------------------------------------------------------- zone memberships
def _median_edge(rest, edges, verts_mask=None):
    if len(edges) == 0:
        return 0.0
    if verts_mask is not None:
        sel = verts_mask[edges].any(axis=1)
        if sel.any():
            edges = edges[sel]
    return float(np.median(core_mesh.edge_lengths(rest.astype(np.float64), edges)))


def muscle_zones(face, surface=None, muscles=None):
    """Raw zone memberships (V, 8) in [0, 1] from the muscles' wrinkling regions.

    A muscle's membership is its wrinkling region S_w (Zhang eqs. 3/14) weighted by its
    amplitude envelope, normalised to a maximum of 1.  The amplitude ``H(w) At`` changes
    sign twice per wrinkle cycle, so its envelope is taken as the largest ``|H(w) At|``
    within one half cycle ``u`` (a max-filter on the mesh, restricted to the region):
    that keeps the fall-off across the sheet (``At``) and at the ends, without stripes.
    The zone of a muscle comes from its role and side (``jimenez.ZONE_OF_ROLE``; a
    centre muscle fills the left zone on +X and the right one on -X); a zone takes the
    largest membership of its muscles, and each vertex keeps only the zone whose muscle
    has the largest envelope there.
    Raises MapBakeError if no muscle has a role with a zone.
    """
    surface = surface or Surface(face, need_uv=False)
    muscles = _muscles(face, muscles)
    rest = surface.rest
    n = len(rest)
    zones = np.zeros((n, jimenez.N_ZONES), np.float32)
    raw = np.zeros((n, jimenez.N_ZONES), np.float32)
    keep = landmarks.keep_out(face, rest)  # no zone reaches an eyelid or a lip
    used = 0
    for ob in muscles:
        s = ob.ewrinkles_muscle
        pair = jimenez.ZONE_OF_ROLE.get(s.role)
        if pair is None:
            continue
        targets = {"L": (pair[0],), "R": (pair[1],)}.get(s.side, tuple(set(pair)))
        f = muscle_field(rest, muscle_objects.to_core(ob, face))
        if len(f.region) == 0:
            continue
        amp = np.zeros(n)
        amp[f.region] = np.abs(f.amplitude)
        if keep is not None:
            amp *= keep
        in_region = np.zeros(n, bool)
        in_region[f.region] = True
        hops = int(np.ceil(f.half_cycle / max(_median_edge(rest, surface.edges, in_region), 1e-12)))
        env = raster.dilate_max(amp, surface.edges, min(hops, 64), inside=in_region)
        top = env.max()
        if top <= 0:
            continue
        used += 1
        if len(targets) == 2:  # a centre muscle with a left and a right zone: split at x = 0
            left = rest[:, 0] >= 0.0  # the character's left is +X
            zones[:, pair[0]] = np.maximum(zones[:, pair[0]], np.where(left, env / top, 0.0))
            zones[:, pair[1]] = np.maximum(zones[:, pair[1]], np.where(left, 0.0, env / top))
            raw[:, pair[0]] = np.maximum(raw[:, pair[0]], np.where(left, env, 0.0))
            raw[:, pair[1]] = np.maximum(raw[:, pair[1]], np.where(left, 0.0, env))
            continue
        for z in targets:
            zones[:, z] = np.maximum(zones[:, z], env / top)
            raw[:, z] = np.maximum(raw[:, z], env)
    if used == 0:
        raise MapBakeError(f'No muscle of "{face.name}" wrinkles a mask zone: the zones come from '
                        "the Frontalis, Corrugator, Nasalis and Mentalis roles (Add Facial Muscle Set)")
    # The paper's zones are disjoint parts of the face; muscle regions overlap (the
    # Corrugator's lies inside the inner Frontalis'), and sharing an overlap between zones
    # left the brows at a third of their weight on the ICT head.  So each vertex goes to
    # one zone alone, the one whose muscle wrinkles it most (the raw envelope: normalised
    # per muscle, the broad Frontalis took all but 56 of the Corrugator's vertices and
    # Anger's frown lines vanished); the soft borders are made afterwards.
    strongest = raw.argmax(axis=1)
    return np.where(np.arange(jimenez.N_ZONES) == strongest[:, None], zones, 0.0).astype(np.float32)


def _parse_groups(group_names):
    names = [g.strip() for g in (group_names or "").split(",")]
    if not any(names):
        return list(DEFAULT_GROUPS)
    names = (names + [""] * jimenez.N_ZONES)[: jimenez.N_ZONES]
    return names


def group_zones(face, group_names=None):
    """Raw zone memberships (V, 8) from 8 vertex groups, and the names not found.

    ``group_names``: comma-separated names in zone order (empty: "Wrinkle Zone 1" to
    "Wrinkle Zone 8"); an empty entry skips its zone.  Raises MapBakeError if none exists."""
    _check_face(face)
    names = _parse_groups(group_names)
    index = {}
    missing = []
    for z, name in enumerate(names):
        if not name:
            continue
        vg = face.vertex_groups.get(name)
        if vg is None:
            missing.append(name)
        else:
            index[vg.index] = index.get(vg.index, ()) + (z,)
    if not index:
        wanted = ", ".join(f'"{n}"' for n in names if n)
        raise MapBakeError(f'"{face.name}" has none of the vertex groups {wanted}')
    vert, group, weight = meshio.vertex_group_weights(face.data, index.keys())
    zones = np.zeros((len(face.data.vertices), jimenez.N_ZONES), np.float32)
    for gi, zs in index.items():
        sel = group == gi
        for z in zs:
            zones[vert[sel], z] = weight[sel]
    return zones, missing


def generate_masks(face, resolution, source, softness, uv_map=None, group_names=None, progress=None):
    """The two RGBA zone masks (R, R, 4) float32 each (``core.maps.uvmaps.mask_images``) and a
    list of notes for the user.  ``softness``: the width of the zone borders, in the face's
    local units (see ``core.raster.diffusion_time``).  Raises MapBakeError."""
    R, step, surface = _start(face, resolution, uv_map, progress)
    notes = []
    if source == "MUSCLES":
        zones = muscle_zones(face, surface)
    elif source == "VERTEX_GROUPS":
        zones, missing = group_zones(face, group_names)
        if missing:
            notes.append("Vertex groups not found (their zones stay empty): " + ", ".join(missing))
    else:
        raise MapBakeError(f"Unknown mask source {source!r}")
    step(0.4, "soft borders")
    soft = _soften(surface, zones, zones.max(axis=1) > 0, softness)
    step(0.7, f"rasterising {R} x {R}")
    a, b = uvmaps.mask_images(surface.uv, soft[surface.tris], R, padding=max(2, R // 64))
    return a, b, notes
