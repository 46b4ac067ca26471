# SPDX-License-Identifier: GPL-3.0-or-later
"""The batch command's files: whether a frame on disk is a complete image (for --resume),
a folder that can be written, and the contact sheet."""

import math
import os
import struct
import tempfile
import zlib
from pathlib import Path

import bpy
import numpy as np

from ..glue import images
from .args import UsageError


def _png_complete(data):
    """A PNG whose every chunk is whole, with a good CRC, up to IEND."""
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        return False
    at = 8
    while at + 12 <= len(data):
        (length,) = struct.unpack(">I", data[at:at + 4])
        kind = data[at + 4:at + 8]
        end = at + 12 + length
        if end > len(data):
            return False
        (crc,) = struct.unpack(">I", data[end - 4:end])
        if zlib.crc32(data[at + 4:end - 4]) != crc:
            return False
        if kind == b"IEND":
            return True
        at = end
    return False


def complete(path):
    """Whether ``path`` holds a whole image.  A PNG is read chunk by chunk (a file cut short
    fails); a JPEG must end with its end-of-image marker; any other format must load in
    Blender with its pixels."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError:
        return False
    if path.suffix.lower() == ".png":
        return _png_complete(data)
    if path.suffix.lower() in (".jpg", ".jpeg"):
        return data[:2] == b"\xff\xd8" and data.rstrip(b"\0")[-2:] == b"\xff\xd9"
    try:
        img = bpy.data.images.load(str(path), check_existing=False)
    except RuntimeError:
        return False
    try:
        return img.has_data or (img.size[0] > 0 and len(img.pixels) > 0)
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
    tmp = Path(out).with_name(f".{Path(out).stem}.partial.png")
    images.write(sheet, str(tmp), name="Contact Sheet")
    os.replace(tmp, out)
    return out
