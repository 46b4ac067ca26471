# SPDX-License-Identifier: GPL-3.0-or-later
"""The wrinkle-source contract and the live list of sources.

A **wrinkle source** is one method of making wrinkles.  The frame stage, the farm bake
and the panel loop over :func:`sources`; none of them names a method.  The list is filled
by ``sources/__init__.py`` (one line per method) when the add-on registers; a test can
:func:`add` a source of its own and :func:`remove` it again.

Per frame, for each face, the stage (``glue/pipeline.py``) reads the deformed skin once,
asks every active source for its :class:`~..core.combine.Contribution`, sums the
geometric ones through ``core.combine`` and writes the result once, then writes the
shading values.
"""

import contextlib

from ..core import combine


class MeshArrays:
    """The face's rest mesh as the stage caches it: ``rest`` (N, 3) float32, ``edges``
    (E, 2) int32, ``tris`` (T, 3) int64.  Shared read-only by every source."""

    __slots__ = ("rest", "edges", "tris")

    def __init__(self, rest, edges, tris):
        self.rest, self.edges, self.tris = rest, edges, tris


class WrinkleSource:
    """The contract.  Subclass it, override what applies, and add one line to
    ``sources/__init__.py``.

    * ``name``: a unique id (the status channel, the panel section); ``label``: its heading.
    * ``geometric``: the source moves the skin (offsets and heights), so it runs only on
      faces with wrinkles enabled (the *Wrinkles* modifier); otherwise it gives only
      shading values and runs on any face it is :meth:`active` on.
    * ``properties``: ``((attribute, PropertyGroup class), ...)`` hung on the face's
      settings (``Object.ewrinkles_face.<attribute>``) while the source is registered
      (``sources.add``).
    * ``reads_pull``: Blender computes the source's values itself, in a Geometry Nodes tree
      above the Wrinkles modifier that measures the skin plus the tangential offsets of the
      sources before it (``glue.stage.PULL_ATTR``).  The stage then writes that pull with
      the offsets.  On a viewport frame written in place the tree has measured the skin
      without that frame's pull (it sees one only in the original mesh): the stage then asks
      the source to :meth:`write_pulled` its values into the evaluated mesh, and writes the
      frame back into the original mesh when it cannot.
    * ``per_frame``: False when the source computes nothing per frame (Blender does, in the
      face's modifiers): on a viewport frame that leaves its static data as it is
      (:meth:`unchanged`), the stage does not visit a face on which only such sources are
      active.  Renders, exports, edits and saving still check everything.
    """

    name = ""
    label = ""
    geometric = True
    properties = ()
    reads_pull = False
    per_frame = True

    # --- per frame -------------------------------------------------------------------
    def active(self, face):
        """Whether the source has work on ``face`` this frame (cheap: every frame)."""
        return False

    def static_key(self, face, in_scene):
        """A value that changes whenever :meth:`build`'s result would (cheap: every frame).
        ``in_scene``: the ``session_uid`` of every object of the scene."""
        return None

    def unchanged(self, face, static, changes, in_scene):
        """True when the IDs Blender updated this frame cannot have changed the static data,
        so :meth:`static_key` need not be computed.  ``changes``: ``session_uid`` ->
        ``(transform, geometry)`` flags of every updated ID (viewport frames only); a
        deleted object is in none of them, so check ``in_scene`` too.  Default: always
        check the key."""
        return False

    def build(self, face, mesh, in_scene):
        """The static data (anything) for ``face`` and its :class:`MeshArrays` ``mesh``.  A
        geometric source's static data has a ``footprint`` (``core.combine.Footprint``)."""
        return None

    def inputs(self, face, static):
        """The frame's inputs besides the skin (e.g. contractions), read once per frame and
        handed to :meth:`contribute`; compared with ``==`` to skip unchanged frames.
        Default: none."""
        return ()

    def contribute(self, face, static, skin, inputs):
        """This frame's :class:`core.combine.Contribution` for the skin ``skin`` (N, 3) and
        this frame's ``inputs`` (what :meth:`inputs` returned)."""
        return combine.Contribution()

    def write_pulled(self, face, static, ev, pulled):
        """For a ``reads_pull`` source, on a viewport frame written in place: write into the
        evaluated mesh ``ev`` the values its tree computes from the pulled skin ``pulled``
        (N, 3), exactly as the tree would.  Returns whether it wrote them; when False the
        stage writes the frame back into the original mesh, where the tree sees the pull."""
        return False

    def write_shading(self, face, static, name, values):
        """Write one of the contribution's ``shading`` values (its ``attributes`` are
        written by the stage as point attributes)."""

    def map_heights(self, face, mesh, skin, formed):
        """This source's heights (N,) along the normal for a baked wrinkle map (the maps'
        Bake Wrinkle Map), or None if it has none.  ``formed``: the wrinkles fully formed
        (the map's animated zone weights play the part of their amplitude), else those of
        this frame on the posed ``skin`` (N, 3).  The muscles are baked by the maps
        themselves, zone by zone; other geometric sources add theirs here."""
        return None

    def problems(self, face, static):
        """A message for the panel about the static data (e.g. a muscle without effect)."""
        return ""

    # --- Refine Wrinkling Regions -----------------------------------------------------------
    def refine_need(self, face, factor, scene):
        """What this source asks of Refine Wrinkling Regions (``glue.refine``): a callable
        ``(rest (N, 3), edges (E, 2)) -> indices`` of the edges to split, asked again after
        every pass, or None when it asks for nothing.  ``factor``: the operator's edges per
        half cycle.  The operator splits the union of every source's edges."""
        return None

    # --- farm bake ---------------------------------------------------------------------
    def bake(self, face, scene, frame_start, frame_end, progress):
        """Bake what a farm without the add-on cannot compute and the geometry cache does not
        hold (the stage's Alembic cache holds every geometric contribution).  Returns a
        line for the report, or ""."""
        return ""

    def bakes(self, face):
        """Whether :meth:`bake` has anything to do on ``face``."""
        return False

    def check(self, face, scene, frame_start, frame_end):
        """Why :meth:`bake` cannot run on ``face`` now (a message for the artist), or "".
        Bake for Farm asks every source that :meth:`bakes` before it changes anything, so a
        bake either runs whole or refuses with every reason."""
        return ""

    def has_bake(self, face):
        """Whether ``face`` holds a bake of this source that :meth:`free_bake` can undo."""
        return False

    def free_bake(self, face):
        """Undo :meth:`bake`."""

    def skin_handed_over(self, old, new):
        """Bake for Farm hands a face's evaluated skin to its stand-in (``old`` the face,
        ``new`` the stand-in, which holds the baked wrinkles), and Free Bake hands it back:
        make what this method has following ``old``'s skin follow ``new``'s (the shedding
        tears).  Called on every registered source, active or not.  Default: nothing."""

    def exporting(self, face):
        """A context manager around the Alembic export of Bake for Farm: what the source
        changes on ``face`` for the cache to carry its values (and undoes after).  Default:
        nothing."""
        return contextlib.nullcontext()

    # --- files of older versions -------------------------------------------------------
    def upgrade(self, face):
        """Bring what an older version of the add-on stored on the mesh object ``face`` up to
        date (on every file load, and when the add-on is enabled with a file open).  Returns
        a line for the console when it changed something, else ""."""
        return ""

    # --- panel -------------------------------------------------------------------------
    def draw(self, layout, context, face):
        """Draw the source's part of the face panel."""


_sources = []


def sources():
    return tuple(_sources)


def add(source):
    """Put ``source`` in the list.  Raises ValueError on a duplicate name.  (``sources.add``
    also registers its face properties.)"""
    if any(s.name == source.name for s in _sources):
        raise ValueError(f"a wrinkle source named {source.name!r} is already registered")
    _sources.append(source)


def upgrade_all(data):
    """Every source's :meth:`upgrade` on every local mesh object of ``data``; a line on the
    console for each change, and for each failure (the file opens whatever happens)."""
    for ob in data.objects:
        if ob.type != "MESH" or ob.library is not None:
            continue
        for source in _sources:
            try:
                line = source.upgrade(ob)
            except Exception as exc:  # a file must open whatever it holds
                line = f"could not bring {source.label or source.name} up to date: {exc}"
            if line:
                print(f"Expression Wrinkles: {ob.name}: {line}")


def remove(source):
    if source in _sources:
        _sources.remove(source)
