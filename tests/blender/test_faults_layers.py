"""Regression tests: the pattern layers' stack and the Add operators.

* Duplicate Pattern and Mirror Pattern copied a layer through a reference taken before
  ``layers.add()``, which can move the stack's items in memory: the copy read freed memory
  (garbage settings, a hang, or a segmentation fault).  Checked in a fresh process, so that
  a crash cannot take pytest down with it.
* RNA does not check a stored value when it is read: a file can hold a layer ``kind``,
  ``region`` or ``drive`` this version does not know (it reads as ""), a negative ``seed``
  or an ``active`` index of -3.  Such a layer is skipped with a message in the panel, the
  other layers still work, and no operator or panel raises.  Also in a fresh process (an
  unknown ``kind`` once crashed the process), on a file saved and opened again.
* On a library override the add-on's lists (pattern layers, wrinkle curves) cannot grow:
  Add Pattern and Add Wrinkle Curve refuse up front; Add Teardrop and Add Shedding Tear
  work there.  Whatever an Add operator made is removed when it fails.
"""

import json
import os
import subprocess
import sys
import textwrap

import bpy
import numpy as np
import pytest

from tests.blender import scenes
from wrinkle_addon.glue.bando import curves
from wrinkle_addon.glue.patterns import pattern_layers as glue
from wrinkle_addon.glue.patterns import shedding, tears
from wrinkle_addon.ops.common import nothing_left_on_failure

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MID = scenes.HEIGHT / 2
COPIES = 8


def _run(tmp_path, script_text, *args):
    """Run ``script_text`` in a fresh interpreter with the add-on enabled; it gets the
    repository root, ``args`` and a JSON output path as its arguments.  Returns what it
    wrote there."""
    script = tmp_path / "script.py"
    script.write_text(script_text)
    out = tmp_path / "result.json"
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(tmp_path / "user"))
    run = subprocess.run([sys.executable, str(script), ROOT, *map(str, args), str(out)], env=env,
                         cwd=str(tmp_path), capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, f"exit {run.returncode}:\n" + run.stdout[-3000:] + run.stderr[-3000:]
    return json.loads(out.read_text())


PROLOGUE = textwrap.dedent("""
    import json, sys
    root, out = sys.argv[1], sys.argv[-1]
    sys.path.insert(0, root)
    import bpy
    import addon_utils
    addon_utils.enable("wrinkle_addon", default_set=True)
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    from tests.blender import scenes


    def settings(lay):  # every setting but the name and the frame, read the plain way
        return {p.identifier: getattr(lay, p.identifier) for p in lay.bl_rna.properties
                if not p.is_readonly and p.identifier not in ("rna_type", "name", "frame")}


    def add(face, kind, x):
        bpy.context.scene.cursor.location = (x, -0.2, scenes.HEIGHT / 2)
        bpy.context.view_layer.objects.active = face
        assert bpy.ops.wrinkle.add_pattern(kind=kind, where="CURSOR") == {"FINISHED"}
        return face.ewrinkles_face.patterns.layers[-1]
""")

# --- Duplicate and Mirror: no layer held across layers.add() ----------------------------

COPY_MANY = PROLOGUE + textwrap.dedent("""
    copies = int(sys.argv[2])
    face = scenes.make_face()
    bpy.ops.wrinkle.enable()
    src = add(face, "EYE_CORNER", 0.03)
    src.name = "Crow L"
    src.depth, src.sharpness, src.count, src.fraction, src.seed = -0.123, 7.5, 4.25, 0.5, 3
    src.drive, src.drive_shape_key, src.follow_scene = "SHAPE_KEY", "BrowsUp", False
    want = settings(src)
    st = face.ewrinkles_face.patterns
    results = []
    for _ in range(copies):
        for op in (bpy.ops.wrinkle.duplicate_pattern, bpy.ops.wrinkle.mirror_pattern):
            st.active = 0
            results.append(sorted(op()))
    layers = [{"name": lay.name, "frame": lay.frame.name if lay.frame else None, "settings": settings(lay)}
              for lay in st.layers]
    json.dump({"want": want, "results": results, "layers": layers}, open(out, "w"))
""")


def test_duplicate_and_mirror_copy_the_layer_however_often_the_stack_grows(tmp_path):
    got = _run(tmp_path, COPY_MANY, COPIES)
    assert got["results"] == [["FINISHED"]] * (2 * COPIES)
    layers = got["layers"]
    assert len(layers) == 1 + 2 * COPIES
    src, copies = layers[0], layers[1:]
    assert src["name"] == "Crow L" and src["settings"] == got["want"]
    for i, lay in enumerate(copies):
        assert lay["settings"] == got["want"], f"copy {i} differs from its source"
    names = {lay["name"] for lay in copies}
    assert names == {"Crow L Copy", "Crow L Mirrored"}
    for lay in copies:  # a duplicate shares the frame; a mirrored copy has its own
        mirrored = lay["name"].endswith("Mirrored")
        assert (lay["frame"] != src["frame"]) == mirrored
        assert not mirrored or lay["frame"].startswith(src["frame"] + " Mirrored")


# --- Values RNA does not check on read -------------------------------------------------

CRAFTED = PROLOGUE + textwrap.dedent("""
    from wrinkle_addon.glue import status
    from wrinkle_addon.ui import patterns as patterns_ui
    from tests.blender.test_ui_contract import _Layout
    case, blend = sys.argv[2], sys.argv[3]


    def heights():
        bpy.context.scene.frame_set(2)
        return (-scenes.offsets(bpy.data.objects["Face"])[:, 1]).tolist()


    face = scenes.make_face()
    bpy.ops.wrinkle.enable()
    bad = add(face, "CHEEK", -0.035)
    good = add(face, "FOREHEAD", 0.035)
    bad.name = "Bad"
    for lay in (bad, good):
        lay.follow_scene = False
        lay.radius, lay.border = 0.03, 0.01
    bad.show_viewport = bad.show_render = False
    only_good = heights()
    bad.show_viewport = bad.show_render = True
    both = heights()
    st = face.ewrinkles_face.patterns
    if case == "seed":
        bad.fraction = 0.5
        bad["seed"] = -4
    else:
        bad[case] = 99
    st["active"] = -3
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    bpy.ops.wm.open_mainfile(filepath=blend)
    face = bpy.data.objects["Face"]
    st = face.ewrinkles_face.patterns
    got = {"only_good": only_good, "both": both, "active": st.active, "heights": heights(),
           "status": status.get(face)}
    layout = _Layout()
    patterns_ui.draw_face_patterns(layout, bpy.context, face)  # must not raise
    got["drawn"] = layout.drawn
    ops = {}
    for name in ("apply_pattern", "duplicate_pattern", "mirror_pattern", "move_pattern",
                 "remove_pattern"):
        st["active"] = -3
        bpy.context.view_layer.objects.active = face
        try:
            ops[name] = sorted(getattr(bpy.ops.wrinkle, name)())
        except RuntimeError as exc:  # an ERROR report
            ops[name] = str(exc)
    got["ops"] = ops
    got["layers"] = len(st.layers)
    got["after"] = heights()
    got["status_after"] = status.get(face)
    json.dump(got, open(out, "w"))
""")


@pytest.mark.parametrize("case", ["kind", "region", "drive", "seed"])
def test_a_layer_with_a_crafted_value_is_skipped_with_a_message_and_nothing_raises(tmp_path, case):
    got = _run(tmp_path, CRAFTED, case, tmp_path / "crafted.blend")
    only_good, both = np.array(got["only_good"]), np.array(got["both"])
    assert np.abs(only_good).max() > 1e-4 and np.abs(both - only_good).max() > 1e-5
    assert got["active"] == -3  # as stored: nothing rewrote it on load
    label = {"kind": "Type", "region": "Region", "drive": "Driven By"}.get(case)
    if label:  # skipped with a message naming it; the other layer still works
        assert f'The layer "Bad" has a {label} that this version' in got["status"], got["status"]
        np.testing.assert_allclose(got["heights"], only_good, atol=1e-7)
    else:  # a negative seed reads as 0: the layer works
        assert got["status"] == "", got["status"]
        assert np.abs(np.array(got["heights"]) - only_good).max() > 1e-5
    assert "Internal error" not in got["status"]
    assert "kind" in got["drawn"]
    ops = got["ops"]
    for name, result in ops.items():
        assert "unexpectedly" not in str(result), (name, result)
    if label:  # the active layer (-3 reads as the first) is the bad one: refused, with its name
        for name in ("apply_pattern", "duplicate_pattern", "mirror_pattern"):
            assert f'The layer "Bad" has a {label}' in ops[name], (name, ops[name])
    else:
        assert ops["apply_pattern"] == ops["duplicate_pattern"] == ops["mirror_pattern"] == ["FINISHED"]
    assert ops["move_pattern"] == ops["remove_pattern"] == ["FINISHED"]
    assert "Internal error" not in got["status_after"]


# --- Library overrides, and nothing left behind by a failed Add --------------------------


def _overridden_face(tmp_path):
    """A face in a collection of a saved library file, linked into the current file and
    overridden (its mesh too), with a band of faces selected for a tear's path."""
    face = scenes.make_face()
    me = face.data
    centres = np.empty(len(me.polygons) * 3, np.float32)
    me.polygons.foreach_get("center", centres)
    centres = centres.reshape(-1, 3)
    me.polygons.foreach_set("select", (np.abs(centres[:, 0] - 0.01) < 0.003) & (centres[:, 2] > 0.015)
                            & (centres[:, 2] < 0.065))
    coll = bpy.data.collections.new("Head")
    bpy.context.scene.collection.children.link(coll)
    coll.objects.link(face)
    bpy.context.scene.collection.objects.unlink(face)
    lib = str(tmp_path / "head_library.blend")
    bpy.ops.wm.save_as_mainfile(filepath=lib)
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    with bpy.data.libraries.load(lib, link=True) as (_src, dst):
        dst.collections = ["Head"]
    scene = bpy.context.scene
    holder = bpy.data.objects.new("Head", None)
    holder.instance_type, holder.instance_collection = "COLLECTION", dst.collections[0]
    scene.collection.objects.link(holder)
    dst.collections[0].override_hierarchy_create(scene, bpy.context.view_layer, reference=holder,
                                                 do_fully_editable=True)
    face = next(o for o in scene.objects if o.type == "MESH")
    face.data.override_create(remap_local_usages=True)
    assert face.override_library is not None and face.data.override_library is not None
    for o in bpy.context.selected_objects:
        o.select_set(False)
    face.select_set(True)
    bpy.context.view_layer.objects.active = face
    scene.cursor.location = (0.0, -0.2, MID)
    assert bpy.ops.wrinkle.enable() == {"FINISHED"}
    return face


_KINDS = ("objects", "meshes", "curves", "collections", "materials", "node_groups", "images")


def _ids():
    return {kind: sorted(i.name for i in getattr(bpy.data, kind)) for kind in _KINDS}


def test_on_a_library_override_add_pattern_and_add_curve_refuse_and_the_tears_work(tmp_path):
    face = _overridden_face(tmp_path)
    before = _ids()
    for op, kw in ((bpy.ops.wrinkle.add_pattern, {"kind": "CHEEK"}), (bpy.ops.wrinkle.add_curve, {}),
                   (bpy.ops.wrinkle.curve_from_stroke, {})):
        assert not op.poll()
        with pytest.raises(RuntimeError, match="is a library override"):
            op(**kw)
    assert _ids() == before
    # the real failure, past the polls: adding to an override's list raises; nothing is left
    point, normal = glue.nearest_on_skin(face, bpy.context.scene.cursor.location)
    with pytest.raises(TypeError, match="not supported"), nothing_left_on_failure():
        glue.add_layer(bpy.context, face, "CHEEK", point, normal)
    with pytest.raises(TypeError, match="not supported"), nothing_left_on_failure():
        curves.create(bpy.context, face, [(-0.01, 0.0, MID), (0.01, 0.0, MID)])
    assert _ids() == before
    # the tears add no list item: they work, in the scene's collection (an override's is fixed)
    assert bpy.ops.wrinkle.add_teardrop() == {"FINISHED"}
    bpy.context.view_layer.objects.active = face
    assert bpy.ops.wrinkle.add_shedding_tear(path="FACES") == {"FINISHED"}
    for name in ("Face Teardrop", "Face Tear"):
        ob = bpy.data.objects[name]
        assert ob.parent == face and tuple(ob.users_collection) == (bpy.context.scene.collection,)


@pytest.mark.parametrize("op, module, function", [
    ("add_pattern", glue, "add_layer"),
    ("add_curve", curves, "create"),
    ("add_teardrop", tears, "add_teardrop"),
    ("add_shedding_tear", shedding, "add_shedding_tear"),
])
def test_an_add_operator_that_fails_leaves_nothing_behind(monkeypatch, op, module, function):
    """The glue makes everything, then something fails: the operator reports it and every
    object, mesh, curve, collection, material and node group it made is gone again."""
    face = scenes.make_face()
    assert bpy.ops.wrinkle.enable() == {"FINISHED"}
    me = face.data
    centres = np.empty(len(me.polygons) * 3, np.float32)
    me.polygons.foreach_get("center", centres)
    centres = centres.reshape(-1, 3)
    me.polygons.foreach_set("select", (np.abs(centres[:, 0] - 0.01) < 0.003) & (centres[:, 2] > 0.015)
                            & (centres[:, 2] < 0.065))
    bpy.context.scene.cursor.location = (0.0, -0.2, MID)
    before = _ids()
    real = getattr(module, function)

    def fails_at_the_end(*args, **kwargs):
        real(*args, **kwargs)
        raise RuntimeError("a failure after everything was made")

    monkeypatch.setattr(module, function, fails_at_the_end)
    bpy.context.view_layer.objects.active = face
    with pytest.raises(RuntimeError, match="failed unexpectedly"):
        getattr(bpy.ops.wrinkle, op)(**({"path": "FACES"} if op == "add_shedding_tear" else {}))
    assert _ids() == before
