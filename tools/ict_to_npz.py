#!/usr/bin/env python3
"""Build ``ict_head.npz``, the scanned head used by tests, benchmarks and the demo, from ICT-FaceKit.

    python tools/ict_to_npz.py /path/to/ICT-FaceKit [-o ict_head.npz]

The input is a checkout of ICT-FaceKit (the ICT Face Model Light, (c) 2020 USC Institute for
Creative Technologies, MIT licence), which is public:

    git clone https://github.com/ICT-VGL/ICT-FaceKit

The project reads the result from ``../shared/data/ict_head.npz``, next to the repository
(``-o ../shared/data/ict_head.npz`` from the repository root). Never copy it into the
repository. The checkout's ``LICENSE`` is copied next to the output as ``<name>.LICENSE``,
because the MIT licence asks for its notice to go with every copy.

What is read, from ``<checkout>/FaceXModel/``:

* ``generic_neutral_mesh.obj``: the neutral model, its ``v``, ``vt`` and ``f`` lines;
* ``<name>.obj`` for each of the 53 names in ``EXPRESSIONS``: only the ``v`` lines, which
  must be as many as the neutral's and in the same order (ICT writes every blend shape
  as the full model). The other OBJs of the folder (``identity000.obj`` ... and any other
  shapes) are not read.

What is kept: the skin, that is ICT's "Face" (vertices 0-9408) and "Head and Neck"
(9409-11247) geometries from the vertex index table of ICT-FaceKit's README, so vertices
0..11247, and the faces whose corners all lie in that range, in file order. The mouth
socket, eyes, teeth, gums, lacrimal fluid, eye blend and occlusion meshes and eyelashes
come after it in the file and are dropped. Every kept face must be a quad with UVs.

The file written (``numpy.load`` reads it; units and axes unchanged: centimetres, Y up):

=====================  =======================  ==========================================
key                    shape, dtype             meaning
=====================  =======================  ==========================================
``positions``          (11248, 3) float32       the neutral vertex positions
``quads``              (F, 4) int32             faces, indexing ``positions`` (11144)
``corner_uvs``         (F, 4, 2) float32        UV of each face corner, in ``quads`` order
``expression_names``   (53,) str                ``EXPRESSIONS``, in that order
``expression_deltas``  (53, 11248, 3) float32   each expression's target minus the neutral
=====================  =======================  ==========================================

The expression order is fixed: ``EXPRESSIONS`` lists ICT's 53 ARKit-style names sorted as
Python sorts strings, which is also the order of the ``expressions`` list in ICT's
``FaceXModel/vertex_indices.json``, and the order of the file the project has always
used. The deltas are computed from the text in double precision, then stored as float32.

Only the standard library and NumPy are needed (no Blender). User errors (a missing
folder or OBJ, a wrong vertex count, a malformed line) print one message and exit with
status 1.
"""

from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path

import numpy as np

__all__ = ["EXPRESSIONS", "HEAD_VERTICES", "ConversionError", "convert", "build_arrays", "main"]

#: Vertices kept: ICT's "Face" [0:9408] plus "Head and Neck" [9409:11247].
HEAD_VERTICES = 11248

NEUTRAL_OBJ = "generic_neutral_mesh.obj"
MODEL_DIR = "FaceXModel"

#: ICT-FaceKit's 53 expression blend shapes, in the order they are stored.
EXPRESSIONS = (
    "browDown_L", "browDown_R", "browInnerUp_L", "browInnerUp_R", "browOuterUp_L",
    "browOuterUp_R", "cheekPuff_L", "cheekPuff_R", "cheekSquint_L", "cheekSquint_R",
    "eyeBlink_L", "eyeBlink_R", "eyeLookDown_L", "eyeLookDown_R", "eyeLookIn_L",
    "eyeLookIn_R", "eyeLookOut_L", "eyeLookOut_R", "eyeLookUp_L", "eyeLookUp_R",
    "eyeSquint_L", "eyeSquint_R", "eyeWide_L", "eyeWide_R", "jawForward", "jawLeft",
    "jawOpen", "jawRight", "mouthClose", "mouthDimple_L", "mouthDimple_R", "mouthFrown_L",
    "mouthFrown_R", "mouthFunnel", "mouthLeft", "mouthLowerDown_L", "mouthLowerDown_R",
    "mouthPress_L", "mouthPress_R", "mouthPucker", "mouthRight", "mouthRollLower",
    "mouthRollUpper", "mouthShrugLower", "mouthShrugUpper", "mouthSmile_L", "mouthSmile_R",
    "mouthStretch_L", "mouthStretch_R", "mouthUpperUp_L", "mouthUpperUp_R", "noseSneer_L",
    "noseSneer_R",
)


class ConversionError(Exception):
    """A problem with the input, reported to the user without a traceback."""


def _floats(tokens, count, path, lineno):
    if len(tokens) < count:
        raise ConversionError(f"{path}:{lineno}: expected {count} numbers, got {' '.join(tokens)!r}")
    try:
        return [float(t) for t in tokens[:count]]
    except ValueError:
        raise ConversionError(f"{path}:{lineno}: not a number in {' '.join(tokens)!r}") from None


def read_obj(path, faces=True):
    """The ``v`` positions (float64, (N, 3)) of an OBJ file, and with ``faces`` its ``vt``
    UVs (float64, (T, 2)) and faces (a list of ``(line, [(v, vt), ...])`` with 0-based
    indices, ``vt`` None when absent). Other lines are ignored."""
    path = Path(path)
    verts, uvs, polys = [], [], []
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            for lineno, line in enumerate(f, 1):
                if line.startswith("v "):
                    verts.append(_floats(line.split()[1:], 3, path, lineno))
                elif not faces:
                    continue
                elif line.startswith("vt "):
                    uvs.append(_floats(line.split()[1:], 2, path, lineno))
                elif line.startswith("f "):
                    polys.append((lineno, [_corner(c, len(verts), len(uvs), path, lineno)
                                           for c in line.split()[1:]]))
    except OSError as exc:
        raise ConversionError(f"cannot read {path}: {exc.strerror or exc}") from None
    return (np.array(verts, dtype=np.float64).reshape(-1, 3),
            np.array(uvs, dtype=np.float64).reshape(-1, 2), polys)


def _corner(token, nverts, nuvs, path, lineno):
    """``v``, ``v/vt``, ``v//vn`` or ``v/vt/vn`` (1-based, or negative = from the end so far)."""
    parts = token.split("/")
    try:
        v = int(parts[0])
        vt = int(parts[1]) if len(parts) > 1 and parts[1] else None
    except ValueError:
        raise ConversionError(f"{path}:{lineno}: bad face corner {token!r}") from None
    v = v - 1 if v > 0 else nverts + v
    if vt is not None:
        vt = vt - 1 if vt > 0 else nuvs + vt
    return v, vt


def _model_dir(checkout):
    checkout = Path(checkout)
    if not checkout.is_dir():
        raise ConversionError(f"{checkout} is not a folder: give the path of an ICT-FaceKit checkout "
                              "(git clone https://github.com/ICT-VGL/ICT-FaceKit)")
    model = checkout / MODEL_DIR
    if not model.is_dir():
        raise ConversionError(f"{checkout} has no {MODEL_DIR} folder: is it an ICT-FaceKit checkout? "
                              "(git clone https://github.com/ICT-VGL/ICT-FaceKit)")
    missing = [n for n in (NEUTRAL_OBJ, *(f"{e}.obj" for e in EXPRESSIONS)) if not (model / n).is_file()]
    if missing:
        shown = ", ".join(missing[:5]) + (f" and {len(missing) - 5} more" if len(missing) > 5 else "")
        raise ConversionError(f"{model} lacks {len(missing)} of the OBJ files needed: {shown}")
    return model


def build_arrays(checkout, log=None):
    """Read an ICT-FaceKit checkout; return the dict of arrays that goes into the npz."""
    model = _model_dir(checkout)
    neutral_path = model / NEUTRAL_OBJ
    if log:
        log(f"reading {neutral_path}")
    neutral, uvs, polys = read_obj(neutral_path)
    if len(neutral) < HEAD_VERTICES:
        raise ConversionError(f"{neutral_path}: {len(neutral)} vertices, expected at least "
                              f"{HEAD_VERTICES} (the face, head and neck of the ICT model)")
    quads, corner_uv_index = [], []
    for lineno, corners in polys:
        index = [v for v, _ in corners]
        if min(index) < 0 or max(index) >= len(neutral):
            raise ConversionError(f"{neutral_path}:{lineno}: face refers to a vertex that does not exist")
        if max(index) >= HEAD_VERTICES:
            continue  # mouth socket, eyes, teeth ...: not the skin
        if len(corners) != 4:
            raise ConversionError(f"{neutral_path}:{lineno}: a face of the head with {len(corners)} "
                                  "corners; the head should be all quads")
        uv_index = [t for _, t in corners]
        if any(t is None or not 0 <= t < len(uvs) for t in uv_index):
            raise ConversionError(f"{neutral_path}:{lineno}: a face of the head without valid UVs")
        quads.append(index)
        corner_uv_index.append(uv_index)
    if not quads:
        raise ConversionError(f"{neutral_path}: no face lies within the first {HEAD_VERTICES} vertices")
    head = neutral[:HEAD_VERTICES]
    deltas = np.empty((len(EXPRESSIONS), HEAD_VERTICES, 3), dtype=np.float32)
    for i, name in enumerate(EXPRESSIONS):
        path = model / f"{name}.obj"
        target, _, _ = read_obj(path, faces=False)
        if len(target) != len(neutral):
            raise ConversionError(f"{path}: {len(target)} vertices, but {NEUTRAL_OBJ} has {len(neutral)}; "
                                  "the blend shapes must come from the same checkout as the neutral mesh")
        deltas[i] = target[:HEAD_VERTICES] - head
        if log:
            log(f"  {i + 1:2d}/{len(EXPRESSIONS)} {name}")
    return {
        "positions": head.astype(np.float32),
        "quads": np.array(quads, dtype=np.int32),
        "corner_uvs": uvs[np.array(corner_uv_index)].astype(np.float32),
        "expression_names": np.array(EXPRESSIONS, dtype=str),
        "expression_deltas": deltas,
    }


def convert(checkout, out, log=None):
    """Write ``out`` (an .npz) from an ICT-FaceKit checkout; return the arrays written."""
    out = Path(out)
    if out.suffix != ".npz":
        raise ConversionError(f"{out}: the output file name must end in .npz")
    arrays = build_arrays(checkout, log=log)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(out, **arrays)
        licence = Path(checkout) / "LICENSE"
        if licence.is_file():
            shutil.copyfile(licence, out.with_suffix(".LICENSE"))
    except OSError as exc:
        raise ConversionError(f"cannot write {out}: {exc.strerror or exc}") from None
    return arrays


def main(argv=None):
    parser = argparse.ArgumentParser(
        description="Build ict_head.npz (the skin of the ICT Face Model Light with its 53 expression "
                    "blend shapes) from an ICT-FaceKit checkout "
                    "(git clone https://github.com/ICT-VGL/ICT-FaceKit; MIT licence).")
    parser.add_argument("checkout", help="the ICT-FaceKit folder (the one holding FaceXModel/)")
    parser.add_argument("-o", "--output", default="ict_head.npz",
                        help="the .npz to write (default: ict_head.npz); the project reads "
                             "../shared/data/ict_head.npz")
    parser.add_argument("-q", "--quiet", action="store_true", help="print only errors")
    args = parser.parse_args(argv)

    def log(msg):
        if not args.quiet:
            print(msg, flush=True)

    try:
        arrays = convert(args.checkout, args.output, log=log)
    except ConversionError as exc:
        print(f"ict_to_npz: error: {exc}", file=sys.stderr)
        return 1
    log(f"wrote {args.output}: {len(arrays['positions'])} vertices, {len(arrays['quads'])} quads, "
        f"{len(arrays['expression_names'])} expressions")
    return 0


if __name__ == "__main__":
    sys.exit(main())
