# SPDX-License-Identifier: GPL-3.0-or-later
"""What every operator shares: the face poll and the one error-report helper."""

import contextlib
import functools
import traceback

import bpy

from ..glue import faces
from ..glue.errors import WrinkleError


def face_ok(cls, context, **needs):
    """Whether the active face passes :func:`glue.faces.problem` with ``needs``; otherwise
    the reason becomes the poll message (the disabled button's tooltip).  For polls that
    check more than the face."""
    why = faces.problem(faces.active(context), **needs)
    if why:
        cls.poll_message_set(why)
        return False
    return True


def face_poll(**needs):
    """A ``poll`` classmethod that checks only the face (:func:`face_ok`)."""
    return classmethod(lambda cls, context: face_ok(cls, context, **needs))


def select_only(context, ob):
    """Make ``ob`` the only selected object and the active one (a newly added muscle or
    curve, ready to edit)."""
    for o in context.selected_objects:
        o.select_set(False)
    ob.select_set(True)
    context.view_layer.objects.active = ob


# What an operator of ours can make, in the order they are removed (objects before their data).
_MADE = ("objects", "meshes", "curves", "collections", "materials", "node_groups", "images")


@contextlib.contextmanager
def nothing_left_on_failure():
    """Run the block; if it raises, remove every object, mesh, curve, collection, material,
    node group and image made inside it, then let the error go on (to :func:`guarded`).  A
    failed Add leaves nothing behind; what existed before the block is never touched."""
    before = {kind: {idb.session_uid for idb in getattr(bpy.data, kind)} for kind in _MADE}
    try:
        yield
    except BaseException:
        for kind in _MADE:
            ids = getattr(bpy.data, kind)
            for idb in [i for i in ids if i.session_uid not in before[kind]]:
                ids.remove(idb)
        raise


def guarded(execute):
    """Wrap an operator's ``execute``: a :class:`WrinkleError` becomes an ERROR report with
    its message; anything unexpected prints its traceback to the console and reports one
    short line.  Either way the operator is cancelled and nothing is left half done by
    the wrapper itself."""

    @functools.wraps(execute)
    def run(self, context):
        try:
            return execute(self, context)
        except WrinkleError as exc:
            self.report({"ERROR"}, str(exc))
        except Exception as exc:  # a bug: the user gets a line, the console the details
            traceback.print_exc()
            self.report({"ERROR"}, f"{self.bl_label} failed unexpectedly ({type(exc).__name__}: {exc}); "
                                   "the details are in the system console")
        return {"CANCELLED"}

    return run
