# SPDX-License-Identifier: GPL-3.0-or-later
"""The glslang commands the documentation gives for the engine shaders (docs/shaders/) run
as they are written.

Each shader's header comment gives its command on a line of its own; docs/wrinkle_map_shaders.md
and README.md quote commands in backticks.  Every one of them is taken from the text as it
stands and run from a copy of the repository's docs/shaders/ (the commands are written
for the repository's root; their -o output lands in the copy, not in the repository), so a
command that lacks a flag (HLSL input, -D, compiles only to SPIR-V: -V) fails here.
Without glslangValidator the tests skip, or fail with CI=true (tools/setup_system.sh
installs it), like tests/core/test_shaders.py.
"""

import re
import shlex
import shutil
import subprocess

import pytest

from tests.core import glsl_runner as runner

TOOL = "glslangValidator"
SHADERS = (runner.GLSL, runner.HLSL)
DOCS = (runner.ROOT / "docs" / "wrinkle_map_shaders.md", runner.ROOT / "README.md")


def header(path):
    """The text of the comment lines at the top of a shader file (up to its first line of
    code; the GLSL's #version line is skipped)."""
    out = []
    for line in path.read_text().splitlines():
        stripped = line.strip()
        if stripped.startswith("//"):
            out.append(stripped[2:])
        elif stripped and not stripped.startswith("#version"):
            break
    return out


def header_commands(path):
    return [line.strip() for line in header(path) if line.strip().startswith(TOOL + " ")]


def doc_commands(path):
    """The backticked commands of a Markdown file: `glslangValidator ARGS...`."""
    return re.findall(rf"`({TOOL} [^`]+)`", path.read_text())


COMMANDS = ([(path.name + " header", c) for path in SHADERS for c in header_commands(path)]
            + [(path.name, c) for path in DOCS for c in doc_commands(path)])


def run_as_written(command, tmp_path):
    """Run ``command`` (a line of the docs) from a folder laid out like the repository's root
    with a copy of docs/shaders/; returns the finished process."""
    shutil.copytree(runner.GLSL.parent, tmp_path / "docs" / "shaders")
    argv = shlex.split(command)
    assert argv[0] == TOOL
    argv[0] = runner.tool(TOOL)
    return subprocess.run(argv, cwd=tmp_path, capture_output=True, text=True, timeout=300)


def test_each_shader_header_gives_one_command_on_a_line_of_its_own():
    """A command inside a sentence cannot be copied and is not run below: every mention of
    the tool with arguments in a header is its one command line."""
    for path in SHADERS:
        commands = header_commands(path)
        assert len(commands) == 1, f"{path.name}: {commands}"
        assert commands[0].split()[-1] == f"docs/shaders/{path.name}"
        inline = [line for line in header(path)
                  if re.search(rf"{TOOL} -", line) and line.strip() not in commands]
        assert not inline, f"{path.name} mentions {TOOL} with arguments outside its command line: {inline}"
    assert [c for c in COMMANDS if c[0] == "wrinkle_map_shaders.md"], "the doc's commands were not found"


@pytest.mark.parametrize("where,command", COMMANDS, ids=[f"{w}: {c}" for w, c in COMMANDS])
def test_the_documented_command_runs_as_written(where, command, tmp_path):
    done = run_as_written(command, tmp_path)
    assert done.returncode == 0, (f"{where}: `{command}` failed (exit {done.returncode}):\n"
                                  f"{done.stdout}{done.stderr}")
    argv = shlex.split(command)
    if "-o" in argv:  # the SPIR-V it says it writes
        out = tmp_path / argv[argv.index("-o") + 1]
        assert out.is_file() and out.stat().st_size > 0, out


def test_a_command_without_its_spirv_flag_fails(tmp_path):
    """The check can fail: the HLSL command as its header once gave it, without -V."""
    done = run_as_written("glslangValidator -D -S frag -e main docs/shaders/wrinkle_blend.hlsl", tmp_path)
    assert done.returncode != 0 and "SPIR-V" in done.stdout + done.stderr
