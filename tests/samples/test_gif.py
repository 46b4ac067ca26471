"""sample_scenes/lib/gif.py: the README's animated GIF, decoded back here by a small GIF
reader (the format's own LZW decoding), so the file is checked, not only written."""

import struct

import numpy as np

from sample_scenes.lib import gif


def _unlzw(data, min_code):
    clear, end = 1 << min_code, (1 << min_code) + 1
    size, table, prev, out = min_code + 1, None, None, bytearray()
    bits = int.from_bytes(data, "little")
    pos, total = 0, len(data) * 8
    while pos + size <= total:
        code = (bits >> pos) & ((1 << size) - 1)
        pos += size
        if code == clear:
            table = [bytes([i]) for i in range(clear)] + [b"", b""]
            size, prev = min_code + 1, None
            continue
        if code == end:
            break
        if prev is None:
            entry = table[code]
        else:
            entry = table[code] if code < len(table) else prev + prev[:1]
            table.append(prev + entry[:1])
            if len(table) == (1 << size) and size < 12:
                size += 1
        out += entry
        prev = entry
    return bytes(out)


def read_gif(path):
    raw = open(path, "rb").read()
    assert raw[:6] == b"GIF89a"
    w, h, flags = struct.unpack("<HHB", raw[6:11])
    n = 2 << (flags & 7)
    pal = np.frombuffer(raw[13:13 + 3 * n], np.uint8).reshape(n, 3)
    i, frames, delays, loops = 13 + 3 * n, [], [], False
    while raw[i] != 0x3B:
        if raw[i] == 0x21:
            label = raw[i + 1]
            if label == 0xF9:
                delays.append(struct.unpack("<H", raw[i + 4:i + 6])[0])
            if label == 0xFF and raw[i + 3:i + 14] == b"NETSCAPE2.0":
                loops = True
            i += 2
            while raw[i]:
                i += raw[i] + 1
            i += 1
        elif raw[i] == 0x2C:
            i += 10
            min_code = raw[i]
            i += 1
            data = bytearray()
            while raw[i]:
                data += raw[i + 1:i + 1 + raw[i]]
                i += raw[i] + 1
            i += 1
            idx = np.frombuffer(_unlzw(bytes(data), min_code), np.uint8)
            frames.append(pal[idx].reshape(h, w, 3))
        else:
            raise AssertionError(f"unexpected byte {raw[i]:#x} at {i}")
    return np.stack(frames), delays, loops


def test_round_trip_of_a_small_clip(tmp_path):
    rng = np.random.default_rng(3)
    t, h, w = 5, 48, 64
    y, x = np.mgrid[0:h, 0:w]
    frames = np.stack([np.stack([(x * 4 + k * 20) % 256, y * 5 % 256, np.full_like(x, 90 + 30 * k)], -1)
                       for k in range(t)]).astype(np.uint8)
    frames[2, 10:20, 10:30] = rng.integers(0, 256, (10, 20, 3))  # noise: the LZW table fills and resets
    path = tmp_path / "clip.gif"
    gif.write_gif(path, frames, fps=12)
    back, delays, loops = read_gif(path)
    assert back.shape == frames.shape and loops and delays == [8] * t
    err = np.abs(back.astype(int) - frames.astype(int))
    assert np.median(err) <= 6 and err[:, :8].mean() < 12  # 256 colours for the whole clip


def test_lzw_table_reset_on_long_noise(tmp_path):
    frames = np.random.default_rng(0).integers(0, 256, (1, 120, 160, 3)).astype(np.uint8)
    path = tmp_path / "noise.gif"
    gif.write_gif(path, frames)
    back, _d, _l = read_gif(path)
    pal = gif.palette(frames)
    idx = gif._nearest(frames.reshape(-1, 3).astype(np.float32), pal)
    assert np.array_equal(back.reshape(-1, 3), pal[idx])  # exactly the mapped indices
