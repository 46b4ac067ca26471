# SPDX-License-Identifier: GPL-3.0-or-later
"""Read the points of the mesh in a USD file at some time codes, with usd-core's ``pxr``.

    python tests/tools/usd_points.py FILE FRAME [FRAME ...] [--prim PATH]

prints one JSON object on stdout:

* ``prim``: the path of the mesh prim (the only ``UsdGeom.Mesh`` in the file, or ``--prim``);
* ``metersPerUnit``, ``upAxis``, ``timeCodesPerSecond``, ``startTimeCode``, ``endTimeCode``:
  the stage's metadata;
* ``samples``: the time codes at which ``points`` is authored;
* ``primvars``: the names of the mesh's authored primvars; ``blendShapes``: whether it is bound
  to UsdSkel blend shapes; ``subdivisionScheme``; ``faces``: its face count; ``material``: the
  path of the material bound to it ("" if none); ``surface``: what a ``UsdPreviewSurface``
  consumer reads from that material (:func:`surface`);
* ``frames``: for each FRAME, ``points`` (the mesh's own points, a flat list) and ``world``
  (the same points through the prim's local-to-world transform, in the stage's up axis).

It runs in a process of its own: Blender's bundled USD and usd-core's ``pxr`` are two builds of
the same libraries, which must not meet in one process.
"""

import argparse
import json
import os
import sys

import numpy as np
from pxr import Usd, UsdGeom, UsdShade, UsdSkel


def _mesh(stage, path):
    if path:
        prim = stage.GetPrimAtPath(path)
        if not prim or not prim.IsA(UsdGeom.Mesh):
            raise SystemExit(f"no mesh prim at {path}")
        return prim
    meshes = [p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh)]
    if len(meshes) != 1:
        raise SystemExit(f"expected one mesh prim, found {[str(p.GetPath()) for p in meshes]}")
    return meshes[0]


def _source(shader_input):
    """What feeds a shader input: the feeding shader's id and output, and for a texture its
    file (as written and whether it resolves to a file on disk) and the primvar its ``st``
    reads; for a primvar reader, its ``varname``."""
    sources = shader_input.GetConnectedSources()[0]
    if not sources:
        return None
    info = sources[0]
    shader = UsdShade.Shader(info.source.GetPrim())
    out = {"id": str(shader.GetIdAttr().Get()), "output": str(info.sourceName)}
    file_input = shader.GetInput("file")
    if file_input:
        asset = file_input.Get()
        out["file"] = asset.path if asset else ""
        out["exists"] = bool(asset and asset.resolvedPath and os.path.isfile(asset.resolvedPath))
    varname = shader.GetInput("varname")
    if varname:
        out["varname"] = str(varname.Get())
    st = shader.GetInput("st")
    if st:
        out["st"] = _source(st)
    return out


def surface(material):
    """{input: {"value": ..., "from": _source}} of the material's UsdPreviewSurface."""
    if not material:
        return {}
    shader = material.ComputeSurfaceSource()[0]
    if not shader:
        return {}
    out = {"id": str(shader.GetIdAttr().Get())}
    for inp in shader.GetInputs():
        value = inp.Get()
        out[inp.GetBaseName()] = {"value": list(value) if hasattr(value, "__len__") else value,
                                  "from": _source(inp)}
    return out


def read(filepath, frames, prim_path=None):
    stage = Usd.Stage.Open(filepath)
    if stage is None:
        raise SystemExit(f"could not open {filepath}")
    prim = _mesh(stage, prim_path)
    mesh = UsdGeom.Mesh(prim)
    points = mesh.GetPointsAttr()
    material = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()[0]
    out = {
        "prim": str(prim.GetPath()),
        "metersPerUnit": UsdGeom.GetStageMetersPerUnit(stage),
        "upAxis": str(UsdGeom.GetStageUpAxis(stage)),
        "timeCodesPerSecond": stage.GetTimeCodesPerSecond(),
        "startTimeCode": stage.GetStartTimeCode(),
        "endTimeCode": stage.GetEndTimeCode(),
        "samples": list(points.GetTimeSamples()),
        "primvars": sorted(str(p.GetPrimvarName()) for p in UsdGeom.PrimvarsAPI(prim).GetAuthoredPrimvars()),
        "blendShapes": bool(UsdSkel.BindingAPI(prim).GetBlendShapeTargetsRel().GetTargets()),
        "subdivisionScheme": str(mesh.GetSubdivisionSchemeAttr().Get()),
        "faces": len(mesh.GetFaceVertexCountsAttr().Get() or ()),
        "material": str(material.GetPath()) if material else "",
        "surface": surface(material),
        "frames": {},
    }
    for frame in frames:
        time = Usd.TimeCode(frame)
        local = np.asarray(points.Get(time), np.float64).reshape(-1, 3)
        # USD's matrices act on row vectors: world = [p, 1] @ M
        matrix = np.asarray(UsdGeom.XformCache(time).GetLocalToWorldTransform(prim), np.float64)
        world = local @ matrix[:3, :3] + matrix[3, :3]
        out["frames"][str(frame)] = {"points": local.ravel().tolist(), "world": world.ravel().tolist()}
    return out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("file")
    parser.add_argument("frames", nargs="+", type=float)
    parser.add_argument("--prim", default=None, help="the mesh prim's path (default: the only mesh)")
    args = parser.parse_args(argv)
    frames = [int(f) if f.is_integer() else f for f in args.frames]
    json.dump(read(args.file, frames, args.prim), sys.stdout)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
