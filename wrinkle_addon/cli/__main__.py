# SPDX-License-Identifier: GPL-3.0-or-later
"""``python -m wrinkle_addon.cli <command> ...``: the batch command with the pip ``bpy``
module (scripts, CI), the same entry point as ``blender -b -c ewrinkles <command> ...``.

The process ends with ``os._exit``: bpy 4.5 can hang at interpreter exit (after a
Python-function driver ran), so the exit code must not depend on a clean shutdown.
"""

import os
import sys


def main():
    import wrinkle_addon

    wrinkle_addon.register()
    from wrinkle_addon.cli import execute

    code = execute(sys.argv[1:])
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


if __name__ == "__main__":
    main()
