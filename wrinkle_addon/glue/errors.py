# SPDX-License-Identifier: GPL-3.0-or-later
"""The one base class of the problems a user must fix.

Every message is written for the artist and shown as is (an ERROR report, a panel line).
Anything else that goes wrong is a bug: the operators print its traceback to the console
and report a short line (``ops.common.guarded``).
"""


class WrinkleError(Exception):
    """A problem the user must fix; the message is shown as is."""
