#!/usr/bin/env python3
"""Build and validate the Expression Wrinkles extension zip.

    python tools/build_extension.py [--output-dir dist]

Blender wants ``blender_manifest.toml`` next to ``__init__.py`` at the root of the zip,
while this repository keeps the manifest at its top level and the code in
``wrinkle_addon/``. So this script stages a temporary directory holding the manifest plus
the contents of ``wrinkle_addon/`` (no ``__pycache__``, no ``*.pyc``), then runs Blender's
own extension tool on it: ``build``, then ``validate`` on the resulting zip.

The tool is ``bpy/<ver>/scripts/addons_core/bl_pkg/cli/blender_ext.py`` inside the bpy
wheel. It needs only the standard library, so it is located from the running
interpreter's installed ``bpy`` package without importing bpy, and run as a subprocess.
Set ``BLENDER_EXT_TOOL`` to use another copy of it.

Prints the path of the zip as the last line; exits non-zero with a message on failure.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MANIFEST = ROOT / "blender_manifest.toml"
PACKAGE = ROOT / "wrinkle_addon"
IGNORE = shutil.ignore_patterns("__pycache__", "*.pyc", "*.pyo")


class BuildError(Exception):
    pass


def find_blender_ext() -> Path:
    """Path of blender_ext.py in the installed bpy wheel (bpy is located, not imported)."""
    override = os.environ.get("BLENDER_EXT_TOOL")
    if override:
        path = Path(override)
        if not path.is_file():
            raise BuildError(f"BLENDER_EXT_TOOL={override} does not exist")
        return path
    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        raise BuildError(
            f"the bpy package is not installed for {sys.executable}; "
            "run this with .venv45/bin/python (bash tools/setup_env.sh 45)"
        )
    candidates = []
    for location in spec.submodule_search_locations:
        candidates += Path(location).glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py")
    if not candidates:
        raise BuildError(f"blender_ext.py not found under {list(spec.submodule_search_locations)}")
    return sorted(candidates)[-1]


def run_tool(tool: Path, *args: str) -> None:
    cmd = [sys.executable, str(tool), *args]
    print("$", " ".join(cmd), flush=True)
    result = subprocess.run(cmd, stdin=subprocess.DEVNULL)
    if result.returncode != 0:
        raise BuildError(f"blender_ext.py {args[0]} failed with exit status {result.returncode}")


def build(output_dir: Path) -> Path:
    if not MANIFEST.is_file() or not (PACKAGE / "__init__.py").is_file():
        raise BuildError(f"expected {MANIFEST} and {PACKAGE / '__init__.py'}")
    tool = find_blender_ext()
    output_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="wrinkle-ext-") as tmp:
        stage = Path(tmp) / "stage"
        shutil.copytree(PACKAGE, stage, ignore=IGNORE)
        shutil.copy2(MANIFEST, stage / MANIFEST.name)
        # Build into an empty directory so the zip's name (id-version.zip, from the
        # manifest) is simply the only file there.
        out = Path(tmp) / "out"
        out.mkdir()
        run_tool(tool, "build", "--source-dir", str(stage), "--output-dir", str(out))
        zips = list(out.glob("*.zip"))
        if len(zips) != 1:
            raise BuildError(f"expected one zip from the build, found {[z.name for z in zips]}")
        target = output_dir / zips[0].name
        shutil.move(zips[0], target)
    run_tool(tool, "validate", str(target))
    return target


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--output-dir", type=Path, default=ROOT / "dist", help="where the zip goes (default: dist/)"
    )
    args = parser.parse_args(argv)
    try:
        zip_path = build(args.output_dir.resolve())
    except BuildError as exc:
        print(f"build_extension: ERROR: {exc}", file=sys.stderr)
        return 1
    print(zip_path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
