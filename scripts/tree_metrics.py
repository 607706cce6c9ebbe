"""Size and shape of the decision path, for reviews: prints one line per figure.

    python scripts/tree_metrics.py [--root DIR] [--list]

Figures (all read from the source with `ast`, nothing imported):
- node parameters: the ROS parameters the four nodes between a frame and a grasp declare (heightmap,
  attention, policy, episode): the dataclass each passes to `declare_parameters(self, <class>)`, its fields
  counted recursively through nested parameter dataclasses.
- numeric knobs: numeric fields of the parameter dataclasses (*Params, *Parameters, *Rules, *Limits)
  defined in the decision path's cores
  (impurity_attention/core, impurity_policy/core) plus their UPPER_CASE numeric module constants.
- switched-off paths: fields there whose default is 0, 0.0 or False and whose comment or description says
  0 or False turns it off, choice tuples' members that are not the default and that no other line of src/
  names, and rules in no preset.
- declarations per parameter: for each node parameter, the dataclass fields of its name in its node module
  and in the decision path's cores, plus the keyword arguments `name=<obj>.name` in the node module that
  copy it by hand (1 = declared once).
- files over 500 lines, functions over 60 lines: Python files tracked under src/, bringup/, scripts/,
  benchmarks/, tests/.
"""

from __future__ import annotations

import argparse
import ast
import pathlib
import re
import subprocess
import sys

NODE_MODULES = ("heightmap_node.py", "attention_node.py", "policy_node.py", "episode_node.py")
CORE_DIRS = ("src/impurity_attention/impurity_attention/core", "src/impurity_policy/impurity_policy/core")
OFF_WORDS = re.compile(r"0\s*[=:]\s*(off|no |none|this path off|the same)|off by default|\bOff\b[:.]|"
                       r"False\s*[=:]\s*off", re.IGNORECASE)
PARAMS_CLASS = re.compile(r"(Params|Parameters|Rules|Limits)$")
CODE_DIRS = ("src", "bringup", "scripts", "benchmarks", "tests")


def python_files(root: pathlib.Path, dirs=CODE_DIRS) -> list[pathlib.Path]:
    out = subprocess.run(["git", "-C", str(root), "ls-files", *dirs], capture_output=True, text=True,
                         check=True).stdout.split()
    return [root / p for p in out if p.endswith(".py")]


def classes_in(files) -> dict[str, tuple[ast.ClassDef, pathlib.Path, list[str]]]:
    found = {}
    for path in files:
        text = path.read_text()
        tree = ast.parse(text)
        for node in ast.walk(tree):
            if isinstance(node, ast.ClassDef):
                found.setdefault(node.name, (node, path, text.splitlines()))
    return found


def fields(cls: ast.ClassDef, classes=None):
    """The annotated fields of `cls`, those of its base classes first when `classes` ({name: (ClassDef,
    ...)}) can resolve them, as dataclasses order them."""
    for base in cls.bases if classes else ():
        name = ast.unparse(base).split(".")[-1]
        if name in classes and classes[name][0] is not cls:
            yield from fields(classes[name][0], classes)
    for stmt in cls.body:
        if isinstance(stmt, ast.AnnAssign) and isinstance(stmt.target, ast.Name):
            yield stmt


def annotation_name(stmt: ast.AnnAssign) -> str:
    return ast.unparse(stmt.annotation)


def declared_class(node_file: pathlib.Path) -> str | None:
    for node in ast.walk(ast.parse(node_file.read_text())):
        if isinstance(node, ast.Call) and getattr(node.func, "id", getattr(node.func, "attr", "")) == \
                "declare_parameters" and len(node.args) >= 2:
            return ast.unparse(node.args[1]).split(".")[-1]
    return None


def node_parameters(cls_name: str, classes, prefix="") -> list[str]:
    if cls_name not in classes:
        return []
    cls, _, _ = classes[cls_name]
    names = []
    for stmt in fields(cls, classes):
        value = stmt.value
        if value is not None and "ros=False" in ast.unparse(value).replace(" ", ""):
            continue
        ann = annotation_name(stmt)
        if ann in classes and ann != cls_name and any(True for _ in fields(classes[ann][0])):
            names += node_parameters(ann, classes, prefix + stmt.target.id + ".")
        else:
            names.append(prefix + stmt.target.id)
    return names


NUMERIC = ("float", "int")


def constant_name(stmt) -> str:
    """The name of a module-level UPPER_CASE constant assigned by `stmt`, else ""."""
    if isinstance(stmt, ast.Assign) and len(stmt.targets) == 1 and isinstance(stmt.targets[0], ast.Name) \
            and stmt.targets[0].id.isupper():
        return stmt.targets[0].id
    return ""


def numeric_knobs(root, classes) -> list[str]:
    knobs = []
    for d in CORE_DIRS:
        for path in sorted((root / d).glob("*.py")):
            tree = ast.parse(path.read_text())
            for stmt in tree.body:
                name = constant_name(stmt)
                if name and isinstance(stmt.value, ast.Constant) and \
                        type(stmt.value.value) in (int, float):
                    knobs.append(f"{path.name}:{name}")
                if isinstance(stmt, ast.ClassDef) and PARAMS_CLASS.search(stmt.name) and any(
                        "dataclass" in ast.unparse(dec) for dec in stmt.decorator_list):
                    for f in fields(stmt):
                        if annotation_name(f).split("[")[0] in NUMERIC:
                            knobs.append(f"{path.name}:{stmt.name}.{f.target.id}")
    return knobs


def switched_off(root) -> list[str]:
    sources = [f.read_text() for f in python_files(root, ("src",))]
    out = []
    for d in CORE_DIRS:
        for path in sorted((root / d).glob("*.py")):
            text = path.read_text()
            lines = text.splitlines()
            tree = ast.parse(text)
            for stmt in ast.walk(tree):
                if isinstance(stmt, ast.ClassDef) and PARAMS_CLASS.search(stmt.name) and \
                        any("dataclass" in ast.unparse(x) for x in stmt.decorator_list):
                    for f in fields(stmt):
                        if f.value is None:
                            continue
                        default = f.value
                        if isinstance(default, ast.Call) and default.args:
                            default = default.args[0]
                        if not (isinstance(default, ast.Constant) and default.value in (0, 0.0, False)
                                and default.value is not None):
                            continue
                        start = f.lineno - 1
                        while start > 0 and lines[start - 1].strip().startswith("#"):
                            start -= 1
                        said = "\n".join(lines[start:f.end_lineno])
                        if start == f.lineno - 1:  # no comment of its own: a block above that names it
                            above = "\n".join(lines[max(0, f.lineno - 14):f.lineno - 1])
                            said += "\n" + (above if f.target.id in above else "")
                        checks = re.findall(rf"{f.target.id}[^\n]*\(0 = off\)", text)
                        if OFF_WORDS.search(said) or checks:
                            out.append(f"{path.name}:{stmt.name}.{f.target.id} = {ast.unparse(default)}")
                if constant_name(stmt).endswith("S") and constant_name(stmt) != "CHANNELS" and \
                        isinstance(stmt.value, ast.Tuple) and 2 <= len(stmt.value.elts) <= 4 and \
                        all(isinstance(getattr(e, "value", None), str) for e in stmt.value.elts):
                    choices = [e.value for e in stmt.value.elts]
                    default = [c for c in choices if re.search(rf'str\s*=\s*(param\()?"{c}"', text)]
                    for c in choices:
                        if default and c not in default and sum(
                                f'"{c}"' in s for s in sources) <= 1:  # named nowhere but in its tuple
                            out.append(f"{path.name}:{stmt.targets[0].id} '{c}' (not the default)")
                if constant_name(stmt) == "CANDIDATES" and isinstance(stmt.value, ast.Tuple):
                    out += [f"{path.name}: rule '{e.value}' in no preset" for e in stmt.value.elts]
    return out


def declarations(root, params) -> dict[str, int]:
    """{"<node module>:<parameter>": places it is declared}: dataclass fields of its name in the node module
    and in the decision path's cores, plus keyword arguments in the node module that copy it by hand
    (`name=<obj>.name`)."""
    core = [ast.parse(f.read_text()) for d in CORE_DIRS for f in sorted((root / d).glob("*.py"))]
    count = {}
    for param in params:
        module, name = param.split(":")
        leaf = name.split(".")[-1]
        node_tree = ast.parse(next(f for f in python_files(root, ("src",)) if f.stem == module).read_text())
        n = 0
        for tree in (node_tree, *core):
            for node in ast.walk(tree):
                if isinstance(node, ast.ClassDef) and \
                        any("dataclass" in ast.unparse(d) for d in node.decorator_list):
                    n += sum(f.target.id == leaf for f in fields(node))
        n += sum(isinstance(node, ast.keyword) and node.arg == leaf and isinstance(node.value, ast.Attribute)
                 and node.value.attr == leaf for node in ast.walk(node_tree))
        count[param] = n
    return count


def long_functions(files, limit=60) -> list[str]:
    out = []
    for path in files:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and \
                    node.end_lineno - node.lineno + 1 > limit:
                out.append(f"{path}:{node.name} {node.end_lineno - node.lineno + 1}")
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--root", default=str(pathlib.Path(__file__).resolve().parents[1]))
    p.add_argument("--list", action="store_true", help="also list what each figure counts")
    args = p.parse_args(argv)
    root = pathlib.Path(args.root).resolve()
    files = python_files(root)
    src_files = [f for f in files if str(f.relative_to(root)).startswith("src/")]
    classes = classes_in(src_files)
    params = []
    for node_file in [f for f in src_files if f.name in NODE_MODULES]:
        cls = declared_class(node_file)
        params += [f"{node_file.stem}:{n}" for n in node_parameters(cls, classes)] if cls else []
    knobs = numeric_knobs(root, classes)
    off = switched_off(root)
    decl = declarations(root, params)
    big = [f"{f.relative_to(root)} {len(f.read_text().splitlines())}" for f in files
           if len(f.read_text().splitlines()) > 500]
    longf = long_functions(files)
    many = {k: v for k, v in decl.items() if v > 1}
    print(f"node parameters on the decision path: {len(params)}")
    print(f"numeric knobs in the decision path's cores: {len(knobs)}")
    print(f"switched-off paths: {len(off)}")
    print(f"declarations per node parameter: mean {sum(decl.values()) / max(len(decl), 1):.2f}, "
          f"max {max(decl.values(), default=0)}, declared more than once: {len(many)} of {len(decl)}")
    print(f"python files over 500 lines: {len(big)}")
    print(f"functions over 60 lines: {len(longf)}")
    if args.list:
        for title, items in (("node parameters", params), ("numeric knobs", knobs), ("switched-off", off),
                             ("declared more than once", [f"{k} {v}" for k, v in many.items()]),
                             ("files over 500 lines", big), ("functions over 60 lines", longf)):
            print(f"\n## {title}")
            print("\n".join(f"  {i}" for i in items))
    return 0


if __name__ == "__main__":
    sys.exit(main())
