#!/usr/bin/env python3
"""Write a head the benchmarks have never seen: the ICT head with another face.

    python tools/variant_head.py [ICT_HEAD.npz] [-o variant_head.npz]
    .venv45/bin/python benchmarks/realism.py --faces ict --npz variant_head.npz

The input (by default the add-on's sample head, ``wrinkle_addon/data/ict_head.npz``) is
rewritten with the same keys, shapes and dtypes (``positions``, ``quads``, ``corner_uvs``,
``expression_names``, ``expression_deltas``; centimetres, Y up, the face toward +Z), so
anything that reads the ICT head reads this one.  The topology and UVs are kept; the
identity is changed by one smooth warp W of the positions (ICT's frame, cm):

* a narrower, longer face: x scaled by 0.94 (and the lower face by up to 4 % more, a
  narrower jaw), y stretched by 1.07 about y = 2 cm (between the nose tip and the eyes);
* a heavier brow ridge: the brows and the glabella 3 mm further forward (a Gaussian band
  0.9 cm high about y = 5.3 cm, flat across to about +-5 cm);
* fuller cheeks: two Gaussian swellings (1.8 cm wide, at x = +-4.2 cm, y = 0.3 cm) 3 mm
  forward and 2 mm outward;
* a stronger chin: 2 mm forward about y = -6.2 cm.

The swellings act on the front of the head only (a smoothstep over z from 2 to 8 cm), so
the back of the skull and the neck keep their shape.  Each expression's target is warped
with the same map: its delta becomes W(neutral + delta) - W(neutral), which to first
order is W's Jacobian applied to the delta, so the expressions compress the new face as
they did the old.  The ICT model's MIT licence notice is copied next to the output as
``<name>.LICENSE`` (the file is a derivative of it).
"""

import argparse
import shutil
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_SOURCE = ROOT / "wrinkle_addon" / "data" / "ict_head.npz"


def _smoothstep(t):
    t = np.clip(t, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def warp(p):
    """W: (..., 3) ICT positions (cm, Y up, face +Z) -> the variant's positions."""
    p = np.asarray(p, np.float64)
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    front = _smoothstep((z - 2.0) / 6.0)
    dx = np.zeros_like(x)
    dz = np.zeros_like(z)
    # heavier brow ridge
    dz += 0.30 * np.exp(-(((y - 5.3) / 0.9) ** 2)) * np.exp(-((x / 5.0) ** 4)) * front
    # fuller cheeks
    for s in (1.0, -1.0):
        bump = np.exp(-(((x - s * 4.2) / 1.8) ** 2 + ((y - 0.3) / 1.8) ** 2)) * front
        dx += s * 0.20 * bump
        dz += 0.30 * bump
    # stronger chin
    dz += 0.20 * np.exp(-(((y + 6.2) / 1.2) ** 2)) * np.exp(-((x / 2.5) ** 2)) * front
    # narrower (the jaw more) and longer
    narrow = 0.94 * (1.0 - 0.04 * _smoothstep((-y - 1.0) / 5.0))
    out = np.empty_like(p)
    out[..., 0] = (x + dx) * narrow
    out[..., 1] = 2.0 + (y - 2.0) * 1.07
    out[..., 2] = z + dz
    return out


def variant(data):
    """The variant head's arrays from the ICT head's (a dict or ``NpzFile``)."""
    pos = np.asarray(data["positions"], np.float64)
    deltas = np.asarray(data["expression_deltas"], np.float64)
    new_pos = warp(pos)
    new_deltas = warp(pos[None] + deltas) - new_pos[None]
    return {
        "positions": new_pos.astype(np.float32),
        "quads": np.asarray(data["quads"], np.int32),
        "corner_uvs": np.asarray(data["corner_uvs"], np.float32),
        "expression_names": np.asarray(data["expression_names"]),
        "expression_deltas": new_deltas.astype(np.float32),
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("source", nargs="?", default=str(DEFAULT_SOURCE), help="the ICT head (ict_head.npz)")
    ap.add_argument("-o", "--out", default="variant_head.npz", help="the file to write")
    args = ap.parse_args(argv)
    src, out = Path(args.source), Path(args.out)
    with np.load(src) as data:
        arrays = variant(data)
    np.savez_compressed(out, **arrays)
    licence = src.with_suffix(".LICENSE")
    if licence.exists():
        shutil.copyfile(licence, out.with_suffix(".LICENSE"))
    moved = np.linalg.norm(arrays["positions"] - np.load(src)["positions"], axis=1)
    print(f"{out}: {len(arrays['positions'])} vertices moved by up to {moved.max():.2f} cm "
          f"(median {np.median(moved):.2f} cm), {len(arrays['expression_names'])} expressions")
    return 0


if __name__ == "__main__":
    sys.exit(main())
