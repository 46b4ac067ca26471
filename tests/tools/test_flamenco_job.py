"""farm/flamenco/expression_wrinkles.js: the Flamenco job type, compiled under Node.

tests/tools/flamenco_recorder.js stands in for Flamenco Manager's job compiler: it gives the
script Flamenco's documented globals (author.Task/Command, frameChunker, path, print), calls
compileJob on a job built from the settings given here and prints the recorded tasks as JSON.
The tests check the job type's settings, the tasks and their dependencies, the chunks, and
every command line exactly as the Worker would run it, with the Manager's default variables.
No Flamenco Manager or Worker runs here, and no Blender. Plain Python and Node.
"""

import json
import shlex
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
JOB_TYPE = ROOT / "farm" / "flamenco" / "expression_wrinkles.js"
RECORDER = Path(__file__).resolve().with_name("flamenco_recorder.js")
NODE = shutil.which("node")

pytestmark = pytest.mark.skipif(NODE is None, reason="node is not on PATH (the Flamenco job type is "
                                "JavaScript, compiled by tests/tools/flamenco_recorder.js under Node)")

# Flamenco Manager's default values of its {blender} and {blenderArgs} variables (Linux).
VARIABLES = {"{blender}": "blender", "{blenderArgs}": "-b -y"}

SHOT = "/farm/jobs/shot010/shot010.blend"
OUT = "/farm/render/shot010"
SETTINGS = {"blendfile": SHOT, "frames": "1-10", "chunk_size": 4, "render_output_root": OUT,
            "engine": "EEVEE", "samples": 24, "resolution_x": 640, "resolution_y": 360}


def _run(job_file, settings=None, check=True):
    cmd = [NODE, str(RECORDER), str(job_file)]
    if settings is not None:
        cmd.append(json.dumps(settings))
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=30)
    if check:
        assert proc.returncode == 0, proc.stderr
        return json.loads(proc.stdout)
    return proc


def _compile(**changes):
    return _run(JOB_TYPE, {**SETTINGS, **changes})


def _expand(text):
    for name, value in VARIABLES.items():
        text = text.replace(name, value)
    return text


def _argv(command):
    """The command line the Worker runs for a blender-render command: exe, exeArgs split
    like a shell would, argsBefore, blendfile (left out when empty), args."""
    assert command["name"] == "blender-render"
    p = command["parameters"]
    blendfile = [p["blendfile"]] if p.get("blendfile") else []
    return ([_expand(p["exe"])] + shlex.split(_expand(p.get("exeArgs", ""))) + p.get("argsBefore", [])
            + blendfile + p.get("args", []))


def _blender_frames(text):
    """The frames of Blender's --render-frame syntax: "1..4,7"."""
    out = []
    for part in text.split(","):
        first, _, last = part.partition("..")
        out.extend(range(int(first), int(last or first) + 1))
    return out


@pytest.fixture(scope="module")
def job():
    return _compile()


def test_job_type_declares_its_settings():
    job_type = _run(JOB_TYPE)["job_type"]
    assert job_type["label"] == "Expression Wrinkles"
    assert job_type["description"]
    settings = {s["key"]: s for s in job_type["settings"]}
    expected = {"blendfile": "string", "frames": "string", "chunk_size": "int32",
                "render_output_root": "string", "engine": "string", "samples": "int32",
                "resolution_x": "int32", "resolution_y": "int32"}
    assert {k: s["type"] for k, s in settings.items()} == expected
    for key, s in settings.items():
        assert s.get("description", "").strip(), f"{key} has no description"
    for key in ("blendfile", "frames", "render_output_root", "engine"):
        assert settings[key]["required"] is True, key
    assert settings["blendfile"]["eval"] == "bpy.data.filepath"
    assert settings["frames"]["eval"] == "f'{C.scene.frame_start}-{C.scene.frame_end}'"
    assert settings["chunk_size"]["default"] == 4
    assert settings["render_output_root"]["subtype"] == "dir_path"
    assert settings["engine"]["choices"] == ["CYCLES", "EEVEE"]
    for key in ("samples", "resolution_x", "resolution_y"):
        assert "C.scene" in settings[key]["eval"], key


def test_bake_then_render_chunks_then_assemble(job):
    tasks = job["tasks"]
    assert [t["name"] for t in tasks] == ["bake", "render-1-4", "render-5-8", "render-9-10", "assemble"]
    assert {t["type"] for t in tasks} == {"blender"}
    assert all(len(t["commands"]) == 1 for t in tasks)
    bake, *renders, assemble = tasks
    assert bake["dependencies"] == []
    assert all(t["dependencies"] == ["bake"] for t in renders)
    assert assemble["dependencies"] == [t["name"] for t in renders]


@pytest.mark.parametrize(("frames", "chunk_size", "chunks"), [
    ("1-10", 4, ["1..4", "5..8", "9..10"]),
    ("1-48", 4, [f"{a}..{a + 3}" for a in range(1, 49, 4)]),
    ("1..10", 3, ["1..3", "4..6", "7..9", "10"]),         # Blender's syntax in the setting
    ("3,5-10,47", 2, ["3,5", "6..7", "8..9", "10,47"]),  # gaps: a chunk may span one
    ("7", 4, ["7"]),
])
def test_chunks_cover_every_frame_once(frames, chunk_size, chunks):
    tasks = _compile(frames=frames, chunk_size=chunk_size)["tasks"][1:-1]
    got = [_argv(t["commands"][0])[-1] for t in tasks]
    assert got == chunks
    rendered = [f for chunk in got for f in _blender_frames(chunk)]
    wanted = [f for chunk in chunks for f in _blender_frames(chunk)]
    assert rendered == sorted(set(wanted)) == wanted
    assert all(len(_blender_frames(c)) <= chunk_size for c in got)


def test_bake_command_line(job):
    assert _argv(job["tasks"][0]["commands"][0]) == [
        "blender", "-b", "-y", "-c", "ewrinkles", "bake", SHOT, "--frames", "1-10",
        "--save-as", f"{OUT}/farm.blend", "--engine", "EEVEE", "--samples", "24",
        "--resolution", "640", "360"]


def test_render_command_lines_need_no_add_on(job):
    for task, chunk in zip(job["tasks"][1:-1], ["1..4", "5..8", "9..10"]):
        argv = _argv(task["commands"][0])
        assert argv == ["blender", "-b", "-y", "--factory-startup", f"{OUT}/farm.blend",
                        "--render-output", f"{OUT}/frames/frame_####", "--render-format", "PNG",
                        "--use-extension", "1", "--render-frame", chunk]
        assert "-c" not in argv and SHOT not in argv


def test_assemble_command_line(job):
    assert _argv(job["tasks"][-1]["commands"][0]) == [
        "blender", "-b", "-y", "-c", "ewrinkles", "sheet", f"{OUT}/frames", "--frames", "1-10",
        "--out", f"{OUT}/contact_sheet.png"]


def test_bake_covers_first_to_last_and_sheet_the_frames():
    tasks = _compile(frames="3,5-10,47", chunk_size=2)["tasks"]
    bake, sheet = _argv(tasks[0]["commands"][0]), _argv(tasks[-1]["commands"][0])
    assert bake[bake.index("--frames") + 1] == "3-47"
    assert sheet[sheet.index("--frames") + 1] == "3,5-10,47"


def test_chunk_size_defaults_to_the_job_types():
    settings = {k: v for k, v in SETTINGS.items() if k != "chunk_size"}
    assert len(_run(JOB_TYPE, settings)["tasks"]) == 1 + 3 + 1


def test_recorder_frame_chunker_is_flamencos(tmp_path):
    """Flamenco's frameChunker writes a chunk in its own notation, two frames as "9,10": the
    job type must not pass it to Blender as it is."""
    script = tmp_path / "chunks.js"
    script.write_text(
        'const JOB_TYPE = { label: "Chunks", settings: [{ key: "frames", type: "string" }] };\n'
        "function compileJob(job) {\n"
        "    const t = author.Task('echo', 'misc');\n"
        "    for (const c of frameChunker(job.settings.frames, 4)) {\n"
        "        t.addCommand(author.Command('echo', { message: c }));\n"
        "    }\n"
        "    job.addTask(t);\n"
        "}\n")
    task = _run(script, {"frames": "1-10, 12..13,20"})["tasks"][0]
    assert [c["parameters"]["message"] for c in task["commands"]] == ["1-4", "5-8", "9,10,12,13", "20"]


BAD_JOB_TYPES = {
    "dependency on a task never added": (
        "const a = author.Task('a', 'misc'); a.addCommand(author.Command('echo', { message: 'a' }));\n"
        "const b = author.Task('b', 'misc'); b.addCommand(author.Command('echo', { message: 'b' }));\n"
        "b.addDependency(a); job.addTask(b);", "not added to the job"),
    "unknown command": (
        "const a = author.Task('a', 'misc'); a.addCommand(author.Command('blender-rendr', {}));\n"
        "job.addTask(a);", 'unknown command "blender-rendr"'),
    "dependency given after the task was added": (
        "const a = author.Task('a', 'misc'); a.addCommand(author.Command('echo', { message: 'a' }));\n"
        "const b = author.Task('b', 'misc'); b.addCommand(author.Command('echo', { message: 'b' }));\n"
        "job.addTask(a); job.addTask(b); b.addDependency(a);", "addDependency() after job.addTask(task)"),
    "task with no commands": ("job.addTask(author.Task('a', 'misc'));", 'task "a" has no commands'),
    "blender-render parameter it does not take": (
        "const a = author.Task('a', 'blender');\n"
        "a.addCommand(author.Command('blender-render', { exe: '{blender}', blendFile: 'x.blend' }));\n"
        "job.addTask(a);", 'no parameter "blendFile"'),
    "undeclared variable (strict mode)": ("undeclared = 1;", "undeclared is not defined"),
}


@pytest.mark.parametrize("case", BAD_JOB_TYPES)
def test_recorder_rejects_api_misuse(tmp_path, case):
    body, message = BAD_JOB_TYPES[case]
    script = tmp_path / "bad.js"
    script.write_text('const JOB_TYPE = { label: "Bad", settings: [] };\n'
                      f"function compileJob(job) {{\n{body}\n}}\n")
    proc = _run(script, {}, check=False)
    assert proc.returncode == 1 and message in proc.stderr, proc.stderr


@pytest.mark.parametrize(("changes", "message"), [
    ({"smaples": 24}, 'the job setting "smaples" is not declared by JOB_TYPE'),
    ({"blendfile": None}, 'the job setting "blendfile" must be a string'),
    ({"engine": "WORKBENCH"}, "must be one of CYCLES, EEVEE"),
    ({"samples": 0}, "samples setting must be a whole number of at least 1"),
    ({"render_output_root": "/farm/jobs/shot010", "blendfile": "/farm/jobs/shot010/farm.blend"},
     "the bake would overwrite it"),
])
def test_bad_settings_are_refused(changes, message):
    settings = {**SETTINGS, **changes}
    proc = _run(JOB_TYPE, settings, check=False)
    assert proc.returncode == 1 and message in proc.stderr, proc.stderr


def test_required_setting_missing_is_refused():
    settings = {k: v for k, v in SETTINGS.items() if k != "render_output_root"}
    proc = _run(JOB_TYPE, settings, check=False)
    assert proc.returncode == 1 and '"render_output_root" is required' in proc.stderr, proc.stderr
