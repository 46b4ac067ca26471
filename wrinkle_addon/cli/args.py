# SPDX-License-Identifier: GPL-3.0-or-later
"""The batch command's arguments: the parser, frame ranges and chunks.  Pure Python: no
Blender, so it is tested in the fast tier."""

import argparse
import math

# The exit codes of `ewrinkles` (README, "The batch command and render farms")
OK, FAILED, USAGE, NOT_READY, STOPPED = 0, 1, 2, 3, 130


class UsageError(Exception):
    """A mistake in the command line or its input files: exit 2 with this one line."""


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # argparse would print the usage and exit the process
        raise UsageError(f"{self.prog}: {message} (see {self.prog} --help)")

    def exit(self, status=0, message=None):  # --help: print, then stop this command only
        if message:
            self._print_message(message)
        raise SystemExit(status)


# Blender's frames (MINFRAME and MAXFRAME): the hard limits of Scene.frame_start and
# frame_end, which every command sets to the frames it works on (RNA, bpy 4.5 and 5.2)
FIRST_FRAME, LAST_FRAME = 0, 1048574
# RenderSettings.resolution_x and resolution_y at most (RNA hard_max, bpy 4.5 and 5.2)
MAX_RESOLUTION = 65536


def shown(text, room=160):
    """``text`` for a message: as it is, or its start and end around "..." when long."""
    if len(text) <= room:
        return text
    head = (room - 3) // 2
    return f"{text[:head]}...{text[head - room + 3:]}"


def frames(text, option="--frames"):
    """The frames of a range expression: "1-48", "7", "1,3,10-12", "1-9:2" (a step), in
    order, without repeats.  Raises UsageError with what is wrong: also for a frame outside
    Blender's (0 to 1048574), and before any list is built."""
    ranges, count = [], 0
    for part in text.replace(" ", "").split(","):
        step = 1
        if ":" in part:
            part, _, by = part.partition(":")
            try:
                step = int(by)
            except ValueError:
                step = 0
            if step < 1:
                raise UsageError(f'bad frame step in "{shown(text)}": the step after ":" must be 1 or more')
        first, dash, last = part[1:].partition("-")  # a leading "-" is a negative frame
        first = part[0] + first if part else ""
        try:
            a = int(first)
            b = int(last) if dash else a
        except ValueError:
            raise UsageError(f'bad frame range "{shown(text)}": write frames as 1-48, 7 or 1,3,10-12'
                             ) from None
        if b < a:
            raise UsageError(f'bad frame range "{shown(text)}": {a}-{b} ends before it starts')
        for f in (a, b):
            if not FIRST_FRAME <= f <= LAST_FRAME:
                raise UsageError(f'frame {shown(str(f), 30)} in {option} "{shown(text)}" is outside '
                                 f"Blender's frames: give frames from {FIRST_FRAME} to {LAST_FRAME}")
        ranges.append(range(a, b + 1, step))
        count += len(ranges[-1])
        every = LAST_FRAME - FIRST_FRAME + 1
        if count > every:  # more than all of Blender's frames: repeats
            raise UsageError(f'{option} "{shown(text)}" names more than {every} frames, repeats counted: '
                             f"Blender has that many, from {FIRST_FRAME} to {LAST_FRAME}")
    return list(dict.fromkeys(f for r in ranges for f in r))


def chunk(text):
    """(K, N) from "K/N", 1 <= K <= N."""
    k, slash, n = text.partition("/")
    if not (slash and k.isascii() and k.isdigit() and n.isascii() and n.isdigit()
            and len(k) <= 9 and len(n) <= 9 and 1 <= int(k) <= int(n)):
        raise UsageError(f'bad chunk "{shown(text)}": write K/N with 1 <= K <= N, '
                         "e.g. 2/4 for the second of four")
    return int(k), int(n)


def chunk_of(frame_list, k, n):
    """The K-th of N interleaved parts of ``frame_list``: every N-th frame from the K-th, so
    that every part samples the whole shot and the parts together hold each frame once."""
    return frame_list[k - 1::n]


def contiguous(frame_list, text):
    """(first, last) of a range without gaps (a bake covers one), else UsageError."""
    if frame_list != list(range(frame_list[0], frame_list[-1] + 1)):
        raise UsageError(f'the bake needs one range without gaps, like 1-48, not "{text}"')
    return frame_list[0], frame_list[-1]


def parser():
    p = _Parser(prog="ewrinkles", description="Expression Wrinkles batch commands: render a shot, bake it "
                "for a farm with no add-on, check what it needs, assemble a contact sheet.")
    sub = p.add_subparsers(dest="command", metavar="{render,bake,check,sheet,export}")
    sub.required = True

    look = argparse.ArgumentParser(add_help=False)
    look.add_argument("--engine", choices=("CYCLES", "EEVEE"), help="the render engine (default: the file's)")
    look.add_argument("--samples", type=int, help="render samples (default: the file's)")
    look.add_argument("--resolution", type=int, nargs=2, metavar=("W", "H"),
                      help="the image size in pixels, at 100%% (default: the file's)")

    def add(name, help_text, *parents):
        return sub.add_parser(name, help=help_text, description=help_text, parents=list(parents))

    r = add("render", "Render frames of a shot with its live wrinkles. The .blend is never saved.", look)
    r.add_argument("blend", help="the shot's .blend file")
    r.add_argument("--frames", help="frames to render, e.g. 1-48 or 1,5,10-12 (default: the scene's range)")
    r.add_argument("--out", required=True,
                   help='the folder for the frames (frame_0001.png ...); "//" is the shot\'s folder')
    r.add_argument("--chunk", help="render only the K-th of N interleaved parts of the frames, e.g. 1/4")
    r.add_argument("--resume", action="store_true",
                   help="skip frames whose files exist and are complete images")
    r.add_argument("--json", action="store_true",
                   help="print one JSON line per finished frame on stdout (frame, file, seconds, stage_ms)")
    r.add_argument("--contact-sheet", action="store_true",
                   help="also write contact_sheet.png of the rendered frames into the folder")

    b = add("bake", "Bake for Farm from the shell: the wrinkles of every face baked, saved as a new .blend "
            "that renders with no add-on. The shot itself is never overwritten.", look)
    b.add_argument("blend", help="the shot's .blend file")
    b.add_argument("--frames", help="the range to bake, e.g. 1-48 (default: the scene's range)")
    b.add_argument("--save-as", help='the baked file to write (default: SHOT_farm.blend beside the shot); '
                   '"//" is the shot\'s folder')

    c = add("check", "What the shot needs before a farm: its faces, their sources and problems, and whether "
            "it renders without the add-on (exit 0: ready, 3: not ready).")
    c.add_argument("blend", help="the shot's .blend file")

    s = add("sheet", "Assemble the contact sheet of rendered frames.")
    s.add_argument("folder", help="the folder of the frames (frame_0001.png ...)")
    s.add_argument("--frames", help="the frames to put on the sheet (default: every frame_####.png there)")
    s.add_argument("--out", help="the sheet to write (default: FOLDER/contact_sheet.png)")
    s.add_argument("--width", type=int, default=256, help="the width of each frame on the sheet, in pixels")
    e = add("export", "Export a face's wrinkles for other tools: glTF (wrinkle morph targets and their "
            "weights, Blender's glTF exporter), USD (time-sampled points) or the wrinkle-map package "
            "(wrinkles.json and images, for engine shaders). The .blend is never saved.")
    e.add_argument("blend", help="the shot's .blend file")
    e.add_argument("--format", choices=("gltf", "usd", "package"), required=True, help="what to write")
    e.add_argument("--out", required=True,
                   help="the file to write (.glb or .gltf; .usd, .usda, .usdc or .usdz) or, for a package, "
                   'its folder; "//" is the shot\'s folder')
    e.add_argument("--face", help="the face to export (needed when the scene has more than one)")
    e.add_argument("--frames", help="the range to export, e.g. 1-48 (default: the scene's range)")
    e.add_argument("--tolerance", type=float, default=0.05,
                   help="glTF: the largest error of the wrinkle targets, in mm (default 0.05)")
    e.add_argument("--max-targets", type=int, default=16,
                   help="glTF: at most this many wrinkle morph targets (default 16)")
    e.add_argument("--targets", type=int, default=0,
                   help="glTF: exactly this many wrinkle morph targets (default 0: the fewest within "
                   "the tolerance)")
    e.add_argument("--image-format", choices=("PNG", "OPEN_EXR"), default="PNG",
                   help="package: the images' format (default PNG, 16-bit)")
    e.add_argument("--keep-attributes", action="store_true",
                   help="USD: also write the add-on's own attributes (the wrinkle stage's skin, offsets and "
                   "frame stamp, the fine wrinkles' fields), which only Blender reads")
    e.add_argument("--json", action="store_true", help="print the export's report as one JSON line on stdout")
    return p


def parse(argv):
    """The parsed arguments, with their values checked; UsageError otherwise."""
    ns = parser().parse_args(list(argv))
    if getattr(ns, "samples", None) is not None and ns.samples < 1:
        raise UsageError("--samples must be 1 or more")
    if getattr(ns, "resolution", None) is not None and not (
            4 <= min(ns.resolution) and max(ns.resolution) <= MAX_RESOLUTION):
        w, h = ns.resolution
        raise UsageError(f"--resolution {w} {h} is not allowed: W and H must be from 4 to "
                         f"{MAX_RESOLUTION} pixels")
    tolerance = getattr(ns, "tolerance", 0.0)
    if not (math.isfinite(tolerance) and tolerance >= 0.0):
        raise UsageError(f"--tolerance {tolerance:g} is not allowed: give a finite number of millimetres, "
                         "0 or more (default 0.05)")
    if getattr(ns, "max_targets", 1) < 1 or getattr(ns, "targets", 0) < 0:
        raise UsageError("--max-targets must be 1 or more and --targets 0 or more")
    if getattr(ns, "width", 8) < 8:
        raise UsageError("--width must be at least 8 pixels")
    return ns
