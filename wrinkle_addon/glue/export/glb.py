# SPDX-License-Identifier: GPL-3.0-or-later
"""Reading a glTF (.glb, or .gltf with its .bin) written by Blender's exporter, and one
in-place patch: the normals of the wrinkle morph targets.

Blender's glTF exporter gives every morph target the normal delta of its shape key alone
at full weight.  An engine shades with ``normalize(NORMAL + Σ_t w_t dNORMAL_t)``, linear in
the weights, while the normals of a wrinkled face are not: wrinkles at partial weight, over
an expression made of several shape keys, bend the normal in ways no single key shows (on
the ICT head, 12° off at the 99th percentile with Blender's deltas).  So the export
replaces the wrinkle targets' normal deltas by the least-squares fit over the range
(``core.morphs.fit_normals``) of what the engine is missing on each frame: the live face's
normals minus the engine's normal from everything else.  The accessors are dense float32
(the export asks for no sparse accessors), so the new values go in place, byte for byte,
and nothing else in the file moves.

glTF is Y up: Blender's (x, y, z) is the file's (x, z, -y) (``TO_GLTF``).
"""

import json
import os
import urllib.parse

import numpy as np

TO_GLTF = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}
_TYPES = {5126: np.float32, 5125: np.uint32, 5123: np.uint16, 5121: np.uint8}


class Glb:
    """A .glb's JSON and binary chunk, with its accessors as arrays; or a .gltf's JSON and
    its one .bin file (what Blender's "glTF Separate" writes)."""

    def __init__(self, path):
        self.path = path
        with open(path, "rb") as fh:
            data = fh.read()
        if path.lower().endswith(".gltf"):
            self.json = json.loads(data)
            buffers = self.json.get("buffers", [])
            uri = buffers[0].get("uri", "") if len(buffers) == 1 else ""
            if not uri or uri.startswith("data:"):
                raise ValueError(f"{path} has no single .bin buffer")
            self.bin_path = os.path.join(os.path.dirname(path), urllib.parse.unquote(uri))
            with open(self.bin_path, "rb") as fh:
                self.data = bytearray(fh.read())
            self.bin_start = 0
            return
        if data[:4] != b"glTF" or len(data) < 28:
            raise ValueError(f"{path} is not a binary glTF")
        n = int.from_bytes(data[12:16], "little")
        self.json = json.loads(data[20:20 + n])
        self.bin_start = 20 + n + 8  # the BIN chunk's data
        self.bin_path = path
        self.data = bytearray(data)

    def _span(self, index, offset, count, kind, width):
        view = self.json["bufferViews"][index]
        stride = view.get("byteStride")
        if stride not in (None, width * np.dtype(_TYPES[kind]).itemsize):
            raise ValueError("interleaved buffer views are not read")
        start = self.bin_start + view.get("byteOffset", 0) + offset
        return start, start + count * width * np.dtype(_TYPES[kind]).itemsize

    def accessor(self, i):
        """The values of accessor ``i`` (a sparse one included), (count, components)."""
        acc = self.json["accessors"][i]
        kind, width, count = acc["componentType"], _WIDTH[acc["type"]], acc["count"]
        if "bufferView" in acc:
            a, b = self._span(acc["bufferView"], acc.get("byteOffset", 0), count, kind, width)
            out = np.frombuffer(bytes(self.data[a:b]), _TYPES[kind]).reshape(count, width).copy()
        else:
            out = np.zeros((count, width), _TYPES[kind])
        sparse = acc.get("sparse")
        if sparse:
            ind, val = sparse["indices"], sparse["values"]
            a, b = self._span(ind["bufferView"], ind.get("byteOffset", 0), sparse["count"],
                              ind["componentType"], 1)
            idx = np.frombuffer(bytes(self.data[a:b]), _TYPES[ind["componentType"]])
            a, b = self._span(val["bufferView"], val.get("byteOffset", 0), sparse["count"], kind, width)
            out[idx] = np.frombuffer(bytes(self.data[a:b]), _TYPES[kind]).reshape(-1, width)
        return out

    def overwrite(self, i, values):
        """Put ``values`` into the dense float32 accessor ``i``, in place."""
        acc = self.json["accessors"][i]
        if "bufferView" not in acc or "sparse" in acc or acc["componentType"] != 5126:
            raise ValueError(f"accessor {i} is not a dense float32 accessor")
        values = np.ascontiguousarray(values, "<f4").reshape(acc["count"], _WIDTH[acc["type"]])
        a, b = self._span(acc["bufferView"], acc.get("byteOffset", 0), acc["count"], 5126,
                          _WIDTH[acc["type"]])
        self.data[a:b] = values.tobytes()

    def save(self):
        """Write the binary data back (the .glb, or the .gltf's .bin), through a temporary name."""
        tmp = self.bin_path + ".partial"
        with open(tmp, "wb") as fh:
            fh.write(self.data)
        os.replace(tmp, self.bin_path)

    def mesh(self, name):
        """The first primitive of the mesh called ``name`` and the mesh's target names."""
        for mesh in self.json.get("meshes", []):
            if mesh.get("name") == name:
                return mesh["primitives"][0], mesh.get("extras", {}).get("targetNames", [])
        raise ValueError(f"{self.path} has no mesh {name!r}")

    def weights(self, n_targets):
        """The morph weights (frames, targets) of the file's first animation."""
        for channel in self.json["animations"][0]["channels"]:
            if channel["target"]["path"] == "weights":
                sampler = self.json["animations"][0]["samplers"][channel["sampler"]]
                return self.accessor(sampler["output"]).reshape(-1, n_targets)
        raise ValueError(f"{self.path} animates no morph weights")


def vertex_map(gltf_positions, blender_positions):
    """For each glTF vertex, the Blender vertex at the same position: the exporter splits
    vertices along UV seams, and every copy keeps its vertex's position exactly (float32,
    only the axes swapped).  None when some glTF vertex has no exact twin, or two Blender
    vertices share a position (then the position does not tell them apart)."""
    g = np.asarray(gltf_positions, np.float32) @ TO_GLTF.astype(np.float32)  # file axes to Blender's
    b = np.asarray(blender_positions, np.float32)
    both = np.concatenate([b, g])
    _unique, inverse, counts = np.unique(both, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    of_blender = np.full(len(counts), -1, np.int64)
    of_blender[inverse[: len(b)]] = np.arange(len(b))
    if len(np.unique(inverse[: len(b)])) < len(b):
        return None
    out = of_blender[inverse[len(b):]]
    return None if np.any(out < 0) else out
