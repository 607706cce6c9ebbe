"""Reading the project's sources without importing them (for workspace specifications)."""

import ast
import pathlib


def imported_top_levels(package_dir: pathlib.Path) -> set[str]:
    """Top-level module names (`numpy` for `numpy.linalg`) that any module under `package_dir` (or the
    one module `package_dir` names) imports with an absolute import, at any depth of the module."""
    found = set()
    for path in [package_dir] if package_dir.is_file() else package_dir.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            found |= {name.split(".")[0] for name in names}
    return found


_NOT_LITERAL = object()  # what _literal gives for an expression that is not a literal


def _literal(node):
    if isinstance(node, ast.Dict):  # its literal entries only: {"a": 1, "b": BASE + 1} -> {"a": 1}
        entries = {}
        for key, value in zip(node.keys, node.values, strict=True):
            key, value = _literal(key), _literal(value)
            if key is not _NOT_LITERAL and value is not _NOT_LITERAL:
                entries[key] = value
        return entries
    try:
        return ast.literal_eval(node)
    except ValueError:
        return _NOT_LITERAL


def module_constants(path: pathlib.Path) -> dict:
    """The module-level NAME = <literal> (and A, B = <literal>, <literal>) assignments of a Python file; of a
    dict, its literal entries only."""
    found = {}
    for node in ast.parse(path.read_text(), str(path)).body:
        if not isinstance(node, ast.Assign) or len(node.targets) != 1:
            continue
        target, value = node.targets[0], node.value
        pairs = [(target, value)]
        if isinstance(target, ast.Tuple) and isinstance(value, ast.Tuple):
            pairs = list(zip(target.elts, value.elts, strict=True))
        for name, item in pairs:
            if isinstance(name, ast.Name) and (constant := _literal(item)) is not _NOT_LITERAL:
                found[name.id] = constant
    return found


def option_default(path: pathlib.Path, option: str):
    """The default of a script's argparse option `option` (its add_argument call's `default=` literal)."""
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if (isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant)
                and node.args[0].value == option):
            return next(ast.literal_eval(k.value) for k in node.keywords if k.arg == "default")
    raise AssertionError(f"{path} has no option {option}")
