"""Every custom property the add-on writes on a datablock or a node starts with
``ewrinkles_`` (``props/migrate.py`` moves the older names on load), checked on the source.
Pure Python (``ast``), so it runs in the fast tier without Blender.

A write is ``holder["key"] = value`` (or ``holder[KEY]`` with ``KEY`` a string constant of
the same module) and the ``key=`` of ``ensure_group``, which tags a node group with its
version.  A name bound in the same function to a dict (``{...}``, ``dict(...)``, a dict
comprehension or ``**kwargs``) holds no ID properties and is left out."""

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[2] / "wrinkle_addon"
PREFIX = "ewrinkles_"
# Not a stored property: the glTF extras key of the material copy an export writes (engines
# read it under that name), never kept in the artist's file.
EXTRAS = "ewrinkles"


def _constants(tree):
    """The module's string constants: ``NAME = "..."`` at the top level."""
    out = {}
    for node in tree.body:
        if isinstance(node, ast.Assign) and isinstance(node.value, ast.Constant) and isinstance(
                node.value.value, str):
            out.update((t.id, node.value.value) for t in node.targets if isinstance(t, ast.Name))
    return out


_FUNCTIONS = (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)


def _own(scope):
    """The nodes of ``scope`` (the module or a function) outside the functions it defines."""
    todo = list(ast.iter_child_nodes(scope))
    while todo:
        node = todo.pop()
        yield node
        if not isinstance(node, _FUNCTIONS):
            todo.extend(ast.iter_child_nodes(node))


def _dicts(scope):
    """The names bound to a dict in ``scope``."""
    names = {scope.args.kwarg.arg} if getattr(getattr(scope, "args", None), "kwarg", None) else set()
    for node in _own(scope):
        value = getattr(node, "value", None) if isinstance(node, ast.Assign) else None
        if isinstance(value, (ast.Dict, ast.DictComp)) or (
                isinstance(value, ast.Call) and getattr(value.func, "id", None) == "dict"):
            names.update(t.id for t in node.targets if isinstance(t, ast.Name))
    return names


def _writes(source):
    """(line, key) of every ID property write in the module ``source`` whose key is known."""
    tree = ast.parse(source)
    constants = _constants(tree)
    for scope in [tree] + [n for n in ast.walk(tree) if isinstance(n, _FUNCTIONS)]:
        dicts = _dicts(scope)
        for node in _own(scope):
            targets = node.targets if isinstance(node, ast.Assign) else (
                [node.target] if isinstance(node, ast.AugAssign) else [])
            for target in targets:
                for t in target.elts if isinstance(target, ast.Tuple) else [target]:
                    if not isinstance(t, ast.Subscript) or getattr(t.value, "id", None) in dicts:
                        continue
                    key = constants.get(t.slice.id) if isinstance(t.slice, ast.Name) else getattr(
                        t.slice, "value", None)
                    if isinstance(key, str):
                        yield node.lineno, key
            func = node.func if isinstance(node, ast.Call) else None
            if getattr(func, "attr", getattr(func, "id", None)) == "ensure_group":
                for kw in node.keywords:
                    if kw.arg == "key" and isinstance(kw.value, ast.Constant):
                        yield node.lineno, kw.value.value


def test_every_id_property_the_add_on_writes_starts_with_the_prefix():
    bad = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if path == PACKAGE / "props" / "migrate.py":  # it writes the old names' values under the new
            continue
        for line, key in set(_writes(path.read_text())):
            if not key.startswith(PREFIX) and key != EXTRAS:
                bad.append(f"{path.relative_to(PACKAGE.parent)}:{line}: {key!r}")
    assert not bad, "custom properties without the prefix (add the old name to migrate.KEYS):\n" + "\n".join(
        sorted(bad))


def test_the_check_sees_a_write():
    """The check itself: it finds the writes it looks for and leaves dicts alone."""
    src = '''
KEY = "wrinkle_const"
def f(ob, **kw):
    d = {}
    ob["wrinkle_a"] = 1
    ob[KEY], x = 2, 3
    d["plain"] = kw["plain"] = 4
    nodes.ensure_group("G", "T", 1, None, None, key="wrinkle_v")
'''
    assert sorted(k for _line, k in _writes(src)) == ["wrinkle_a", "wrinkle_const", "wrinkle_v"]
