"""Bake for Farm with wrinkle maps that need no bake, and a bake that fails.

* Wrinkle maps driven by shape keys alone need no bake (their one-variable drivers evaluate
  on a farm with no add-on): the maps source does not ask for one, so `ewrinkles bake` of a
  face with such maps bakes its geometry, exits 0, and `ewrinkles check` calls the baked
  file farm-ready; it renders the same in a fresh process with no add-on.
* A bake that fails midway (in the Alembic export, or in making the stand-in once the cache
  is written) leaves nothing: no cache, no folder it made, no other file, and the scene as
  it was, a previous bake's stand-in and cache included.  Through `ewrinkles bake` too.
"""

import json
import textwrap
from pathlib import Path

import bpy
import numpy as np
import pytest

from tests.blender import exportscenes, scenes
from wrinkle_addon import cli
from wrinkle_addon.cli import args as cli_args
from wrinkle_addon.glue import farm_bake, registry
from wrinkle_addon.glue.maps import map_material


def _maps_source():
    return next(s for s in registry.sources() if s.name == map_material.CHANNEL)


def _files(root):
    """Every file and folder under ``root``, with the bytes of each file."""
    root = Path(root)
    return {str(p.relative_to(root)): (p.read_bytes() if p.is_file() else None) for p in root.rglob("*")}


# --------------------------------------------------------------------------- maps with nothing to bake
def test_the_maps_ask_for_a_bake_only_for_what_a_farm_cannot_compute(tmp_path):
    face, muscle = exportscenes.wrinkled_face_with_maps()
    maps, source = face.ewrinkles_face.maps, _maps_source()
    assert maps.expressions[0].source == "SHAPE_KEY"
    assert not source.bakes(face) and not source.has_bake(face)  # a shape key: nothing to bake
    ex = maps.expressions[0]
    ex.source, ex.muscle = "MUSCLE", muscle  # a muscle's contraction is an add-on property
    assert source.bakes(face)
    ex.source = "SHAPE_KEY"
    maps.weight_mode = "TENSION"  # the measured compression: only the add-on computes it
    assert source.bakes(face)
    maps.weight_mode = "TABLE"
    ex.source = "MUSCLE"
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "shot.blend"))
    face = bpy.data.objects["Face"]
    scenes.select_only(face)
    assert bpy.ops.wrinkle.bake(frame_start=1, frame_end=2) == {"FINISHED"}
    assert source.has_bake(face)
    face.ewrinkles_face.maps.expressions[0].source = "SHAPE_KEY"
    assert source.bakes(face)  # the stale bake of the muscle's row is freed by baking again
    assert bpy.ops.wrinkle.bake(frame_start=1, frame_end=2) == {"FINISHED"}
    assert not source.has_bake(face) and not source.bakes(face)
    drivers = face.ewrinkles_face.maps.weights_group.animation_data.drivers
    assert [fc.driver.variables[0].targets[0].id_type for fc in drivers] == ["KEY"]


FARM_RENDER = textwrap.dedent("""
    import json, sys
    import bpy
    blend, out = sys.argv[-2], sys.argv[-1]
    bpy.ops.wm.open_mainfile(filepath=blend)
    assert "wrinkle_addon" not in sys.modules, "the add-on must not be loaded on the farm"
    scene = bpy.context.scene
    group = next(g for g in bpy.data.node_groups if g.name.startswith("Wrinkle Weights"))
    node = group.nodes["Expression 0"]
    values = {}
    for f in (1, 5):
        scene.frame_set(f)
        values[f] = node.outputs[0].default_value
        scene.frame_start = scene.frame_end = f
        scene.render.filepath = out + "/farm_####"
        bpy.ops.render.render(animation=True)
    json.dump(values, open(out + "/values.json", "w"))
    bpy.ops.wm.read_factory_settings(use_empty=True)
""")


@pytest.mark.render
def test_a_face_with_shape_key_maps_bakes_is_farm_ready_and_renders_the_same(tmp_path, capfd):
    scene = bpy.context.scene
    face, _muscle = exportscenes.wrinkled_face_with_maps()
    scenes.add_camera_and_light(scene)
    scenes.setup_cycles(scene, size=32, samples=2)
    shot = tmp_path / "shot.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(shot))
    farm = tmp_path / "job" / "farm.blend"
    capfd.readouterr()
    assert cli.execute(["bake", str(shot), "--save-as", str(farm)]) == cli_args.OK, capfd.readouterr().err
    assert (farm.parent / "wrinkle_bake" / "Face.abc").is_file()
    capfd.readouterr()
    assert cli.execute(["check", str(farm)]) == cli_args.OK
    out = capfd.readouterr().out
    assert "baked, renders without the add-on" in out and out.rstrip().endswith("farm-ready: yes"), out
    group = bpy.data.objects["Face"].ewrinkles_face.maps.weights_group
    assert not map_material.baked_paths(group) and len(group.animation_data.drivers) == 1  # live driver

    assert cli.execute(["render", str(shot), "--frames", "1,5", "--out", str(tmp_path / "live")]) == 0
    scenes.run_on_farm(FARM_RENDER, farm, tmp_path)
    values = json.loads((tmp_path / "values.json").read_text())
    assert values == {"1": 0.0, "5": 1.0}  # the shape key's driver, evaluated with no add-on
    live = {f: scenes.load_png(tmp_path / "live" / f"frame_{f:04d}.png") for f in (1, 5)}
    assert np.abs(live[5] - live[1]).max() > 0.05  # the frames differ: a farm showing one fails
    for f in (1, 5):
        got = scenes.load_png(tmp_path / f"farm_{f:04d}.png")
        assert np.abs(got - live[f]).max() < 2e-5, f


# --------------------------------------------------------------------------- a bake that fails
def _fail_in(where, monkeypatch):
    if where == "export":  # the exporter writes (part of) the cache, then stops
        real = farm_bake._export

        def export(*args):
            real(*args)
            raise RuntimeError("the Alembic exporter stopped")

        monkeypatch.setattr(farm_bake, "_export", export)
    else:  # the cache is written and in place: the stand-in cannot read it (once: the
        # previous stand-in, made again from the previous cache, reads that one)
        real, calls = farm_bake._object_path, []

        def object_path(face, cache):
            calls.append(cache.filepath)
            if len(calls) == 1:
                raise farm_bake.BakeError("the cache holds no single mesh")
            return real(face, cache)

        monkeypatch.setattr(farm_bake, "_object_path", object_path)


def _saved_shot(tmp_path):
    """The wrinkled face, its shape key animated over frames 1-3, saved as shot.blend and selected."""
    face, _muscle = scenes.wrinkled_face()
    scenes.animate_shape_key(face, [(1, 0.0), (3, 1.0)])
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "shot.blend"))
    face = bpy.data.objects["Face"]
    scenes.select_only(face)
    return face


def _scene_state(face):
    scene = bpy.context.scene
    baked = face.ewrinkles_face.bake_object
    return {
        "objects": sorted(bpy.data.objects.keys()), "meshes": sorted(bpy.data.meshes.keys()),
        "caches": sorted(c.filepath for c in bpy.data.cache_files),
        "hidden": face.hide_render, "baked": baked.name if baked is not None else None,
        "reads": [m.cache_file.filepath for m in (baked.modifiers if baked is not None else ())
                  if m.type == "MESH_SEQUENCE_CACHE"],
        "frame": scene.frame_current, "active": bpy.context.view_layer.objects.active.name,
        "selected": sorted(o.name for o in bpy.context.selected_objects),
    }


@pytest.mark.parametrize("where", ["export", "stand-in"])
@pytest.mark.parametrize("before", ["live", "baked"])
def test_a_bake_that_fails_midway_leaves_nothing(tmp_path, monkeypatch, where, before):
    face = _saved_shot(tmp_path)
    if before == "baked":
        assert bpy.ops.wrinkle.bake(frame_start=1, frame_end=3) == {"FINISHED"}
        assert farm_bake.stand_in(face) is not None and face.hide_render
    bpy.context.scene.frame_set(2)
    files, state = _files(tmp_path), _scene_state(face)
    _fail_in(where, monkeypatch)
    with pytest.raises(RuntimeError, match="exporter stopped|no single mesh"):
        bpy.ops.wrinkle.bake(frame_start=1, frame_end=2)
    assert _files(tmp_path) == files  # no cache, no folder, no temporary file; a previous cache kept
    assert _scene_state(face) == state
    if before == "baked":  # the previous stand-in renders its cache again
        assert farm_bake.stand_in(face).modifiers[farm_bake.CACHE_MODIFIER].cache_file is not None


@pytest.mark.parametrize("before", ["live", "baked"])
def test_a_geometry_bake_is_undone_whole_until_it_is_kept(tmp_path, before):
    """What a later step that fails (a wrinkle source's bake after the geometry's) undoes."""
    face = _saved_shot(tmp_path)
    if before == "baked":
        assert bpy.ops.wrinkle.bake(frame_start=1, frame_end=3) == {"FINISHED"}
    files, state = _files(tmp_path), _scene_state(face)
    job = farm_bake.Bake(bpy.context, face, farm_bake.default_path(face), 1, 2)
    baked = job.run()
    assert farm_bake.stand_in(face) == baked and _files(tmp_path) != files  # the new cache
    job.undo()
    assert _files(tmp_path) == files and _scene_state(face) == state


@pytest.mark.parametrize("where", ["export", "stand-in"])
def test_a_failed_ewrinkles_bake_leaves_no_file(tmp_path, monkeypatch, capfd, where):
    scene, _face = scenes.animated_render_scene(2)
    shot = tmp_path / "shot.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(shot))
    job = tmp_path / "job"
    job.mkdir()
    files = _files(tmp_path)
    _fail_in(where, monkeypatch)
    capfd.readouterr()
    code = cli.execute(["bake", str(shot), "--save-as", str(job / "farm.blend")])
    err = capfd.readouterr().err
    assert code == cli_args.FAILED and "Nothing was baked" in err, err  # a failure, not a refusal
    assert _files(tmp_path) == files  # no farm.blend, no wrinkle_bake/, no .abc, no partial file


def test_a_source_bake_that_fails_after_the_geometry_takes_the_cache_back(tmp_path, monkeypatch):
    """Bake for Farm bakes the geometry first, then each source's own bake; when a source's
    bake fails, the geometry's cache is taken back too: no file is left, the face renders live."""
    face, muscle = exportscenes.wrinkled_face_with_maps()
    ex = face.ewrinkles_face.maps.expressions[0]
    ex.source, ex.muscle = "MUSCLE", muscle  # the weights need a bake
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "shot.blend"))
    face = bpy.data.objects["Face"]
    scenes.select_only(face)
    source = _maps_source()
    assert source.bakes(face)
    files, state = _files(tmp_path), _scene_state(face)

    def fail(self, *_args, **_kw):
        raise farm_bake.BakeError("the weights could not be read")

    monkeypatch.setattr(type(source), "bake", fail)
    with pytest.raises(RuntimeError, match="weights could not be read. Nothing was baked"):
        bpy.ops.wrinkle.bake(frame_start=1, frame_end=3)
    assert _files(tmp_path) == files  # no .abc, no wrinkle_bake/ folder
    assert _scene_state(face) == state and farm_bake.stand_in(face) is None
