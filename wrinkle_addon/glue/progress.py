# SPDX-License-Identifier: GPL-3.0-or-later
"""The one progress helper: the window manager's progress in the interface, and a line per
step on the console in background mode (batch jobs, farms)."""

import sys

import bpy

# Where background-mode progress lines go (None: stdout).  The batch command sets stderr,
# so that its stdout holds only its JSON lines.
stream = [None]


class Progress:
    """``with Progress(context, "Bake Wrinkle Map") as p: p(0.5, "rasterising")``.

    Call it with a fraction in [0, 1] (or a step and ``total``) and a message.  In
    background mode each call prints ``Expression Wrinkles: <title>: 50% <message>``,
    at most one line per ``every`` steps when ``total`` is given.
    """

    def __init__(self, context, title, total=None, every=1):
        self.wm = context.window_manager if context is not None else None
        self.title = title
        self.total = total
        self.every = max(1, int(every))

    def __enter__(self):
        if self.wm is not None:
            self.wm.progress_begin(0, 100)
        return self

    def __exit__(self, *exc):
        if self.wm is not None:
            self.wm.progress_end()
        return False

    def __call__(self, done, message=""):
        fraction = done / self.total if self.total else done
        if self.wm is not None:
            self.wm.progress_update(int(100 * fraction))
        quiet = self.total and done % self.every and done != self.total
        if bpy.app.background and not quiet:
            step = f" {done}/{self.total}" if self.total else ""
            print(f"Expression Wrinkles: {self.title}:{step} {int(100 * fraction):3d}% {message}".rstrip(),
                  flush=True, file=stream[0] or sys.stdout)
