# SPDX-License-Identifier: GPL-3.0-or-later
"""The batch command ``ewrinkles``, registered as a Blender command-line command:

    blender -b -c ewrinkles render SHOT.blend --frames 1-48 --out DIR
    blender -b -c ewrinkles bake SHOT.blend
    blender -b -c ewrinkles check SHOT.blend
    blender -b -c ewrinkles sheet DIR
    blender -b -c ewrinkles export SHOT.blend --format gltf|usd|package --out PATH

and, with the pip ``bpy`` module, ``python -m wrinkle_addon.cli render ...`` (``__main__``).
The commands themselves are in ``commands``; this module turns their outcome into an exit
code and one line on stderr.
"""

import sys
import traceback

import bpy

from .args import FAILED, STOPPED, USAGE, UsageError, parse

COMMAND = "ewrinkles"
_handle = [None]


def execute(argv):
    """Run one command line (the arguments after ``ewrinkles``); returns the exit code."""
    from ..glue import progress
    from . import commands

    progress.stream[0] = sys.stderr  # stdout is for results (--json, check's report)
    try:
        ns = parse(argv)
        return commands.COMMANDS[ns.command](ns)
    except UsageError as exc:
        commands.say(str(exc))
        return USAGE
    except SystemExit as exc:  # --help
        return exc.code if isinstance(exc.code, int) else 0
    except KeyboardInterrupt:
        commands.say("stopped by Ctrl-C")
        return STOPPED
    except Exception as exc:  # a bug: the traceback for the report, one line for the user
        traceback.print_exc()
        commands.say(f"internal error: {exc!r}")
        return FAILED
    finally:
        progress.stream[0] = None
        sys.stdout.flush()
        sys.stderr.flush()


def register():
    if hasattr(bpy.utils, "register_cli_command"):  # Blender 4.2 and later
        _handle[0] = bpy.utils.register_cli_command(COMMAND, execute)


def unregister():
    if _handle[0] is not None:
        bpy.utils.unregister_cli_command(_handle[0])
        _handle[0] = None
