#!/usr/bin/env python3
"""Build the project's sample head, ``ict_head.npz`` and ``ict_head_parts.npz``, from ICT-FaceKit.

    python tools/ict_to_npz.py /path/to/ICT-FaceKit [-o wrinkle_addon/data/ict_head.npz]
    python tools/ict_to_npz.py --repack FOLDER [-o wrinkle_addon/data/ict_head.npz]

The input is a checkout of ICT-FaceKit (the ICT Face Model Light, (c) 2020 USC Institute for
Creative Technologies, MIT licence), which is public:

    git clone https://github.com/ICT-VGL/ICT-FaceKit

The project ships the result as its sample data in ``wrinkle_addon/data/`` (the default
output), where the add-on's *Add Sample Head*, the demo, the tests and the benchmarks read
it. The checkout's ``LICENSE`` is copied next to the output as ``<name>.LICENSE``, because
the MIT licence asks for its notice to go with every copy. ``--repack FOLDER`` reads a pair
of files this converter wrote before (``ict_head.npz``, ``ict_head_parts.npz`` and the
licence in FOLDER), checks every array against the layout below, and writes them again.

What is read, from ``<checkout>/FaceXModel/``:

* ``generic_neutral_mesh.obj``: the neutral model, its ``v``, ``vt`` and ``f`` lines;
* ``<name>.obj`` for each of the 53 names in ``EXPRESSIONS``: only the ``v`` lines, which
  must be as many as the neutral's and in the same order (ICT writes every blend shape
  as the full model). The other OBJs of the folder (``identity000.obj`` ... and any other
  shapes) are not read.

The skin, ``ict_head.npz``: ICT's "Face" (vertices 0-9408) and "Head and Neck"
(9409-11247) geometries from the vertex index table of ICT-FaceKit's README, so vertices
0..11247, and the faces whose corners all lie in that range, in file order. Every kept
face must be a quad with UVs.

=====================  =======================  ==========================================
key                    shape, dtype             meaning
=====================  =======================  ==========================================
``positions``          (11248, 3) float32       the neutral vertex positions
``quads``              (F, 4) int32             faces, indexing ``positions`` (11144)
``corner_uvs``         (F, 4, 2) float32        UV of each face corner, in ``quads`` order
``expression_names``   (53,) str                ``EXPRESSIONS``, in that order
``expression_deltas``  (53, 11248, 3) float32   each expression's target minus the neutral
=====================  =======================  ==========================================

The parts, ``<stem>_parts.npz`` beside it: the geometries of ``PARTS`` (same table), each
with the faces whose corners all lie in its range, numbered from 0. The two eyeballs are two
shells each: the outer one, with the cornea's bulge in front, is ``sclera_<side>``; the inner
one, which carries the iris, is ``iris_<side>``. A pair's ``_L`` is the one on +X, the
character's left. The mouth socket, eye sockets and eye blends are not kept.

=================================  ==================  ==================================
key                                shape, dtype        meaning
=================================  ==================  ==================================
``part_names``                     (12,) str           ``PART_NAMES``
``expression_names``               (53,) str           as in the skin's file
``<part>/positions``               (V, 3) float32      neutral positions
``<part>/face_sizes``              (F,) int32          corners per polygon
``<part>/corner_verts``            (sum, ) int32       each polygon's vertices in turn
``<part>/corner_uvs``              (sum, 2) float32    UV of each corner
``<part>/expression_deltas``       (53, V, 3) float16  each expression's target minus neutral
=================================  ==================  ==================================

Units and axes are ICT's: centimetres, Y up. The expression order is fixed:
``EXPRESSIONS`` lists ICT's 53 ARKit-style names sorted as Python sorts strings, which is
also the order of the ``expressions`` list in ICT's ``FaceXModel/vertex_indices.json``.
The deltas are computed from the text in double precision, then stored as float32 (skin)
or float16 (parts, which only follow the blinks and the jaw).

Only the standard library and NumPy are needed (no Blender; the add-on's pure-NumPy
``core.skin.components`` splits the eyeballs). User errors (a missing
folder or OBJ, a wrong vertex count, a malformed line) print one message and exit with
status 1.
"""

from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from wrinkle_addon.core.skin import components  # noqa: E402  (pure NumPy: no Blender needed)

__all__ = ["EXPRESSIONS", "HEAD_VERTICES", "PARTS", "PART_NAMES", "ConversionError", "convert", "repack",
           "build_arrays", "check_skin", "check_parts", "main"]

#: Vertices kept: ICT's "Face" [0:9408] plus "Head and Neck" [9409:11247].
HEAD_VERTICES = 11248

#: ICT's other geometries kept as the parts: name -> (first, last) vertex, both included, from
#: the vertex index table of ICT-FaceKit's README. A pair is named by its side afterwards.
PARTS = {
    "gums_tongue": (14062, 17038),
    "teeth": (17039, 21450),
    "eyeball_a": (21451, 23020),
    "eyeball_b": (23021, 24590),
    "lacrimal_a": (24591, 24794),
    "lacrimal_b": (24795, 24998),
    "eye_occlusion_a": (25047, 25198),
    "eye_occlusion_b": (25199, 25350),
    "eyelashes_a": (25351, 26034),
    "eyelashes_b": (26035, 26718),
}
MODEL_VERTICES = 26719

#: The parts' names in the file, in this order.
PART_NAMES = ("gums_tongue", "teeth", "sclera_L", "iris_L", "sclera_R", "iris_R", "lacrimal_L",
              "lacrimal_R", "eye_occlusion_L", "eye_occlusion_R", "eyelashes_L", "eyelashes_R")
PART_KEYS = ("positions", "face_sizes", "corner_verts", "corner_uvs", "expression_deltas")

NEUTRAL_OBJ = "generic_neutral_mesh.obj"
MODEL_DIR = "FaceXModel"
DEFAULT_OUTPUT = Path(__file__).resolve().parents[1] / "wrinkle_addon" / "data" / "ict_head.npz"

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
    """Read an ICT-FaceKit checkout; return the two dicts of arrays, ``(skin, parts)``, that go
    into ``ict_head.npz`` and ``ict_head_parts.npz``."""
    model = _model_dir(checkout)
    neutral_path = model / NEUTRAL_OBJ
    if log:
        log(f"reading {neutral_path}")
    neutral, uvs, polys = read_obj(neutral_path)
    if len(neutral) < MODEL_VERTICES:
        raise ConversionError(f"{neutral_path}: {len(neutral)} vertices, expected {MODEL_VERTICES} "
                              "(the whole ICT Face Model: skin, eyes, teeth and lashes)")
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
    deltas = np.empty((len(EXPRESSIONS), len(neutral), 3), dtype=np.float32)
    for i, name in enumerate(EXPRESSIONS):
        path = model / f"{name}.obj"
        target, _, _ = read_obj(path, faces=False)
        if len(target) != len(neutral):
            raise ConversionError(f"{path}: {len(target)} vertices, but {NEUTRAL_OBJ} has {len(neutral)}; "
                                  "the blend shapes must come from the same checkout as the neutral mesh")
        deltas[i] = target - neutral  # in float64, then rounded once
        if log:
            log(f"  {i + 1:2d}/{len(EXPRESSIONS)} {name}")
    skin = {
        "positions": neutral[:HEAD_VERTICES].astype(np.float32),
        "quads": np.array(quads, dtype=np.int32),
        "corner_uvs": uvs[np.array(corner_uv_index)].astype(np.float32),
        "expression_names": np.array(EXPRESSIONS, dtype=str),
        "expression_deltas": np.ascontiguousarray(deltas[:, :HEAD_VERTICES]),
    }
    return skin, _parts(neutral, uvs, polys, deltas, neutral_path)


def _part_faces(polys, uvs, first, last, path):
    """(face_sizes, corner_verts, corner_uv_index) of the faces whose corners all lie in
    [first, last], the vertices numbered from ``first``."""
    sizes, verts, uv_index = [], [], []
    for lineno, corners in polys:
        index = [v for v, _ in corners]
        if min(index) < first or max(index) > last:
            continue
        ts = [t for _, t in corners]
        if any(t is None or not 0 <= t < len(uvs) for t in ts):
            raise ConversionError(f"{path}:{lineno}: a face of the eyes, teeth or lashes without valid UVs")
        sizes.append(len(corners))
        verts += [v - first for v in index]
        uv_index += ts
    if not sizes:
        raise ConversionError(f"{path}: no face lies within vertices {first}..{last}")
    return np.array(sizes, np.int32), np.array(verts, np.int32), np.array(uv_index, np.int64)


def _subset(part, keep):
    """The vertices ``keep`` (bool mask) of a part and the faces all of whose corners they hold."""
    sizes, corner_verts = part["face_sizes"], part["corner_verts"]
    face = np.repeat(np.arange(len(sizes)), sizes)
    inside = np.ones(len(sizes), bool)
    np.logical_and.at(inside, face, keep[corner_verts])
    corners = inside[face]
    number = np.cumsum(keep) - 1
    return {
        "positions": part["positions"][keep],
        "face_sizes": sizes[inside],
        "corner_verts": number[corner_verts[corners]].astype(np.int32),
        "corner_uvs": part["corner_uvs"][corners],
        "expression_deltas": part["expression_deltas"][:, keep],
    }


def _parts(neutral, uvs, polys, deltas, path):
    found = {}
    for name, (first, last) in PARTS.items():
        sizes, corner_verts, uv_index = _part_faces(polys, uvs, first, last, path)
        part = {
            "positions": neutral[first:last + 1].astype(np.float32),
            "face_sizes": sizes,
            "corner_verts": corner_verts,
            "corner_uvs": uvs[uv_index].astype(np.float32),
            "expression_deltas": deltas[:, first:last + 1].astype(np.float16),
        }
        paired = name.endswith(("_a", "_b"))
        base = name[:-2] if paired else name
        pieces = {base: part}
        if base == "eyeball":  # two shells: the outer (cornea's bulge) and the inner (iris)
            label = components(len(part["positions"]), sizes, corner_verts)
            if label.max() != 1:
                raise ConversionError(f"{path}: the eyeball at vertices {first}..{last} should be two "
                                      f"shells, found {label.max() + 1}")
            pos = part["positions"].astype(np.float64)
            reach = [np.linalg.norm(pos[label == k] - pos.mean(axis=0), axis=1).mean() for k in (0, 1)]
            outer = int(np.argmax(reach))
            pieces = {"sclera": _subset(part, label == outer), "iris": _subset(part, label != outer)}
        side = "L" if float(part["positions"][:, 0].mean()) > 0.0 else "R"
        for base, piece in pieces.items():
            found[f"{base}_{side}" if paired else base] = piece
    if set(found) != set(PART_NAMES):
        raise ConversionError(f"{path}: the pairs of eyes, lacrimal fluids, occlusions and lashes should "
                              f"lie one on each side; found {sorted(found)}")
    parts = {"part_names": np.array(PART_NAMES, dtype=str),
             "expression_names": np.array(EXPRESSIONS, dtype=str)}
    for name in PART_NAMES:
        for key in PART_KEYS:
            parts[f"{name}/{key}"] = found[name][key]
    return parts


_SKIN_LAYOUT = {"positions": ((HEAD_VERTICES, 3), "float32"), "quads": ((None, 4), "int32"),
                "corner_uvs": ((None, 4, 2), "float32"), "expression_names": ((len(EXPRESSIONS),), "U"),
                "expression_deltas": ((len(EXPRESSIONS), HEAD_VERTICES, 3), "float32")}


def _check_array(where, key, array, shape, dtype):
    kind_ok = array.dtype.kind == "U" if dtype == "U" else array.dtype == np.dtype(dtype)
    shape_ok = array.ndim == len(shape) and all(s is None or s == a for s, a in zip(shape, array.shape))
    if not (kind_ok and shape_ok):
        want = "x".join("F" if s is None else str(s) for s in shape)
        raise ConversionError(f"{where}: {key} is {array.dtype} {array.shape}, expected {dtype} ({want})")
    if array.dtype.kind == "f" and not np.isfinite(array).all():
        raise ConversionError(f"{where}: {key} holds NaN or infinite values")


def check_skin(skin, where="ict_head.npz"):
    """Raise ConversionError unless ``skin`` has the layout of ``ict_head.npz``."""
    for key, (shape, dtype) in _SKIN_LAYOUT.items():
        if key not in skin:
            raise ConversionError(f"{where}: no {key}")
        _check_array(where, key, skin[key], shape, dtype)
    if tuple(skin["expression_names"]) != EXPRESSIONS:
        raise ConversionError(f"{where}: the expressions are not ICT's 53, in their order")
    if len(skin["corner_uvs"]) != len(skin["quads"]) or skin["quads"].min() < 0 \
            or skin["quads"].max() >= HEAD_VERTICES:
        raise ConversionError(f"{where}: the quads do not match the vertices and corner UVs")


def check_parts(parts, where="ict_head_parts.npz"):
    """Raise ConversionError unless ``parts`` has the layout of ``ict_head_parts.npz``."""
    for key in ("part_names", "expression_names"):
        if key not in parts:
            raise ConversionError(f"{where}: no {key}")
    if tuple(parts["part_names"]) != PART_NAMES or tuple(parts["expression_names"]) != EXPRESSIONS:
        raise ConversionError(f"{where}: the parts or expressions are not {PART_NAMES} and ICT's 53")
    for name in PART_NAMES:
        missing = [k for k in PART_KEYS if f"{name}/{k}" not in parts]
        if missing:
            raise ConversionError(f"{where}: {name} has no {', '.join(missing)}")
        pos, sizes, verts, uv, dl = (parts[f"{name}/{k}"] for k in PART_KEYS)
        _check_array(where, f"{name}/positions", pos, (None, 3), "float32")
        _check_array(where, f"{name}/face_sizes", sizes, (None,), "int32")
        _check_array(where, f"{name}/corner_verts", verts, (int(sizes.sum()),), "int32")
        _check_array(where, f"{name}/corner_uvs", uv, (len(verts), 2), "float32")
        _check_array(where, f"{name}/expression_deltas", dl, (len(EXPRESSIONS), len(pos), 3), "float16")
        if sizes.min() < 3 or verts.min() < 0 or verts.max() >= len(pos):
            raise ConversionError(f"{where}: {name}'s faces do not match its vertices")


def _write(out, skin, parts, licence):
    parts_out = parts_path(out)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(out, **skin)
        np.savez_compressed(parts_out, **parts)
        if licence is not None and licence.is_file() \
                and licence.resolve() != out.with_suffix(".LICENSE").resolve():
            shutil.copyfile(licence, out.with_suffix(".LICENSE"))
    except OSError as exc:
        raise ConversionError(f"cannot write {out}: {exc.strerror or exc}") from None


def parts_path(out):
    """Where the parts go next to the skin's ``out``: ``<stem>_parts.npz``."""
    out = Path(out)
    return out.with_name(out.stem + "_parts.npz")


def _output(out):
    out = Path(out)
    if out.suffix != ".npz":
        raise ConversionError(f"{out}: the output file name must end in .npz")
    return out


def convert(checkout, out, log=None):
    """Write ``out`` and its parts (``parts_path(out)``) from an ICT-FaceKit checkout; return
    the arrays written, ``(skin, parts)``."""
    out = _output(out)
    skin, parts = build_arrays(checkout, log=log)
    check_skin(skin)
    check_parts(parts)
    _write(out, skin, parts, Path(checkout) / "LICENSE")
    return skin, parts


def repack(folder, out, log=None):
    """Check the pair of files this converter wrote in ``folder`` and write them again at
    ``out``; return ``(skin, parts)``."""
    folder, out = Path(folder), _output(out)
    arrays = []
    for path, check in ((folder / "ict_head.npz", check_skin), (folder / "ict_head_parts.npz", check_parts)):
        if log:
            log(f"reading {path}")
        try:
            with np.load(path) as data:
                found = {k: data[k] for k in data.files}
        except (OSError, ValueError) as exc:
            raise ConversionError(f"cannot read {path}: {exc}") from None
        check(found, str(path))
        arrays.append(found)
    _write(out, *arrays, folder / "ict_head.LICENSE")
    return tuple(arrays)


def main(argv=None):
    parser = argparse.ArgumentParser(
        description="Build ict_head.npz (the skin of the ICT Face Model Light with its 53 expression "
                    "blend shapes) and ict_head_parts.npz (its eyes, teeth and lashes) from an "
                    "ICT-FaceKit checkout (git clone https://github.com/ICT-VGL/ICT-FaceKit; MIT licence).")
    parser.add_argument("checkout", help="the ICT-FaceKit folder (the one holding FaceXModel/), or with "
                                         "--repack a folder holding ict_head.npz and ict_head_parts.npz")
    parser.add_argument("--repack", action="store_true",
                        help="check and write again a pair of files this converter wrote")
    parser.add_argument("-o", "--output", default=str(DEFAULT_OUTPUT),
                        help="the skin's .npz to write; the parts go beside it as <name>_parts.npz "
                             "(default: the add-on's sample data, wrinkle_addon/data/ict_head.npz)")
    parser.add_argument("-q", "--quiet", action="store_true", help="print only errors")
    args = parser.parse_args(argv)

    def log(msg):
        if not args.quiet:
            print(msg, flush=True)

    try:
        skin, parts = (repack if args.repack else convert)(args.checkout, args.output, log=log)
    except ConversionError as exc:
        print(f"ict_to_npz: error: {exc}", file=sys.stderr)
        return 1
    log(f"wrote {args.output}: {len(skin['positions'])} vertices, {len(skin['quads'])} quads, "
        f"{len(skin['expression_names'])} expressions")
    log(f"wrote {parts_path(args.output)}: {len(parts['part_names'])} parts, "
        f"{sum(len(parts[f'{n}/positions']) for n in PART_NAMES)} vertices")
    return 0


if __name__ == "__main__":
    sys.exit(main())
