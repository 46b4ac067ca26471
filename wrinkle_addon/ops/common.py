# SPDX-License-Identifier: GPL-3.0-or-later
"""What every operator shares: the face poll and the one error-report helper."""

import functools
import traceback

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
