"""A stand-in for the `blender` executable, for the farm job tests: Blender's own command line
replayed on the pip ``bpy`` module, which has no executable.

Only what the farm jobs in ``farm/`` use, processed left to right as Blender does:
``-b``, ``-y``, ``--factory-startup``, a .blend file (opened), ``--python-expr``,
``--python``, ``--python-exit-code``, ``--python-use-system-env`` (the module's interpreter
reads ``PYTHONPATH`` anyway), ``-o``/``--render-output``, ``-F``/``--render-format``,
``-x``/``--use-extension``, ``-E``/``--engine``, ``-s``, ``-e``, ``-a`` and ``-f``/``--render-frame``
(``1,3,5..8``), ``--`` (the rest is for scripts), and ``-c ewrinkles ARGS...``.

``-c``: Blender runs the command an installed extension registered.  This module has no
installed extensions: with ``EWRINKLES_ADDON_ROOT`` set (the folder holding
``wrinkle_addon``) it registers the add-on from there and hands the arguments to the
command's function, ``wrinkle_addon.cli.execute``, as Blender does; without it, ``-c``
fails as Blender's does for an unknown command.  Everything else runs with no add-on at all,
so a render through this module is a farm's render without the add-on.

Run as ``python bpy_blender.py ARGS...``; a one-line shell wrapper makes it a `blender`.
"""

import os
import sys


def _frames(text):
    out = []
    for part in text.split(","):
        a, dots, b = part.partition("..")
        out.extend(range(int(a), int(b) + 1) if dots else [int(a)])
    return out


def _render(bpy, frames):
    scene = bpy.context.scene
    for f in frames:
        scene.frame_start = scene.frame_end = f
        bpy.ops.render.render(animation=True)


def main(argv):
    import bpy

    python_exit_code = 0
    i = 0
    while i < len(argv):
        arg = argv[i]
        nxt = argv[i + 1] if i + 1 < len(argv) else None
        scene = bpy.context.scene
        if arg in ("-b", "--background", "-y", "--enable-autoexec"):
            pass
        elif arg == "--factory-startup":  # the module loads no user settings or add-ons anyway
            pass
        elif arg == "--python-use-system-env":
            pass
        elif arg == "--":
            break
        elif arg == "-c":
            root = os.environ.get("EWRINKLES_ADDON_ROOT")
            if nxt != "ewrinkles" or not root:
                print(f"Error: no command named {nxt!r}", file=sys.stderr)
                return 1
            sys.path.insert(0, root)
            import wrinkle_addon

            wrinkle_addon.register()
            from wrinkle_addon.cli import execute

            return execute(argv[i + 2:])
        elif arg == "--python-exit-code":
            python_exit_code = int(nxt)
            i += 1
        elif arg == "--python-expr" or arg == "--python":
            try:
                code = nxt if arg == "--python-expr" else open(nxt).read()
                name = "<expr>" if arg == "--python-expr" else nxt
                exec(compile(code, name, "exec"), {"__name__": "__main__"})
            except Exception:
                import traceback

                traceback.print_exc()
                if python_exit_code:
                    return python_exit_code
            i += 1
        elif arg in ("-o", "--render-output"):
            scene.render.filepath = nxt if "#" in nxt else nxt + "####"
            i += 1
        elif arg in ("-F", "--render-format"):
            scene.render.image_settings.file_format = {"EXR": "OPEN_EXR"}.get(nxt, nxt)
            i += 1
        elif arg in ("-x", "--use-extension"):
            scene.render.use_file_extension = nxt == "1"
            i += 1
        elif arg in ("-E", "--engine"):
            scene.render.engine = nxt
            i += 1
        elif arg in ("-s", "--frame-start"):
            scene.frame_start = int(nxt)
            i += 1
        elif arg in ("-e", "--frame-end"):
            scene.frame_end = int(nxt)
            i += 1
        elif arg in ("-a", "--render-anim"):
            bpy.ops.render.render(animation=True)
        elif arg in ("-f", "--render-frame"):
            _render(bpy, _frames(nxt))
            i += 1
        elif arg.endswith(".blend"):
            bpy.ops.wm.open_mainfile(filepath=arg, load_ui=False)
        else:
            print(f"Error: this stand-in does not know the argument {arg!r}", file=sys.stderr)
            return 1
        i += 1
    return 0


if __name__ == "__main__":
    code = main(sys.argv[1:])
    # for the tests: whether this process ran with the add-on
    print(f"bpy_blender: add-on loaded: {'wrinkle_addon' in sys.modules}", file=sys.stderr)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)  # bpy 4.5 can hang at interpreter exit; the code must not depend on it
