"""Sample content: the bitmap-font labels of the demo's contact sheet.

Pure NumPy; nothing here imports bpy.
"""

import string
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from sample_scenes.lib import labels  # noqa: E402

FONT_CHARS = string.ascii_letters + string.digits + " .,:;-_+/()[]<>!?%='\"#*"


def test_font_covers_the_documented_characters_with_distinct_glyphs():
    seen = {}
    for ch in FONT_CHARS:
        g = labels.glyph(ch)
        assert g.shape == (labels.GLYPH_H, labels.GLYPH_W) and g.dtype == bool, ch
        if ch != " ":
            assert g.any() and g is not labels.glyph("\x00"), ch
        key = g.tobytes()
        assert key not in seen, f"{ch!r} looks like {seen.get(key)!r}"
        seen[key] = ch
    # Capitals and digits sit on the baseline; only descenders use the two rows below it.
    for ch in string.ascii_uppercase + string.digits:
        assert labels.glyph(ch)[6].any() and not labels.glyph(ch)[7:].any(), ch
    for ch in "gjpqy":
        assert labels.glyph(ch)[7:].any(), ch


def test_text_mask_places_glyphs():
    mask = labels.text_mask("HI")
    assert mask.shape == (9, 11) == labels.text_size("HI")[::-1]
    assert mask[:7, 0].all() and mask[:7, 4].all()  # the two legs of the H
    assert mask[3, :5].all() and not mask[2, 1:4].any()  # its bar, on row 3 only
    assert not mask[:, 5].any()  # the blank column between letters
    assert mask[0, 7:10].all() and mask[6, 7:10].all() and mask[1:6, 8].all()  # the I
    assert not mask[7:].any()  # no descenders
    assert labels.text_mask("").shape == (9, 0) and labels.text_size("") == (0, 9)


def test_scale_repeats_pixels():
    small = labels.text_mask("Ag", scale=1)
    big = labels.text_mask("Ag", scale=3)
    assert big.shape == (27, 33)
    assert np.array_equal(big, np.kron(small, np.ones((3, 3), bool)))


def test_draw_text_inks_only_the_glyph_pixels():
    img = np.zeros((20, 30, 4), np.float32)
    labels.draw_text(img, "Hi", 4, 6, color=(1.0, 0.5, 0.25))
    ink = img[..., 0] > 0
    expected = np.zeros((20, 30), bool)
    expected[6:15, 4:15] = labels.text_mask("Hi")
    assert np.array_equal(ink, expected)
    assert np.all(img[ink, :3] == (1.0, 0.5, 0.25)) and not img[..., 3].any()  # alpha untouched


def test_draw_text_bottom_up_is_the_flipped_image():
    top_down = labels.draw_text(np.zeros((16, 40, 4), np.float32), "Brow 2", 3, 2)
    bottom_up = labels.draw_text(np.zeros((16, 40, 4), np.float32), "Brow 2", 3, 2, bottom_up=True)
    assert top_down.any() and np.array_equal(bottom_up, top_down[::-1])


@pytest.mark.parametrize("x, y", [(-7, -4), (25, 12), (-100, 0), (0, 100), (38, -8)])
def test_draw_text_clips_at_the_borders(x, y):
    img = np.zeros((16, 40, 3), np.float32)
    labels.draw_text(img, "Clip me", x, y)
    big = np.zeros((16 + 200, 40 + 200, 3), np.float32)
    labels.draw_text(big, "Clip me", x + 100, y + 100)
    assert np.array_equal(img, big[100:116, 100:140])


def test_unknown_characters_draw_a_box_and_do_not_stop():
    text = "é€\n\t😀"
    mask = labels.text_mask(text)
    assert mask.shape == labels.text_size(text)[::-1] == (9, 5 * 6 - 1)
    box = mask[:7, :5]
    assert box[0].all() and box[-1].all() and box[:, 0].all() and not box[1:-1, 1:-1].any()
    img = np.zeros((12, 40), np.float32)  # a single-channel image works too
    labels.draw_text(img, "x?" + text, 1, 1, color=(0.5,))
    assert set(np.unique(img)) == {0.0, 0.5}
    labels.draw_text(img, 12345, 0, 0)  # not a string: drawn as its str()


def _tiles(rows, cols, h=40, w=60):
    def tile(k):
        t = np.full((h, w, 4), 0.1 * k, np.float32)
        t[..., 3] = 1.0
        return t

    return [[tile(r * cols + c + 1) for c in range(cols)] for r in range(rows)]


def test_sheet_without_labels_is_the_plain_grid():
    tiles = _tiles(2, 3)
    out = labels.sheet(tiles, gap=8)
    assert out.shape == (2 * 48 + 8, 3 * 68 + 8, 4) and out.dtype == np.float32
    for r in range(2):
        for c in range(3):
            y, x = 48 * r + 8, 68 * c + 8
            assert np.array_equal(out[y:y + 40, x:x + 60], tiles[r][c])
    assert np.all(out[:8, :, :3] == np.float32(0.12)) and np.all(out[..., 3] == 1.0)


def test_sheet_with_labels_keeps_tiles_and_draws_names_and_captions():
    tiles = _tiles(2, 4)
    names = ["head", "scanned_head_maps"]
    caps = [[("Surprise", "without"), ("Surprise", "with"), ("Frowning", "without"), ("Frowning", "with")],
            [("Anger", "without"), ("Anger", "with"), ("Surprise + Anger", "without"),
             ("Surprise + Anger", "with")]]
    gap, scale = 8, 1
    out = labels.sheet(tiles, gap=gap, row_names=names, captions=caps, scale=scale)
    left = labels.text_size("scanned_head_maps")[0] + gap
    head = 2 * 9 + 3 * 3
    row_h = head + 40 + gap
    assert out.shape == (2 * row_h + gap, left + 4 * 68 + gap, 4)
    background = np.float32(0.12)
    for r in range(2):
        top = row_h * r + gap + head
        for c in range(4):
            x = left + 68 * c + gap
            assert np.array_equal(out[top:top + 40, x:x + 60], tiles[r][c])
        # The row's name, left of its tiles and level with them, exactly as its mask.
        y = top + (40 - 9) // 2
        mask = labels.text_mask(names[r])
        ink = out[y:y + 9, gap:gap + mask.shape[1], 0] != background
        assert np.array_equal(ink, mask)
        # Above each pair: the group centred over both tiles; above each tile its word.
        band = out[top - head:top, :, 0] != background
        for pair in range(2):
            x0, x1 = left + 68 * 2 * pair + gap, left + 68 * (2 * pair + 1) + gap + 60
            group = caps[r][2 * pair][0]
            w = labels.text_size(group)[0]
            gx = (x0 + x1 - w) // 2
            assert np.array_equal(band[3:12, gx:gx + w], labels.text_mask(group))
        for c, (_group, word) in enumerate(caps[r]):
            x = left + 68 * c + gap
            w = labels.text_size(word)[0]
            wx = x + (60 - w) // 2
            assert np.array_equal(band[15:24, wx:wx + w], labels.text_mask(word))
    assert np.all(out[..., 3] == 1.0)


def test_sheet_default_scale_follows_the_tile_size():
    def height(width):
        out = labels.sheet(_tiles(1, 2, 64, width), row_names=["a"], captions=[[("b", "c"), ("b", "d")]])
        return out.shape[0] - 64 - 2 * 8  # the caption band: 2 lines of 9 rows and 3 paddings of 3

    assert height(100) == 27 and height(256) == 2 * 27 and height(512) == 3 * 27
