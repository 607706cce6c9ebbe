"""Reading the project's sources without importing them (for workspace specifications)."""

import ast
import pathlib


def imported_top_levels(package_dir: pathlib.Path) -> set[str]:
    """Top-level module names (`numpy` for `numpy.linalg`) that any module under `package_dir`
    imports with an absolute import, at any depth of the module."""
    found = set()
    for path in package_dir.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            found |= {name.split(".")[0] for name in names}
    return found
