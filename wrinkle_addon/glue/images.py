# SPDX-License-Identifier: GPL-3.0-or-later
"""Image pixels in and out of Blender for the wrinkle maps of Jimenez et al. 2011, §1.2.

Thin glue around ``image.pixels.foreach_get/foreach_set`` on contiguous float32 buffers;
the maths is in ``core/maps/jimenez.py``.  Arrays are ``(H, W, 4)`` float32 in Blender's
row order (row 0 is the bottom row of the picture).

Measured on bpy 4.5.4 and 5.2.3 (docs/architecture.md, "Measured Blender facts"):

* ``pixels`` of an 8-bit (byte) image are the stored values / 255 whatever its colour
  space tag; an sRGB tag does NOT linearise them.  A 16-bit PNG or an EXR is held as
  floats, and those ARE converted from the tagged colour space on load: a 16-bit
  normal map tagged sRGB reads 0.5 as 0.214.  ``read`` therefore reloads such an image as
  Non-Color for the read and restores the tag, so data maps always give the stored
  numbers.  A tag that is not Non-Color still makes shaders read the map wrong, so the
  operators warn about it (``colour_warning``).
* Changing the colour space of a generated image regenerates it (its pixels are lost),
  and of a file image reloads it: ``store`` sets the colour space before the pixels.
  Assigning the colour space it already has does the same, and so does changing the
  alpha mode of an image with unsaved changes (painted, or filled from Python), which
  is reloaded from its file or its packed copy.  Packing first keeps the pixels: a
  packed image reloads what was packed.  ``tag_as_data`` tags images the user made
  without losing their pixels.
* In memory a byte image takes 4 bytes a pixel (``depth`` 32) and a float image 16 (``depth``
  128, RGBA float32).  There is no half-float buffer: an EXR saved as half loads with
  ``depth`` 128 as well, packed or not.  So the baked maps are 8-bit unless asked for floats.
* A generated image is lost on save unless it is packed and has a user: ``store`` packs
  it (byte images pack as 8-bit PNG, float ones as 32-bit float EXR, both lossless) and
  gives it a fake user.
* ``image.save`` writes a float image to PNG as 16-bit and to EXR always as 32-bit float,
  and a byte image to EXR through a wrong colour conversion.  ``save_render`` with the
  format in a scene's image settings writes all four formats (8/16-bit PNG, half/float
  EXR), and for a Non-Color image applies no view transform (checked with Standard, Raw
  and AgX).  ``save`` uses it on a temporary float Non-Color copy with a temporary scene,
  for EXR.  Every Blender writer treats a float buffer as premultiplied and divides its
  colour by its alpha on the way to PNG (0.5 at alpha 0.067 is written as 1.0), whatever
  the image's alpha mode: a channel-packed mask's zones 1-3 would be lost where zone 4 is
  partial.  So PNGs are written by ``_write_png``: straight RGBA, the numbers as they are.
"""

import os
import struct
import zlib

import bpy
import numpy as np

from .errors import WrinkleError

NON_COLOR = "Non-Color"

# (file_format, color_depth, extension) of the formats that ``save`` writes.
FORMATS = {
    ("PNG", "8"): ".png",
    ("PNG", "16"): ".png",
    ("OPEN_EXR", "16"): ".exr",
    ("OPEN_EXR", "32"): ".exr",
}


class ImageError(WrinkleError):
    """Bad image input; the message is meant for the user."""


def _where(image):
    path = image.filepath
    if image.packed_file is not None:
        return " (packed in the .blend file)"
    if path:
        return f" (file {bpy.path.abspath(path)!r})"
    return ""


def size(image):
    """(width, height); loads the image if needed."""
    return int(image.size[0]), int(image.size[1])


def channel_count(image):
    """Colour channels of the image's own data: 1 grey, 2 grey + alpha, 3 RGB, 4 RGBA.

    ``image.channels`` is always 4 in bpy (the buffer is RGBA); ``depth`` is the bits
    per pixel of the buffer (8 per byte channel, 32 per float channel).
    """
    size(image)
    return max(1, int(image.depth) // (32 if image.is_float else 8))


def is_data(image):
    """True if the image is tagged as data (Non-Color), as normal, PD and mask maps must be."""
    return bool(image.colorspace_settings.is_data)


def colour_warning(image):
    """A warning for the user if a data map is tagged as colour, else None."""
    if is_data(image):
        return None
    return (f"Image '{image.name}' is tagged {image.colorspace_settings.name!r}: its stored values "
            f"were used as data, but set its Color Space to Non-Color so that shaders read it right")


def check_loaded(image):
    """Raise ImageError unless the image has pixels (it loads them if needed)."""
    if image is None:
        raise ImageError("No image given")
    if image.source not in {"FILE", "GENERATED"}:
        raise ImageError(f"Image '{image.name}' is a {image.source.lower()} image; "
                         "use a single still image")
    w, h = size(image)
    if not image.has_data or w == 0 or h == 0:
        if image.filepath and image.packed_file is None:
            raise ImageError(f"Image '{image.name}' has no pixels: its file "
                             f"{bpy.path.abspath(image.filepath)!r} is missing or unreadable")
        raise ImageError(f"Image '{image.name}' has no pixels{_where(image)}")


def check_same_size(images):
    """Raise ImageError naming the images if their sizes differ."""
    images = list(images)
    sizes = [size(im) for im in images]
    if len(set(sizes)) > 1:
        listed = ", ".join(f"'{im.name}' is {w}x{h}" for im, (w, h) in zip(images, sizes))
        raise ImageError(f"The images must have the same size: {listed}")


def check_square(image):
    """Raise ImageError for a map that is not square."""
    w, h = size(image)
    if w != h:
        raise ImageError(f"Image '{image.name}' is {w}x{h}; wrinkle and mask maps must be square")


def _pixels(image):
    w, h = size(image)
    c = int(image.channels)
    buf = np.empty(w * h * c, dtype=np.float32)
    image.pixels.foreach_get(buf)
    buf = buf.reshape(h, w, c)
    if c == 4:
        return buf
    out = np.ones((h, w, 4), dtype=np.float32)
    out[..., : min(c, 4)] = buf[..., :4]
    return out


def read(image):
    """The stored values of ``image`` as an (H, W, 4) float32 array, row 0 at the bottom.

    Raises ImageError if the image has no pixels (missing file, empty image).  A float
    image (16-bit PNG, EXR) from a file that is tagged with a colour space other than
    Non-Color is briefly reloaded as Non-Color, so it gives its stored numbers too; an
    unsaved (dirty) or generated one is read as it is in memory.
    """
    check_loaded(image)
    cs = image.colorspace_settings
    if image.is_float and not cs.is_data and image.source == "FILE" and not image.is_dirty:
        tag = cs.name
        cs.name = NON_COLOR
        try:
            check_loaded(image)
            return _pixels(image)
        finally:
            cs.name = tag
    return _pixels(image)


def _buffer(image):
    buf = np.empty(len(image.pixels), dtype=np.float32)
    image.pixels.foreach_get(buf)
    return buf


def tag_as_data(image, alpha_mode=None):
    """Tag ``image`` Non-Color (and set its ``alpha_mode`` if given) keeping its pixels.

    For images the user made in Blender (a mask painted on a new image), whose pixels
    live only in memory.  A generated image is packed first (its pixels are kept, and it
    survives saving the file, as ``store`` does with its own); a tag is assigned only
    when it differs, since even the same colour space regenerates or reloads the image
    (see the module notes); and an image with unsaved changes gets its pixels back after
    the reload.  Returns True if the image was packed.
    """
    packed = False
    if image.source == "GENERATED" and image.packed_file is None:
        image.pack()  # keeps the pixels (measured); a later reload reads the packed copy
        packed = True
    cs = image.colorspace_settings
    change_cs = cs.name != NON_COLOR
    change_alpha = alpha_mode is not None and image.alpha_mode != alpha_mode
    if not (change_cs or change_alpha):
        return packed
    kept = _buffer(image) if image.is_dirty else None
    if change_cs:
        cs.name = NON_COLOR
    if change_alpha:
        image.alpha_mode = alpha_mode
    if kept is not None and len(image.pixels) == len(kept):
        image.pixels.foreach_set(kept)  # the reload read the file or the packed copy
    return packed


def _rgba(pixels):
    pixels = np.asarray(pixels, dtype=np.float32)
    if pixels.ndim != 3 or pixels.shape[2] not in (3, 4) or 0 in pixels.shape:
        raise ValueError(f"pixels must have shape (H, W, 3 or 4), not {pixels.shape}")
    if pixels.shape[2] == 4:
        return np.ascontiguousarray(pixels)
    out = np.ones(pixels.shape[:2] + (4,), dtype=np.float32)
    out[..., :3] = pixels
    return out


def _reusable(image, w, h, float_buffer):
    if image.library is not None or image.source not in {"FILE", "GENERATED"}:
        return False
    if image.source == "FILE" and image.packed_file is None:
        return False  # it stands for a file on disk: replace it rather than pack over it
    return size(image) == (w, h) and bool(image.is_float) == bool(float_buffer)


def store(name, pixels, *, float_buffer=False, non_color=True, image=None):
    """An image datablock named ``name`` that holds ``pixels`` (H, W, 3 or 4; alpha 1 if absent).

    Reuses ``image``, or else the image already called ``name``, if it is local,
    generated or packed, of the same size and of the same kind (byte or float);
    otherwise makes a new one, moves the old one's users to it and deletes the old one.
    The result is tagged Non-Color (``non_color``), packed into the .blend and given a
    fake user, so it survives saving and reopening the file.  Byte images keep 8 bits
    per channel (4 bytes a pixel in memory); ``float_buffer`` keeps 32-bit floats (16 bytes
    a pixel).
    """
    pixels = _rgba(pixels)
    h, w = pixels.shape[:2]
    old = image if image is not None else bpy.data.images.get(name)
    if old is not None and _reusable(old, w, h, float_buffer):
        img = old
        if img.name != name and bpy.data.images.get(name) is None:
            img.name = name
    else:
        img = bpy.data.images.new(name, w, h, alpha=True, float_buffer=float_buffer)
        if old is not None and old.library is None:
            old.user_remap(img)
            bpy.data.images.remove(old)
            img.name = name
    # Colour space first: changing it regenerates or reloads the image.
    wanted = NON_COLOR if non_color else ("Linear Rec.709" if float_buffer else "sRGB")
    if img.colorspace_settings.name != wanted:
        img.colorspace_settings.name = wanted
    img.pixels.foreach_set(pixels.ravel())
    img.pack()
    img.use_fake_user = True
    return img


def save(image, filepath, file_format="PNG", color_depth="8"):
    """Write ``image`` to ``filepath`` as a data map and return the absolute path written.

    ``file_format`` "PNG" with ``color_depth`` "8" or "16", or "OPEN_EXR" with "16" (half)
    or "32" (float).  The stored values are written with no view transform (see the module
    notes); the extension is added if missing and missing folders are made.  The image
    itself is not changed.
    """
    return write(read(image), filepath, file_format, color_depth, name=image.name)


def write(pixels, filepath, file_format="PNG", color_depth="8", name="image"):
    """Write the (H, W, 4) float ``pixels`` (row 0 at the bottom) as :func:`save` writes an
    image; ``name`` is for the messages."""
    ext = FORMATS.get((file_format, str(color_depth)))
    if ext is None:
        raise ImageError(f"Cannot write {file_format} at {color_depth} bits; use PNG 8 or 16, "
                         "or OPEN_EXR 16 (half) or 32 (float)")
    if not filepath:
        raise ImageError("No file path given")
    if filepath.startswith("//") and not bpy.data.filepath:
        raise ImageError(f"The path {filepath!r} is relative to the .blend file, which is not "
                         "saved yet: save it first or give an absolute path")
    path = bpy.path.ensure_ext(bpy.path.abspath(filepath), ext)
    folder = os.path.dirname(path)
    h, w = pixels.shape[:2]
    scene = temp = None
    try:
        if folder:
            os.makedirs(folder, exist_ok=True)
        if file_format == "PNG":
            _write_png(pixels, path, int(color_depth))
            return path
        temp = bpy.data.images.new(".wrinkle save", w, h, alpha=True, float_buffer=True)
        temp.colorspace_settings.name = NON_COLOR
        temp.pixels.foreach_set(np.ascontiguousarray(pixels, np.float32).ravel())
        scene = bpy.data.scenes.new(".wrinkle save")
        scene.view_settings.view_transform = "Standard"
        settings = scene.render.image_settings
        settings.file_format = file_format
        settings.color_mode = "RGBA"
        settings.color_depth = str(color_depth)
        if file_format == "OPEN_EXR":
            settings.exr_codec = "ZIP"
        temp.save_render(path, scene=scene)
    except (OSError, RuntimeError) as exc:
        raise ImageError(f"Could not write '{name}' to {path!r}: {exc}") from exc
    finally:
        if temp is not None:
            bpy.data.images.remove(temp)
        if scene is not None:
            bpy.data.scenes.remove(scene)
    if not os.path.isfile(path):
        raise ImageError(f"Could not write '{name}' to {path!r}")
    return path


def _write_png(pixels, path, depth):
    """Write (H, W, 4) float ``pixels`` (row 0 at the bottom) as an RGBA PNG of ``depth``
    (8 or 16) bits, the values as they are: straight alpha, no colour transform.

    Blender's own writers treat a float buffer as premultiplied and divide its colour by
    its alpha on the way to PNG (measured on bpy 4.5 and 5.2: 0.5 at alpha 0.067 is written
    as 1.0), which breaks a channel-packed mask, whose alpha is a fourth zone.  A PNG is a
    zlib stream of filtered rows in chunks with CRCs; this writes filter 0 (none) rows,
    which every reader takes."""
    top_down = np.clip(np.asarray(pixels, np.float32)[::-1], 0.0, 1.0)
    h, w = top_down.shape[:2]
    if depth == 16:
        rows = np.round(top_down * 65535.0).astype(">u2").reshape(h, w * 4).view(np.uint8)
    else:
        rows = np.round(top_down * 255.0).astype(np.uint8).reshape(h, w * 4)
    raw = np.concatenate([np.zeros((h, 1), np.uint8), rows], axis=1).tobytes()

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    header = struct.pack(">IIBBBBB", w, h, depth, 6, 0, 0, 0)  # colour type 6: RGBA
    data = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 6))
            + chunk(b"IEND", b""))
    tmp = path + ".partial"
    with open(tmp, "wb") as fh:
        fh.write(data)
    os.replace(tmp, path)


def link_to_file(image, filepath):
    """Make ``image`` stand for the file ``filepath`` (written by ``save``) instead of its
    packed pixels: it is unpacked, pointed at the file and reloaded from it."""
    if image.packed_file is not None:
        image.unpack(method="REMOVE")
    image.source = "FILE"
    image.filepath = filepath
    image.reload()
    check_loaded(image)
    return image
