"""The layers of docs/architecture.md, checked on the source: which package may import
which.  Pure Python (``ast``), so it runs in the fast tier without Blender."""

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[2] / "wrinkle_addon"
BLENDER = {"bpy", "bmesh", "mathutils", "bpy_extras", "gpu", "gpu_extras", "addon_utils"}
# layer -> the add-on layers it may import (besides itself)
ALLOWED = {
    "core": set(),
    "glue": {"core"},
    "props": {"core", "glue"},
    "ops": {"core", "glue"},
    "ui": {"core", "glue"},
    "sources": {"core", "glue", "props", "ui"},
    "cli": {"core", "glue"},
}
# core sub-packages, one per method: independent of each other
METHODS = {"muscles", "maps", "bando", "patterns"}


def _imports(path):
    """(absolute module, line) of every import in ``path``, relative ones resolved."""
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    here = parts if path.name == "__init__.py" else parts[:-1]
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, node.lineno
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = here[: len(here) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module
            for alias in node.names:  # ``from . import glue`` names a module too
                yield (f"{mod}.{alias.name}" if not node.module else mod), node.lineno


def _layer(module):
    parts = module.split(".")
    return parts[1] if parts[0] == "wrinkle_addon" and len(parts) > 1 else None


def _modules():
    return sorted(p for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts)


def test_every_layer_imports_only_what_it_may():
    bad = []
    for path in _modules():
        rel = path.relative_to(PACKAGE)
        layer = rel.parts[0] if len(rel.parts) > 1 else None
        if layer is None:  # wrinkle_addon/__init__.py registers everything
            continue
        assert layer in ALLOWED, f"{rel}: a folder that docs/architecture.md does not list"
        for module, line in _imports(path):
            top = module.split(".")[0]
            target = _layer(module)
            if layer == "core" and (top in BLENDER or (target is None and top == "wrinkle_addon")):
                bad.append(f"{rel}:{line} core imports {module}")
            elif target is not None and target != layer and target not in ALLOWED[layer]:
                bad.append(f"{rel}:{line} {layer} imports {module}")
    assert not bad, "\n".join(bad)


def test_core_methods_do_not_import_each_other():
    bad = []
    for path in _modules():
        rel = path.relative_to(PACKAGE)
        if rel.parts[0] != "core" or len(rel.parts) < 3:
            continue
        for module, line in _imports(path):
            parts = module.split(".")
            others = METHODS - {rel.parts[1]}
            if parts[:2] == ["wrinkle_addon", "core"] and len(parts) > 2 and parts[2] in others:
                bad.append(f"{rel}:{line} imports {module}")
    assert not bad, "\n".join(bad)


def test_every_folder_states_its_rule():
    for folder in [PACKAGE] + [p for p in PACKAGE.rglob("*") if p.is_dir() and p.name != "__pycache__"]:
        if any(folder.glob("*.py")):
            readme = folder / "README.md"
            assert readme.is_file() and readme.read_text().strip(), f"{folder.relative_to(PACKAGE.parent)}"
