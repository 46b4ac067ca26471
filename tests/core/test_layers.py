"""The layers of docs/architecture.md, checked on the source: which package may import
which.  Pure Python (``ast``), so it runs in the fast tier without Blender."""

from pathlib import Path

from tests.core import pyimports

PACKAGE = Path(__file__).resolve().parents[2] / "wrinkle_addon"
ROOT = PACKAGE.parent
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
# glue sub-packages (the methods' and the exports'): the only imports between them, and why
# (docs/architecture.md, "Allowed imports"); what several use is a module of glue itself
GLUE_PACKAGES = METHODS | {"export"}
GLUE_CROSSINGS = {
    ("bando", "muscles"): "the fine wrinkles' direction field follows the muscles' pull",
    ("maps", "muscles"): "Bake Wrinkle Map bakes the muscles' wrinkles zone by zone",
    ("export", "maps"): "the exports carry the wrinkle maps' material and its table",
}


def _is_module(dotted):
    base = ROOT.joinpath(*dotted.split("."))
    return base.with_suffix(".py").is_file() or (base / "__init__.py").is_file()


def _imports(path):
    """(absolute module, line) of every import in ``path``, relative ones resolved; ``from
    package import name`` is an import of the submodule ``name`` when there is one."""
    for line, module, names in pyimports.imports(path, ROOT):
        for target in pyimports.targets(module, names, _is_module):
            yield target, line


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


def _crossings(layer, packages):
    """``(file, line, module, (its package, the imported package))`` of every import from one
    of ``layer``'s sub-packages ``packages`` into another."""
    for path in _modules():
        rel = path.relative_to(PACKAGE)
        if rel.parts[0] != layer or len(rel.parts) < 3:
            continue
        for module, line in _imports(path):
            parts = module.split(".")
            if parts[:2] == ["wrinkle_addon", layer] and len(parts) > 2 and parts[2] in packages \
                    and parts[2] != rel.parts[1]:
                yield rel, line, module, (rel.parts[1], parts[2])


def test_core_methods_do_not_import_each_other():
    bad = [f"{rel}:{line} imports {module}" for rel, line, module, _edge in _crossings("core", METHODS)]
    assert not bad, "\n".join(bad)


def test_glue_packages_import_each_other_only_where_declared():
    found = list(_crossings("glue", GLUE_PACKAGES))
    bad = [f"{rel}:{line} imports {module}" for rel, line, module, edge in found
           if edge not in GLUE_CROSSINGS]
    assert not bad, "\n".join(bad)
    assert {edge for *_where, edge in found} == set(GLUE_CROSSINGS), "a declared crossing no import makes"


def test_every_folder_states_its_rule():
    for folder in [PACKAGE] + [p for p in PACKAGE.rglob("*") if p.is_dir() and p.name != "__pycache__"]:
        if any(folder.glob("*.py")):
            readme = folder / "README.md"
            assert readme.is_file() and readme.read_text().strip(), f"{folder.relative_to(PACKAGE.parent)}"




def _import_graph(files, bare=""):
    """module -> the modules of ``files`` it imports (at the top or inside a function), a
    ``from package import name`` counted as an import of the submodule ``name`` when there is
    one.  ``bare``: the package whose modules are also imported by their bare names (the
    benchmarks put their own folder on ``sys.path``)."""
    names = {pyimports.module_name(p, ROOT): p for p in files}
    graph = {}
    for name, path in names.items():
        out = set()
        for _line, module, imported in pyimports.imports(path, ROOT):
            for t in pyimports.targets(module, imported, names.__contains__):
                if bare and t not in names and f"{bare}.{t}" in names:
                    t = f"{bare}.{t}"
                if t in names and t != name:
                    out.add(t)
        graph[name] = out
    return graph


def _circles(graph):
    """The strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = set()
            while True:
                w = stack.pop()
                on.discard(w)
                component.add(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_no_module_imports_round_a_circle():
    # the package's own __init__ registers every layer and is imported by none
    files = [p for p in _modules() if p != PACKAGE / "__init__.py"]
    assert _circles(_import_graph(files)) == []


def test_no_benchmark_imports_round_a_circle():
    files = sorted((ROOT / "benchmarks").glob("*.py"))
    assert _circles(_import_graph(files, bare="benchmarks")) == []


def test_a_circle_is_found():
    assert _circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _circles({"a": {"b"}, "b": set()}) == []
