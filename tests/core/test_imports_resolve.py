"""Every import of the add-on anywhere in the repository names a module and names that exist:
the benchmarks, the sample scenes and the tools run outside CI's test session, so a renamed
module or function would otherwise break them unseen.  Pure Python (``ast``), no Blender."""

import ast
from pathlib import Path

from tests.core import pyimports

ROOT = Path(__file__).resolve().parents[2]
FOLDERS = ("wrinkle_addon", "tests", "benchmarks", "sample_scenes", "tools", "farm")


def _files():
    for folder in FOLDERS:
        for path in sorted((ROOT / folder).rglob("*.py")):
            if not {"node_modules", "__pycache__"} & set(path.parts):
                yield path


def _module_path(dotted):
    """The file of the module ``dotted`` (``wrinkle_addon.glue.faces``), or None."""
    base = ROOT.joinpath(*dotted.split("."))
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return base if base.is_dir() else None  # a namespace package


def _bound(statements):
    """The names ``statements`` bind (definitions, assignments, imports), inside ``if``,
    ``try`` and ``with`` blocks too (a guarded definition counts)."""
    names = set()
    for node in statements:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
            for target in node.targets if isinstance(node, ast.Assign) else [node.target]:
                names.update(n.id for n in ast.walk(target) if isinstance(n, ast.Name))
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names.update((a.asname or a.name).split(".")[0] for a in node.names)
        elif isinstance(node, (ast.If, ast.Try, ast.With)):
            inner = node.body + getattr(node, "orelse", []) + getattr(node, "finalbody", [])
            names |= _bound(inner + [s for h in getattr(node, "handlers", []) for s in h.body])
    return names


def _top_level_names(path):
    """The names a module binds at its top level."""
    return set() if path.is_dir() else _bound(ast.parse(path.read_text()).body)


def test_every_import_of_the_add_on_resolves():
    bad = []
    for path in _files():
        for line, module, names in pyimports.imports(path, ROOT):
            if module.split(".")[0] != "wrinkle_addon":
                continue
            where = f"{path.relative_to(ROOT)}:{line}"
            target = _module_path(module)
            if target is None:
                bad.append(f"{where}: no module {module}")
                continue
            defined = _top_level_names(target)
            for name in names or ():
                if name != "*" and name not in defined and _module_path(f"{module}.{name}") is None:
                    bad.append(f"{where}: {module} has no {name}")
    assert not bad, "\n".join(bad)


def test_a_broken_import_is_found(tmp_path, monkeypatch):
    """The check itself: a missing module and a missing name are both reported."""
    pkg = tmp_path / "wrinkle_addon"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "real.py").write_text("def here():\n    pass\n")
    (pkg / "user.py").write_text("from .real import here, gone\n"
                                 "from . import missing\n"
                                 "import wrinkle_addon.nowhere\n")
    monkeypatch.setattr(f"{__name__}.ROOT", tmp_path)
    monkeypatch.setattr(f"{__name__}.FOLDERS", ("wrinkle_addon",))
    try:
        test_every_import_of_the_add_on_resolves()
    except AssertionError as exc:
        assert "wrinkle_addon.real has no gone" in str(exc) and "wrinkle_addon has no missing" in str(exc)
        assert "no module wrinkle_addon.nowhere" in str(exc), str(exc)
    else:
        raise AssertionError("the broken imports were not found")
