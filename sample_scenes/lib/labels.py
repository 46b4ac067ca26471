"""Text labels drawn into NumPy images with a built-in 5 x 7 bitmap font (no PIL needed).

Pure NumPy. Images here are float arrays (H, W, C), row 0 at the top; Blender stores
pixels bottom row first, so ``draw_text(..., bottom_up=True)`` takes that order (and the
caller still gives ``y`` from the top).

The font has A-Z, a-z (with descenders), 0-9, space and ``. , : ; - _ + / ( ) [ ] < > ! ? %
= ' " # *``. Each glyph is 5 columns by 9 rows: 7 rows down to the baseline and 2 below it
for g, j, p, q, y, the comma and the underscore; characters advance by 6 columns. Any
other character is drawn as an empty box, so it shows without stopping anything.

``sheet`` lays out a contact sheet: rows of equally sized tiles, each row with its name on
the left and, above its tiles, a caption of two lines (a group such as an expression,
centred over its run of tiles, and one word per tile such as "without" / "with").
"""

import numpy as np

__all__ = ["GLYPH_W", "GLYPH_H", "ADVANCE", "glyph", "text_mask", "text_size", "draw_text", "sheet"]

GLYPH_W = 5  # columns of a glyph
GLYPH_H = 9  # rows: 7 down to the baseline, 2 for descenders
ADVANCE = GLYPH_W + 1  # one blank column between characters

# Rows top to bottom, "#" = ink. Glyphs of 7 rows get the 2 descender rows blank.
_FONT_ROWS = {
    "A": ".###. #...# #...# ##### #...# #...# #...#",
    "B": "####. #...# #...# ####. #...# #...# ####.",
    "C": ".###. #...# #.... #.... #.... #...# .###.",
    "D": "####. #...# #...# #...# #...# #...# ####.",
    "E": "##### #.... #.... ####. #.... #.... #####",
    "F": "##### #.... #.... ####. #.... #.... #....",
    "G": ".###. #...# #.... #.### #...# #...# .####",
    "H": "#...# #...# #...# ##### #...# #...# #...#",
    "I": ".###. ..#.. ..#.. ..#.. ..#.. ..#.. .###.",
    "J": "..### ...#. ...#. ...#. ...#. #..#. .##..",
    "K": "#...# #..#. #.#.. ##... #.#.. #..#. #...#",
    "L": "#.... #.... #.... #.... #.... #.... #####",
    "M": "#...# ##.## #.#.# #.#.# #...# #...# #...#",
    "N": "#...# #...# ##..# #.#.# #..## #...# #...#",
    "O": ".###. #...# #...# #...# #...# #...# .###.",
    "P": "####. #...# #...# ####. #.... #.... #....",
    "Q": ".###. #...# #...# #...# #.#.# #..#. .##.#",
    "R": "####. #...# #...# ####. #.#.. #..#. #...#",
    "S": ".#### #.... #.... .###. ....# ....# ####.",
    "T": "##### ..#.. ..#.. ..#.. ..#.. ..#.. ..#..",
    "U": "#...# #...# #...# #...# #...# #...# .###.",
    "V": "#...# #...# #...# #...# #...# .#.#. ..#..",
    "W": "#...# #...# #...# #.#.# #.#.# #.#.# .#.#.",
    "X": "#...# #...# .#.#. ..#.. .#.#. #...# #...#",
    "Y": "#...# #...# .#.#. ..#.. ..#.. ..#.. ..#..",
    "Z": "##### ....# ...#. ..#.. .#... #.... #####",
    "a": "..... ..... .###. ....# .#### #...# .####",
    "b": "#.... #.... #.##. ##..# #...# #...# ####.",
    "c": "..... ..... .###. #.... #.... #...# .###.",
    "d": "....# ....# .##.# #..## #...# #...# .####",
    "e": "..... ..... .###. #...# ##### #.... .###.",
    "f": "..##. .#..# .#... ###.. .#... .#... .#...",
    "g": "..... ..... .#### #...# #...# #...# .#### ....# .###.",
    "h": "#.... #.... #.##. ##..# #...# #...# #...#",
    "i": "..#.. ..... .##.. ..#.. ..#.. ..#.. .###.",
    "j": "...#. ..... ..##. ...#. ...#. ...#. ...#. #..#. .##..",
    "k": "#.... #.... #..#. #.#.. ##... #.#.. #..#.",
    "l": ".##.. ..#.. ..#.. ..#.. ..#.. ..#.. .###.",
    "m": "..... ..... ##.#. #.#.# #.#.# #.#.# #.#.#",
    "n": "..... ..... #.##. ##..# #...# #...# #...#",
    "o": "..... ..... .###. #...# #...# #...# .###.",
    "p": "..... ..... ####. #...# #...# #...# ####. #.... #....",
    "q": "..... ..... .#### #...# #...# #...# .#### ....# ....#",
    "r": "..... ..... #.##. ##..# #.... #.... #....",
    "s": "..... ..... .###. #.... .###. ....# ####.",
    "t": ".#... .#... ###.. .#... .#... .#..# ..##.",
    "u": "..... ..... #...# #...# #...# #..## .##.#",
    "v": "..... ..... #...# #...# #...# .#.#. ..#..",
    "w": "..... ..... #...# #...# #.#.# #.#.# .#.#.",
    "x": "..... ..... #...# .#.#. ..#.. .#.#. #...#",
    "y": "..... ..... #...# #...# #...# #...# .#### ....# .###.",
    "z": "..... ..... ##### ...#. ..#.. .#... #####",
    "0": ".###. #...# #..## #.#.# ##..# #...# .###.",
    "1": "..#.. .##.. ..#.. ..#.. ..#.. ..#.. .###.",
    "2": ".###. #...# ....# ...#. ..#.. .#... #####",
    "3": "##### ...#. ..#.. ...#. ....# #...# .###.",
    "4": "...#. ..##. .#.#. #..#. ##### ...#. ...#.",
    "5": "##### #.... ####. ....# ....# #...# .###.",
    "6": "..##. .#... #.... ####. #...# #...# .###.",
    "7": "##### ....# ...#. ..#.. .#... .#... .#...",
    "8": ".###. #...# #...# .###. #...# #...# .###.",
    "9": ".###. #...# #...# .#### ....# ...#. .##..",
    " ": "..... ..... ..... ..... ..... ..... .....",
    ".": "..... ..... ..... ..... ..... .##.. .##..",
    ",": "..... ..... ..... ..... ..... .##.. .##.. ..#.. .#...",
    ":": "..... .##.. .##.. ..... .##.. .##.. .....",
    ";": "..... .##.. .##.. ..... .##.. .##.. ..#.. .#...",
    "-": "..... ..... ..... ##### ..... ..... .....",
    "_": "..... ..... ..... ..... ..... ..... ..... #####",
    "+": "..... ..#.. ..#.. ##### ..#.. ..#.. .....",
    "/": "....# ....# ...#. ..#.. .#... #.... #....",
    "(": "...#. ..#.. .#... .#... .#... ..#.. ...#.",
    ")": ".#... ..#.. ...#. ...#. ...#. ..#.. .#...",
    "[": ".###. .#... .#... .#... .#... .#... .###.",
    "]": ".###. ...#. ...#. ...#. ...#. ...#. .###.",
    "<": "...#. ..#.. .#... #.... .#... ..#.. ...#.",
    ">": ".#... ..#.. ...#. ....# ...#. ..#.. .#...",
    "!": "..#.. ..#.. ..#.. ..#.. ..#.. ..... ..#..",
    "?": ".###. #...# ....# ...#. ..#.. ..... ..#..",
    "%": "##..# ##..# ...#. ..#.. .#... #..## #..##",
    "=": "..... ..... ##### ..... ##### ..... .....",
    "'": "..#.. ..#.. .#... ..... ..... ..... .....",
    '"': ".#.#. .#.#. .#.#. ..... ..... ..... .....",
    "#": ".#.#. .#.#. ##### .#.#. ##### .#.#. .#.#.",
    "*": "..... ..#.. #.#.# .###. #.#.# ..#.. .....",
}
_UNKNOWN_ROWS = "##### #...# #...# #...# #...# #...# #####"


def _parse(rows):
    lines = rows.split()
    assert all(len(r) == GLYPH_W for r in lines) and len(lines) in (7, 8, GLYPH_H), rows
    out = np.zeros((GLYPH_H, GLYPH_W), dtype=bool)
    out[: len(lines)] = [[c == "#" for c in r] for r in lines]
    return out


_FONT = {ch: _parse(rows) for ch, rows in _FONT_ROWS.items()}
_UNKNOWN = _parse(_UNKNOWN_ROWS)


def glyph(ch):
    """The (GLYPH_H, GLYPH_W) bool bitmap of one character (a box when it is not in the font)."""
    return _FONT.get(ch, _UNKNOWN)


def text_size(text, scale=1):
    """(width, height) in pixels of ``text`` drawn at ``scale``."""
    n = len(str(text))
    return max(0, n * ADVANCE - 1) * scale, GLYPH_H * scale


def text_mask(text, scale=1):
    """Bool image (height, width) of ``text``, row 0 at the top; ``scale`` >= 1 repeats pixels."""
    text = str(text)
    scale = max(1, int(scale))
    mask = np.zeros((GLYPH_H, max(0, len(text) * ADVANCE - 1)), dtype=bool)
    for i, ch in enumerate(text):
        mask[:, i * ADVANCE:i * ADVANCE + GLYPH_W] = glyph(ch)
    return mask.repeat(scale, axis=0).repeat(scale, axis=1)


def draw_text(image, text, x, y, color=(1.0, 1.0, 1.0, 1.0), scale=1, bottom_up=False):
    """Draw ``text`` into ``image`` (H, W, C) in place with its top-left corner at column ``x``,
    row ``y`` counted from the top; parts outside the image are clipped. ``color`` sets the
    first ``len(color)`` channels. ``bottom_up``: the image's row 0 is its bottom row
    (Blender's pixel order). Returns the image."""
    mask = text_mask(text, scale)
    h, w = mask.shape
    height, width = image.shape[:2]
    x, y = int(round(x)), int(round(y))
    x0, y0 = max(x, 0), max(y, 0)
    x1, y1 = min(x + w, width), min(y + h, height)
    if x1 <= x0 or y1 <= y0:
        return image
    part = mask[y0 - y:y1 - y, x0 - x:x1 - x]
    if bottom_up:
        part = part[::-1]
        y0, y1 = height - y1, height - y0
    color = np.asarray(color, dtype=image.dtype).ravel()
    channels = min(len(color), image.shape[2]) if image.ndim == 3 else 1
    region = image[y0:y1, x0:x1]
    if image.ndim == 3:
        region[part, :channels] = color[:channels]
    else:
        region[part] = color[0]
    return image


def sheet(tiles, gap=8, row_names=None, captions=None, background=0.12, scale=None,
          text_color=(0.92, 0.92, 0.92, 1.0), dim_color=(0.62, 0.62, 0.62, 1.0)):
    """A contact sheet (H, W, 4) float32, row 0 at the top.

    ``tiles``: a list of rows, each a list of (h, w, 4) images of one size, row 0 at the
    top. Without ``row_names`` and ``captions`` the tiles are simply laid out with ``gap``
    pixels around them on a ``background`` grey. ``row_names``: one name per row, drawn
    left of the row. ``captions``: per row, one ``(group, word)`` per tile: each run of
    tiles with the same group gets the group centred above it, underlined, and each tile
    its word. ``scale``: the font's pixel size; by default 2 for tiles 256 pixels wide, 3
    for 512 (1 + width / 256, rounded).
    """
    th, tw = tiles[0][0].shape[:2]
    ncol = max(len(r) for r in tiles)
    if scale is None:
        scale = 1 + (tw + 127) // 256
    pad = 3 * scale
    line = GLYPH_H * scale
    left = 0
    if row_names:
        left = max(text_size(n, scale)[0] for n in row_names) + gap
    head = 2 * line + 3 * pad if captions else 0
    row_h = head + th + gap
    out = np.empty((row_h * len(tiles) + gap, left + (tw + gap) * ncol + gap, 4), np.float32)
    out[..., :3] = background
    out[..., 3] = 1.0
    for r, row in enumerate(tiles):
        top = row_h * r + gap + head  # top of this row's tiles
        for c, tile in enumerate(row):
            x = left + (tw + gap) * c + gap
            out[top:top + th, x:x + tw] = tile[:th, :tw]
        if row_names:
            name = row_names[r]
            draw_text(out, name, gap, top + (th - line) // 2, text_color, scale)
        if captions:
            _draw_captions(out, captions[r], left, top - head, tw, gap, scale, pad, text_color, dim_color)
    return out


def _draw_captions(out, caps, left, y, tw, gap, scale, pad, text_color, dim_color):
    line = GLYPH_H * scale
    runs = []  # [group, first tile, last tile]
    for c, (group, _word) in enumerate(caps):
        if runs and runs[-1][0] == group and runs[-1][2] == c - 1:
            runs[-1][2] = c
        else:
            runs.append([group, c, c])
    for group, first, last in runs:
        x0 = left + (tw + gap) * first + gap
        x1 = left + (tw + gap) * last + gap + tw
        w = text_size(group, scale)[0]
        draw_text(out, group, (x0 + x1 - w) // 2, y + pad, text_color, scale)
        if last > first:
            rule = y + pad + line + pad // 2
            out[rule:rule + max(1, scale // 2), x0:x1, :3] = np.asarray(dim_color[:3]) * 0.6
    for c, (_group, word) in enumerate(caps):
        x = left + (tw + gap) * c + gap
        w = text_size(word, scale)[0]
        draw_text(out, word, x + (tw - w) // 2, y + 2 * pad + line, dim_color, scale)
