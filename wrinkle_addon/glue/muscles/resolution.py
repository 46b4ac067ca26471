# SPDX-License-Identifier: GPL-3.0-or-later
"""The muscles' rule for Refine Wrinkling Regions (``glue/refine.py``): the edges longer than
their half cycles allow (``core.muscles.resolution``), off the eyelids and lips."""

from ...core.muscles import resolution
from .. import landmarks
from . import muscle_objects


def refine_need(face, factor, muscles=None):
    """A callable ``(rest, edges) -> indices`` of the edges on which every half cycle of
    ``muscles`` (default: the face's live muscles) would span fewer than ``factor`` edges,
    or None when there are no muscles."""
    muscles = muscle_objects.live_muscles(face) if muscles is None else list(muscles)
    if not muscles:
        return None
    core = [muscle_objects.to_core(m, face) for m in muscles]

    def need(rest, edges):
        return resolution.refine_edges(rest, edges, core, factor, landmarks.keep_out(face, rest))

    return need
