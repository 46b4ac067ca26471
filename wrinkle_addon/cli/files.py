# SPDX-License-Identifier: GPL-3.0-or-later
"""The batch command's files: the paths its arguments name (read as Blender reads them, and
no longer than Blender's paths hold), whether a frame on disk is a complete image of the
render's size (for --resume), a folder that can be written, and the contact sheet."""

import math
import os
import struct
import tempfile
import zlib
from pathlib import Path

import bpy
import numpy as np

from ..glue import images
from .args import UsageError, shown

# Blender keeps a file path in a buffer of FILE_MAX = 1024 bytes, the terminating zero
# included, and cuts a longer one without a word (RNA: a FILE_PATH string's length_max is
# 1024 on bpy 4.5 and 5.2; RenderSettings.filepath keeps 1023 bytes of a longer value).
PATH_BYTES = 1023


def _bytes(path):
    return len(os.fsencode(str(path)))


def argument_path(text, option, shot_folder=None):
    """The absolute path that the argument ``option`` names with ``text``, read as Blender
    reads a path: "//" is the folder of the .blend file (``shot_folder``), "~" the home
    folder, anything else is from the current folder.  UsageError when it starts with "//"
    and there is no .blend file to start from, or when it is longer than Blender's paths."""
    if text.startswith("//"):
        if shot_folder is None:
            raise UsageError(f'{option} {shown(text)} starts with "//", which Blender reads as the folder '
                             "of the .blend file, and there is none to start from here: give the path "
                             "from the current folder or from /")
        text = bpy.path.abspath(text, start=str(shot_folder))
    try:
        path = Path(os.path.expanduser(text)).resolve()
    except (OSError, RuntimeError, ValueError) as exc:
        raise UsageError(f"{option} {shown(text)} is not a usable path: {exc}") from None
    fits(option, text, path)
    return path


def fits(option, text, path, *written):
    """UsageError unless ``path`` (what ``option`` names with ``text``) and every path in
    ``written`` (the files the command writes in or beside it) fit in Blender's paths."""
    if _bytes(path) > PATH_BYTES:
        raise UsageError(f"{option} {shown(text)} is {_bytes(path)} bytes long as a full path; Blender's "
                         f"file paths hold at most {PATH_BYTES} bytes: choose a shorter path")
    longest = max(written, key=_bytes, default=path)
    extra = _bytes(longest) - _bytes(path)
    if _bytes(longest) > PATH_BYTES:
        raise UsageError(f"{option} {shown(text)} is {_bytes(path)} bytes long as a full path, too long for "
                         f"the files written with it, which take up to {extra} bytes more; Blender's file "
                         f"paths hold at most {PATH_BYTES} bytes: choose a path of at most "
                         f"{PATH_BYTES - extra} bytes")


def not_a_folder(option, text, path, example):
    """UsageError when ``path`` (a file to write, named by ``option`` as ``text``) is a folder
    or is written as one (ending in a slash); ``example`` is a file name to suggest in it."""
    if text.endswith(("/", os.sep)) or os.path.isdir(path):
        raise UsageError(f"{option} {shown(text)} is a folder: {option} names the file to write, "
                         f"e.g. {shown(str(path / example))}")


def not_a_file(option, text, path, what):
    """UsageError when ``path`` (the folder ``option`` names as ``text``, for ``what``) is an
    existing file."""
    if os.path.exists(path) and not os.path.isdir(path):
        raise UsageError(f"{option} {shown(text)} is a file: {option} names the folder for {what}")


def render_size(scene):
    """(width, height) in pixels of the images a render of ``scene`` writes: the resolution
    at its percentage, cropped to the render region when Crop to Render Region is on (as
    Blender's render pipeline computes them)."""
    r = scene.render
    w = r.resolution_x * r.resolution_percentage // 100
    h = r.resolution_y * r.resolution_percentage // 100
    if r.use_border and r.use_crop_to_border:
        w = int(r.border_max_x * w) - int(r.border_min_x * w)
        h = int(r.border_max_y * h) - int(r.border_min_y * h)
    return w, h


_PNG = b"\x89PNG\r\n\x1a\n"
_PNG_CHANNELS = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}  # by colour type
_ADAM7 = ((0, 0, 8, 8), (4, 0, 8, 8), (0, 4, 4, 8), (2, 0, 4, 4), (0, 2, 2, 4), (1, 0, 2, 2), (0, 1, 1, 2))


def _png_rows_bytes(w, h, bits, interlace):
    """The bytes of the filtered rows of a ``w`` x ``h`` PNG at ``bits`` per pixel: what its
    image data inflates to."""
    def rows(pw, ph):
        return ph * (1 + (pw * bits + 7) // 8) if pw and ph else 0
    if not interlace:
        return rows(w, h)
    return sum(rows((w - x + dx - 1) // dx, (h - y + dy - 1) // dy) for x, y, dx, dy in _ADAM7)


def _png_size(data):
    """(width, height) of a whole PNG, else None: the header first, every chunk whole with a
    good CRC, the image data inflating to exactly the rows the header promises, up to IEND."""
    if data[:8] != _PNG:
        return None
    at, size, need, got = 8, None, 0, 0
    inflate = zlib.decompressobj()
    while at + 12 <= len(data):
        length, kind = struct.unpack(">I4s", data[at:at + 8])
        end = at + 12 + length
        if end > len(data):
            return None
        (crc,) = struct.unpack(">I", data[end - 4:end])
        if zlib.crc32(data[at + 4:end - 4]) != crc:
            return None
        body = data[at + 8:end - 4]
        if size is None:
            if kind != b"IHDR" or length != 13:
                return None
            w, h, bit_depth, colour, _method, _filter, interlace = struct.unpack(">IIBBBBB", body)
            if not (w and h) or colour not in _PNG_CHANNELS:
                return None
            size, need = (w, h), _png_rows_bytes(w, h, bit_depth * _PNG_CHANNELS[colour], interlace)
        elif kind == b"IDAT":
            try:
                while body and not inflate.eof:  # a MiB at a time: a frame is never held inflated
                    got += len(inflate.decompress(body, 1 << 20))
                    body = inflate.unconsumed_tail
                    if got > need:
                        return None
            except zlib.error:
                return None
        elif kind == b"IEND":
            return size if inflate.eof and got == need else None
        at = end
    return None


_JPEG_FRAMES = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}


def _jpeg_size(data):
    """(width, height) of a JPEG that starts and ends with its markers, from its frame
    header, else None."""
    if data[:2] != b"\xff\xd8" or data.rstrip(b"\0")[-2:] != b"\xff\xd9":
        return None
    at = 2
    while at + 4 <= len(data) and data[at] == 0xFF:
        marker = data[at + 1]
        if marker == 0xFF:  # fill byte
            at += 1
            continue
        if marker == 0xDA:  # the scan starts before any frame header
            return None
        (length,) = struct.unpack(">H", data[at + 2:at + 4])
        if marker in _JPEG_FRAMES and at + 9 <= len(data):
            h, w = struct.unpack(">HH", data[at + 5:at + 9])
            return (w, h) if w and h else None
        at += 2 + length
    return None


def complete(path, size=None):
    """Whether ``path`` holds a whole image, of ``size`` (width, height) when given.  A PNG
    is read chunk by chunk and its image data inflated (a file cut short, or one with no
    image, fails); a JPEG must end with its end-of-image marker; any other format must load
    in Blender with its pixels."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError:
        return False
    if path.suffix.lower() == ".png":
        found = _png_size(data)
    elif path.suffix.lower() in (".jpg", ".jpeg"):
        found = _jpeg_size(data)
    else:
        found = _blender_size(path)
    return found is not None and (size is None or tuple(found) == tuple(size))


def _blender_size(path):
    try:
        img = bpy.data.images.load(str(path), check_existing=False)
    except RuntimeError:
        return None
    try:
        w, h = img.size
        return (w, h) if w and h and len(img.pixels) == w * h * img.channels else None
    finally:
        bpy.data.images.remove(img)


def writable_folder(folder):
    """Create ``folder`` if needed and prove a file can be written there, else UsageError."""
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".ewrinkles-", delete=True):
            pass
    except OSError as exc:
        raise UsageError(f"cannot write into the output folder {folder}: {exc.strerror or exc}") from None
    return folder


def _load(path):
    img = bpy.data.images.load(str(path), check_existing=False)
    try:
        w, h = img.size
        px = np.empty(w * h * 4, np.float32)
        img.pixels.foreach_get(px)
    finally:
        bpy.data.images.remove(img)
    return px.reshape(h, w, 4)


def _shrink(px, width):
    """``px`` (H, W, 4) scaled to ``width`` by averaging boxes (a whole-pixel box filter)."""
    h, w = px.shape[:2]
    if w <= width:
        return px
    height = max(1, round(h * width / w))
    ys = np.linspace(0, h, height + 1).astype(int)
    xs = np.linspace(0, w, width + 1).astype(int)
    rows = np.add.reduceat(px, ys[:-1], axis=0) / np.diff(ys)[:, None, None]
    return np.add.reduceat(rows, xs[:-1], axis=1) / np.diff(xs)[None, :, None]


def contact_sheet(paths, out, width=256):
    """One PNG of the frames ``paths`` in reading order, at most ``width`` pixels each, on a grid as
    square as the count allows, with a 4-pixel dark gutter.  Returns ``out``."""
    thumbs = [_shrink(_load(p), width) for p in paths]
    if not thumbs:
        raise UsageError("no frames to put on the contact sheet")
    cols = math.ceil(math.sqrt(len(thumbs)))
    rows = math.ceil(len(thumbs) / cols)
    th, tw = max(t.shape[0] for t in thumbs), max(t.shape[1] for t in thumbs)
    gap = 4
    sheet = np.zeros((rows * (th + gap) + gap, cols * (tw + gap) + gap, 4), np.float32)
    sheet[..., :3], sheet[..., 3] = 0.08, 1.0
    for i, t in enumerate(thumbs):
        r, c = divmod(i, cols)
        y = gap + (rows - 1 - r) * (th + gap)  # Blender's rows run bottom-up
        x = gap + c * (tw + gap)
        sheet[y + th - t.shape[0]:y + th, x:x + t.shape[1]] = t
    tmp = sheet_partial(out)
    try:
        images.write(sheet, str(tmp), name="Contact Sheet")
        os.replace(tmp, out)
    except OSError as exc:
        raise UsageError(f"cannot write the contact sheet {out}: {exc.strerror or exc}") from None
    return out


def sheet_partial(out):
    """The name the contact sheet ``out`` is written under before it is moved into place."""
    return Path(out).with_name(f".{Path(out).stem}.partial.png")
