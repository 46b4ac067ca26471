"""`ewrinkles export`: glTF, USD and the wrinkle-map package from the shell, with its
report on stdout, exit codes and one-line refusals; the shot is never written."""

import json

import bpy
import pytest

from tests.blender import exportscenes
from wrinkle_addon import cli


def _shot(path):
    exportscenes.wrinkled_face_with_maps()
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    return path


def _run(capfd, *argv):
    capfd.readouterr()
    code = cli.execute([str(a) for a in argv])
    out, err = capfd.readouterr()
    return code, out, err


@pytest.fixture
def shot(tmp_path):
    return _shot(tmp_path / "shot.blend")


def test_gltf_with_a_json_report(shot, tmp_path, capfd):
    before = shot.stat().st_mtime_ns
    code, out, err = _run(capfd, "export", shot, "--format", "gltf", "--out", tmp_path / "face.glb", "--json")
    assert code == 0, err
    (line,) = out.splitlines()  # stdout holds the report only
    report = json.loads(line)
    assert report["face"] == "Face" and report["targets"] >= 1 and report["within_tolerance"]
    assert (tmp_path / "face.glb").stat().st_size > 1000
    assert "wrinkle targets, largest error" in err
    assert shot.stat().st_mtime_ns == before


def test_package_and_usd(shot, tmp_path, capfd):
    code, out, err = _run(capfd, "export", shot, "--format", "package", "--out", tmp_path / "pkg",
                          "--frames", "1-5")
    assert code == 0, err
    doc = json.loads((tmp_path / "pkg" / "wrinkles.json").read_text())
    assert doc["animation"]["frames"] == [1, 2, 3, 4, 5]
    code, out, err = _run(capfd, "export", shot, "--format", "usd", "--out", tmp_path / "face.usdc")
    assert code == 0, err
    assert (tmp_path / "face.usdc").is_file()
    # the add-on's attributes only with --keep-attributes (USD's text form names them)
    for name, extra in (("lean.usda", ()), ("full.usda", ("--keep-attributes",))):
        code, out, err = _run(capfd, "export", shot, "--format", "usd", "--out", tmp_path / name, *extra)
        assert code == 0, err
    full, lean = (tmp_path / "full.usda").read_text(), (tmp_path / "lean.usda").read_text()
    assert "primvars:wrinkle_offset" in full and "wrinkle_offset" not in lean


def test_refusals_exit_2_with_one_line(shot, tmp_path, capfd):
    cases = [
        (["--format", "gltf", "--out", tmp_path / "x.fbx"], "not a .glb or .gltf"),
        (["--format", "gltf", "--out", tmp_path / "x.glb", "--face", "Nobody"], 'no face "Nobody"'),
        (["--format", "gltf", "--out", tmp_path / "x.glb", "--frames", "1,3"], "without gaps"),
        (["--format", "gltf", "--out", tmp_path / "x.glb", "--tolerance", "-1"], "--tolerance"),
        (["--format", "obj", "--out", tmp_path / "x.obj"], "invalid choice"),
    ]
    for extra, message in cases:
        code, out, err = _run(capfd, "export", shot, *extra, "--json")
        lines = [ln for ln in err.splitlines() if ln.startswith("ewrinkles:")]
        assert code == 2 and message in lines[-1], (extra, err)
        assert out == ""


def test_two_faces_need_face(tmp_path, capfd):
    exportscenes.wrinkled_face_with_maps()
    other = bpy.data.objects["Face"].copy()
    other.data = other.data.copy()
    bpy.context.scene.collection.objects.link(other)
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "two.blend"))
    code, _out, err = _run(capfd, "export", tmp_path / "two.blend", "--format", "gltf", "--out",
                           tmp_path / "x.glb")
    assert code == 2 and "pick one with --face" in err
    code, _out, err = _run(capfd, "export", tmp_path / "two.blend", "--format", "gltf", "--out",
                           tmp_path / "x.glb", "--face", "Face")
    assert code == 0, err
