"""Reading a Python file's imports with ``ast``, for the tests that check them (the layers, the
circles, that every import resolves)."""

import ast


def module_name(path, root):
    """The dotted name of the module in ``path`` under ``root``."""
    parts = list(path.relative_to(root).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(path, root):
    """``(line, module, names)`` of every import in ``path`` (at the top of the file or inside a
    function): ``module`` absolute, a relative one resolved against the file's place under
    ``root``; ``names`` the names a ``from`` import takes, None for a plain ``import``."""
    name = module_name(path, root).split(".")
    here = name if path.name == "__init__.py" else name[:-1]
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name, None
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = here[: len(here) - node.level + 1]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            yield node.lineno, module, [alias.name for alias in node.names]


def targets(module, names, is_module):
    """The modules an import reaches: ``from package import name`` counts as an import of the
    submodule ``name`` when ``is_module(package.name)``, else of ``package``."""
    if names is None:
        return [module]
    return [f"{module}.{n}" if is_module(f"{module}.{n}") else module for n in names]
