"""An animated GIF from RGB frames, for the README: Blender's video output writes MP4 and
other containers but no animated GIF or WebP, so the demo writes the GIF here.

One global palette of 256 colours (k-means over a sample of every frame's pixels, NumPy),
each pixel mapped to its nearest palette colour, then GIF89a with LZW compression (the
standard variable-length-code LZW of the GIF specification, in Python: it runs over the
indices once, a few seconds for a small clip). Frames loop forever.
"""

import struct

import numpy as np

__all__ = ["palette", "write_gif"]


def palette(frames, colours=256, iterations=10, sample=60000, seed=0):
    """(colours, 3) uint8: a k-means palette of the (T, H, W, 3) uint8 ``frames``."""
    px = frames.reshape(-1, 3).astype(np.float32)
    rng = np.random.default_rng(seed)
    pick = px[rng.choice(len(px), size=min(sample, len(px)), replace=False)]
    centres = pick[rng.choice(len(pick), size=colours, replace=len(pick) < colours)].copy()
    for _ in range(iterations):
        label = _nearest(pick, centres)
        sums = np.zeros_like(centres)
        np.add.at(sums, label, pick)
        counts = np.bincount(label, minlength=colours)[:, None]
        centres = np.where(counts > 0, sums / np.maximum(counts, 1), centres)
    return np.clip(np.rint(centres), 0, 255).astype(np.uint8)


def _nearest(px, centres, chunk=65536):
    out = np.empty(len(px), np.int64)
    c = centres.astype(np.float32)
    cc = (c * c).sum(axis=1)
    for i in range(0, len(px), chunk):
        p = px[i:i + chunk]
        out[i:i + chunk] = np.argmin(cc[None, :] - 2.0 * p @ c.T, axis=1)
    return out


def _lzw(indices, min_code=8):
    """GIF LZW of a flat sequence of palette indices: the data sub-blocks' bytes."""
    clear, end = 1 << min_code, (1 << min_code) + 1
    table = {bytes([i]): i for i in range(clear)}
    size, nxt = min_code + 1, end + 1
    bits, nbits, out = 0, 0, bytearray()

    def emit(code):
        nonlocal bits, nbits
        bits |= code << nbits
        nbits += size
        while nbits >= 8:
            out.append(bits & 0xFF)
            bits >>= 8
            nbits -= 8

    emit(clear)
    word = b""
    for b in bytes(indices):
        w = word + bytes([b])
        if w in table:
            word = w
            continue
        emit(table[word])
        if nxt < 4096:
            table[w] = nxt
            nxt += 1
            if nxt > (1 << size) and size < 12:
                size += 1
        else:  # the table is full: start again
            emit(clear)
            table = {bytes([i]): i for i in range(clear)}
            size, nxt = min_code + 1, end + 1
        word = bytes([b])
    if word:
        emit(table[word])
    emit(end)
    if nbits:
        out.append(bits & 0xFF)
    blocks = bytearray([min_code])
    for i in range(0, len(out), 255):
        chunk = out[i:i + 255]
        blocks += bytes([len(chunk)]) + chunk
    return bytes(blocks + b"\x00")


def write_gif(path, frames, fps=12):
    """Write ``frames`` ((T, H, W, 3) uint8, top row first) as a looping GIF at ``fps``."""
    frames = np.asarray(frames, np.uint8)
    t, h, w, _ = frames.shape
    pal = palette(frames)
    delay = max(1, int(round(100 / fps)))
    data = bytearray(b"GIF89a" + struct.pack("<HHBBB", w, h, 0xF7, 0, 0) + pal.tobytes())
    data += b"\x21\xFF\x0BNETSCAPE2.0\x03\x01\x00\x00\x00"  # loop forever
    for frame in frames:
        idx = _nearest(frame.reshape(-1, 3).astype(np.float32), pal).astype(np.uint8)
        data += b"\x21\xF9\x04\x00" + struct.pack("<H", delay) + b"\x00\x00"
        data += b"\x2C" + struct.pack("<HHHHB", 0, 0, w, h, 0)
        data += _lzw(idx)
    data += b"\x3B"
    with open(path, "wb") as f:
        f.write(data)
