"""tools/ict_to_npz.py: an ICT-FaceKit folder of OBJ files back to the sample head's two files.

The ICT-style folder is written here from the shipped ict_head.npz and ict_head_parts.npz
themselves, in the full model's vertex layout (skin, mouth socket, eye sockets, gums, teeth,
eyeballs, lacrimal fluid, eye blends, occlusion, lashes), the pairs and the eyeball's two
shells in an order the converter must not rely on, so the round trip checks the cropping,
the splitting, the naming, the expression order and the values exactly. Pure NumPy.
"""

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
TOOL = ROOT / "tools" / "ict_to_npz.py"
DATA = ROOT / "wrinkle_addon" / "data"
ICT_PATH = DATA / "ict_head.npz"
PARTS_PATH = DATA / "ict_head_parts.npz"
KEYS = ("positions", "quads", "corner_uvs", "expression_names", "expression_deltas")

_spec = importlib.util.spec_from_file_location("ict_to_npz", TOOL)
ict_to_npz = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(ict_to_npz)

# Where each shipped part goes in the model (ICT's table), written in this order: the right
# eye's geometries in the first of each pair's ranges, and the eyeball's inner shell first.
LAYOUT = (("gums_tongue", ("gums_tongue",)), ("teeth", ("teeth",)),
          ("eyeball_a", ("iris_R", "sclera_R")), ("eyeball_b", ("sclera_L", "iris_L")),
          ("lacrimal_a", ("lacrimal_R",)), ("lacrimal_b", ("lacrimal_L",)),
          ("eye_occlusion_a", ("eye_occlusion_L",)), ("eye_occlusion_b", ("eye_occlusion_R",)),
          ("eyelashes_a", ("eyelashes_R",)), ("eyelashes_b", ("eyelashes_L",)))


@pytest.fixture(scope="module")
def shared():
    with np.load(ICT_PATH) as data:
        return {k: data[k] for k in KEYS}


@pytest.fixture(scope="module")
def shared_parts():
    with np.load(PARTS_PATH) as data:
        return {k: data[k] for k in data.files}


def _v_lines(points):
    # repr of the float64 value: reading it back gives exactly the same double.
    return "".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in points.tolist())


HEADER = "# ICT FaceKit (test copy written from ict_head.npz)\nmtllib ICTFaceModelMaterial.mtl\n"


def _model(data, parts):
    """The full model's neutral positions (float64) and, per expression row, its deltas, with
    its faces as OBJ lines (1-based ``v/vt``) and the vt list; the geometries the converter
    drops are filler points with quads among them."""
    rng = np.random.default_rng(7)
    pos = [data["positions"].astype(np.float64)]
    deltas = [data["expression_deltas"].astype(np.float64)]
    faces, vts = [], [data["corner_uvs"].reshape(-1, 2)]
    faces += ["f " + " ".join(f"{v + 1}/{4 * i + k + 1}" for k, v in enumerate(q)) + "\n"
              for i, q in enumerate(data["quads"].tolist())]
    count = len(pos[0])

    def filler(first, last):
        nonlocal count
        assert count == first
        n = last - first + 1
        pos.append(rng.normal(0.0, 5.0, (n, 3)))
        deltas.append(rng.normal(0.0, 0.1, (len(deltas[0]), n, 3)))
        faces.extend(f"f {first + j + 1} {first + j + 2} {first + j + 3} {first + j + 4}\n"
                     for j in range(0, n - 4, 4))
        count += n

    filler(11248, 14061)  # mouth socket and eye sockets
    nvt = len(vts[0])
    for geometry, names in LAYOUT:
        first, last = ict_to_npz.PARTS[geometry]
        if geometry == "eye_occlusion_a":
            filler(24999, 25046)  # eye blends
        assert count == first
        for name in names:
            p = {k: parts[f"{name}/{k}"] for k in ict_to_npz.PART_KEYS}
            pos.append(p["positions"].astype(np.float64))
            deltas.append(p["expression_deltas"].astype(np.float64))
            vts.append(p["corner_uvs"])
            at = np.cumsum(np.concatenate([[0], p["face_sizes"]]))
            faces.extend("f " + " ".join(f"{count + v + 1}/{nvt + c + 1}"
                                         for c, v in zip(range(a, b), p["corner_verts"][a:b])) + "\n"
                         for a, b in zip(at[:-1], at[1:]))
            count += len(p["positions"])
            nvt += len(p["corner_uvs"])
        assert count == last + 1
    return np.concatenate(pos), np.concatenate(deltas, axis=1), faces, np.concatenate(vts)


def write_checkout(folder, data, parts, names):
    """An ICT-FaceKit-like checkout: FaceXModel/ with the neutral OBJ and one OBJ per name."""
    model = folder / "FaceXModel"
    model.mkdir(parents=True)
    (folder / "LICENSE").write_text("MIT License (test copy)\n")
    neutral, deltas, faces, vt = _model(data, parts)
    n = len(data["positions"])
    mixed = f"f {data['quads'][0, 0] + 1}/1 {data['quads'][0, 1] + 1}/2 {n + 5}/3 {n + 6}/4\n"
    text = [HEADER, _v_lines(neutral)]
    text += ["".join(f"vt {u!r} {w!r}\n" for u, w in vt.astype(np.float64).tolist()), "vn 0 0 1\n"]
    text += ["g head\nusemtl skin\n", f"f {n + 1} {n + 2} {n + 3}\n"]  # a face outside the head first ...
    text += faces[:1000] + [mixed] + faces[1000:]  # ... one mixing the skin and the socket ...
    (model / "generic_neutral_mesh.obj").write_text("".join(text))

    order = list(data["expression_names"])
    for name in names:
        target = neutral + deltas[order.index(name)]
        (model / f"{name}.obj").write_text(HEADER + _v_lines(target))
    # Files the converter must ignore.
    (model / "identity000.obj").write_text(HEADER + "v 1 2 3\n")
    (model / "vertex_indices.json").write_text("{}\n")
    return folder


@pytest.fixture(scope="module")
def checkout(tmp_path_factory, shared, shared_parts):
    return write_checkout(tmp_path_factory.mktemp("ICT-FaceKit"), shared, shared_parts,
                          ict_to_npz.EXPRESSIONS)


def assert_same(got, want):
    assert set(got) == set(want)
    for key in want:
        assert got[key].dtype == want[key].dtype, key
        assert got[key].shape == want[key].shape, key
        assert np.array_equal(got[key], want[key]), key


def test_expression_order_is_the_shared_files(shared):
    assert tuple(shared["expression_names"]) == ict_to_npz.EXPRESSIONS
    assert list(ict_to_npz.EXPRESSIONS) == sorted(ict_to_npz.EXPRESSIONS)
    assert len(shared["positions"]) == ict_to_npz.HEAD_VERTICES


def _read(path):
    with np.load(path) as data:
        return {k: data[k] for k in data.files}


def test_round_trip_all_expressions(checkout, shared, shared_parts, tmp_path):
    out = tmp_path / "out" / "ict_head.npz"
    skin, parts = ict_to_npz.convert(checkout, out)
    assert_same(skin, shared)
    assert_same(parts, shared_parts)
    assert_same(_read(out), shared)
    assert_same(_read(tmp_path / "out" / "ict_head_parts.npz"), shared_parts)
    assert out.with_suffix(".LICENSE").read_text() == "MIT License (test copy)\n"


def test_repack_checks_and_rewrites_the_shipped_pair(tmp_path, shared, shared_parts):
    out = tmp_path / "again" / "ict_head.npz"
    run = _cli("--repack", DATA, "-o", out)
    assert run.returncode == 0, run.stderr
    assert_same(_read(out), shared)
    assert_same(_read(tmp_path / "again" / "ict_head_parts.npz"), shared_parts)
    assert out.with_suffix(".LICENSE").read_bytes() == (DATA / "ict_head.LICENSE").read_bytes()


def test_repack_refuses_a_wrong_layout(tmp_path, shared, shared_parts):
    bad = dict(shared_parts)
    bad["teeth/expression_deltas"] = bad["teeth/expression_deltas"].astype(np.float32)
    np.savez(tmp_path / "ict_head.npz", **shared)
    np.savez(tmp_path / "ict_head_parts.npz", **bad)
    run = _cli("--repack", tmp_path, "-o", tmp_path / "out" / "x.npz")
    assert run.returncode == 1 and "Traceback" not in run.stderr
    assert "teeth/expression_deltas is float32 (53, 4412, 3), expected float16" in run.stderr
    assert not (tmp_path / "out").exists()


def test_sides_and_shells_are_named_by_position(shared_parts):
    for side, sign in (("L", 1.0), ("R", -1.0)):
        for part in ("sclera", "iris", "lacrimal", "eye_occlusion", "eyelashes"):
            assert sign * shared_parts[f"{part}_{side}/positions"][:, 0].mean() > 0
        outer = shared_parts[f"sclera_{side}/positions"]
        inner = shared_parts[f"iris_{side}/positions"]
        centre = inner.mean(axis=0)
        assert np.linalg.norm(outer - centre, axis=1).mean() > np.linalg.norm(inner - centre, axis=1).mean()


def test_command_line(checkout, shared, tmp_path):
    out = tmp_path / "head.npz"
    run = subprocess.run([sys.executable, str(TOOL), str(checkout), "-o", str(out)],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert f"wrote {out}: 11248 vertices, 11144 quads, 53 expressions" in run.stdout
    assert "ict_head_parts.npz" not in run.stdout and "head_parts.npz: 12 parts, 12609 vertices" in run.stdout
    assert_same(_read(out), shared)


def _cli(*args):
    return subprocess.run([sys.executable, str(TOOL), *map(str, args)],
                          capture_output=True, text=True, timeout=120)


def test_missing_model_folder(tmp_path):
    run = _cli(tmp_path, "-o", tmp_path / "x.npz")
    assert run.returncode == 1
    assert "has no FaceXModel folder" in run.stderr and "git clone" in run.stderr
    assert "Traceback" not in run.stderr
    assert not (tmp_path / "x.npz").exists()


def test_missing_checkout(tmp_path):
    run = _cli(tmp_path / "nowhere")
    assert run.returncode == 1 and "is not a folder" in run.stderr and "Traceback" not in run.stderr


def test_missing_obj(tmp_path):
    (tmp_path / "FaceXModel").mkdir()
    (tmp_path / "FaceXModel" / "generic_neutral_mesh.obj").write_text("v 0 0 0\n")
    with pytest.raises(ict_to_npz.ConversionError, match=r"lacks 53 of the OBJ files needed: browDown_L.obj"):
        ict_to_npz.build_arrays(tmp_path)


def test_wrong_vertex_count(checkout, tmp_path):
    model = tmp_path / "FaceXModel"
    model.mkdir()
    for f in (checkout / "FaceXModel").iterdir():
        os.symlink(f, model / f.name)
    bad = model / "browDown_R.obj"
    bad.unlink()
    bad.write_text("v 0 0 0\n" * 20)
    run = _cli(tmp_path, "-q", "-o", tmp_path / "x.npz")
    assert run.returncode == 1 and "Traceback" not in run.stderr
    assert f"{bad}: 20 vertices, but generic_neutral_mesh.obj has 26719" in run.stderr


def test_malformed_line(tmp_path):
    obj = tmp_path / "a.obj"
    obj.write_text("v 1 2 3\nv 1 two 3\n")
    with pytest.raises(ict_to_npz.ConversionError, match=r"a.obj:2: not a number"):
        ict_to_npz.read_obj(obj)
