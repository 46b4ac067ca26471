"""tools/ict_to_npz.py: an ICT-FaceKit folder of OBJ files back to ict_head.npz.

The ICT-style folder is written here from the shared ict_head.npz itself, with extra
vertices and faces after the head (like the full model's mouth socket, eyes and teeth), so
the round trip checks the cropping, the expression order and the float32 values exactly.
Pure NumPy; skipped when the shared npz is absent.
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
ICT_PATH = ROOT.parent / "shared" / "data" / "ict_head.npz"
KEYS = ("positions", "quads", "corner_uvs", "expression_names", "expression_deltas")
EXTRA_VERTICES = 300  # after the head, as the full model's other geometries are

_spec = importlib.util.spec_from_file_location("ict_to_npz", TOOL)
ict_to_npz = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(ict_to_npz)

needs_npz = pytest.mark.skipif(not ICT_PATH.exists(), reason=f"{ICT_PATH} not found")


@pytest.fixture(scope="module")
def shared():
    with np.load(ICT_PATH) as data:
        return {k: data[k] for k in KEYS}


def _v_lines(points):
    # repr of the float64 value: reading it back gives exactly the same double.
    return "".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in points.tolist())


HEADER = "# ICT FaceKit (test copy written from ict_head.npz)\nmtllib ICTFaceModelMaterial.mtl\n"


def write_checkout(folder, data, names):
    """An ICT-FaceKit-like checkout: FaceXModel/ with the neutral OBJ and one OBJ per name."""
    model = folder / "FaceXModel"
    model.mkdir(parents=True)
    (folder / "LICENSE").write_text("MIT License (test copy)\n")
    pos, quads, uvs = data["positions"], data["quads"], data["corner_uvs"]
    n = len(pos)
    rng = np.random.default_rng(7)
    extra = rng.normal(0.0, 5.0, (EXTRA_VERTICES, 3)).astype(np.float32)
    neutral = np.concatenate([pos, extra]).astype(np.float64)

    # One vt per head corner (1-based ids), then a few for the extra faces.
    vt = uvs.reshape(-1, 2).astype(np.float64)
    head_faces = [
        "f " + " ".join(f"{v + 1}/{4 * i + k + 1}" for k, v in enumerate(q)) + "\n"
        for i, q in enumerate(quads.tolist())
    ]
    t0 = len(vt) + 1  # the extra faces use vt t0..t0+3
    extra_ids = np.arange(n, n + EXTRA_VERTICES) + 1
    quads_extra = [
        "f " + " ".join(f"{v}/{t0 + k}/1" for k, v in enumerate(extra_ids[j:j + 4])) + "\n"
        for j in range(0, EXTRA_VERTICES - 4, 4)
    ]
    triangle = f"f {extra_ids[0]} {extra_ids[1]} {extra_ids[2]}\n"  # teeth-like triangle, no UVs
    mixed = f"f {quads[0, 0] + 1}/1 {quads[0, 1] + 1}/2 {extra_ids[5]}/3 {extra_ids[6]}/4\n"
    text = [HEADER, _v_lines(neutral)]
    text += ["".join(f"vt {u!r} {w!r}\n" for u, w in vt.tolist()), "vt 0.25 0.5\n" * 4, "vn 0 0 1\n"]
    text += ["g head\nusemtl skin\n", triangle]  # a face outside the head before it ...
    text += head_faces[:1000] + [mixed] + head_faces[1000:]  # ... one mixing both inside it ...
    text += ["g socket\n"] + quads_extra  # ... and the rest after it, as in the real file
    (model / "generic_neutral_mesh.obj").write_text("".join(text))

    order = list(data["expression_names"])
    for name in names:
        delta = data["expression_deltas"][order.index(name)].astype(np.float64)
        target = neutral.copy()
        target[:n] += delta
        target[n:] += rng.normal(0.0, 0.1, (EXTRA_VERTICES, 3))  # the eyes move too
        (model / f"{name}.obj").write_text(HEADER + _v_lines(target))
    # Files the converter must ignore.
    (model / "identity000.obj").write_text(HEADER + "v 1 2 3\n")
    (model / "vertex_indices.json").write_text("{}\n")
    return folder


@pytest.fixture(scope="module")
def checkout(tmp_path_factory, shared):
    if not ICT_PATH.exists():
        pytest.skip(f"{ICT_PATH} not found")
    return write_checkout(tmp_path_factory.mktemp("ICT-FaceKit"), shared, ict_to_npz.EXPRESSIONS)


def assert_same(got, want):
    assert set(got) == set(KEYS)
    for key in KEYS:
        assert got[key].dtype == want[key].dtype, key
        assert got[key].shape == want[key].shape, key
        assert np.array_equal(got[key], want[key]), key


@needs_npz
def test_expression_order_is_the_shared_files(shared):
    assert tuple(shared["expression_names"]) == ict_to_npz.EXPRESSIONS
    assert list(ict_to_npz.EXPRESSIONS) == sorted(ict_to_npz.EXPRESSIONS)
    assert len(shared["positions"]) == ict_to_npz.HEAD_VERTICES


@needs_npz
def test_round_trip_all_expressions(checkout, shared, tmp_path):
    out = tmp_path / "out" / "ict_head.npz"
    arrays = ict_to_npz.convert(checkout, out)
    assert_same(arrays, shared)
    with np.load(out) as data:
        assert_same({k: data[k] for k in data.files}, shared)
    assert out.with_suffix(".LICENSE").read_text() == "MIT License (test copy)\n"


@needs_npz
def test_command_line(checkout, shared, tmp_path):
    out = tmp_path / "head.npz"
    run = subprocess.run([sys.executable, str(TOOL), str(checkout), "-o", str(out)],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert f"wrote {out}: 11248 vertices, 11144 quads, 53 expressions" in run.stdout
    with np.load(out) as data:
        assert_same({k: data[k] for k in data.files}, shared)


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


@needs_npz
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
    assert f"{bad}: 20 vertices, but generic_neutral_mesh.obj has 11548" in run.stderr


def test_malformed_line(tmp_path):
    obj = tmp_path / "a.obj"
    obj.write_text("v 1 2 3\nv 1 two 3\n")
    with pytest.raises(ict_to_npz.ConversionError, match=r"a.obj:2: not a number"):
        ict_to_npz.read_obj(obj)
