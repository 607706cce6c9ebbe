#!/usr/bin/env python3
"""Print the node reference (Markdown): per executable, the topics it publishes and subscribes, the
services and actions it serves or calls, and every parameter with its type, default, allowed values and
description.

Parameters come from each node's parameters dataclass through impurity_common.parameters.parameter_specs,
the same specs the node declares to ROS, so the reference cannot disagree with `--help` on the executable.
Topics, services and actions are read from the node modules' source: every create_publisher,
create_subscription, create_service, create_client and action server or client whose name is a constant
of impurity_common.names. Names a node takes from its parameters (the bag nodes') are not listed there.

    python scripts/node_reference.py                   # the reference, to stdout
    python scripts/node_reference.py --write README.md  # replace the block between the markers
    python scripts/node_reference.py --check README.md  # exit 1 when that block is not the output

The block sits between BEGIN and END (HTML comments, invisible on GitHub). Needs `source scripts/env.sh`.
"""

from __future__ import annotations

import argparse
import ast
import importlib
import importlib.util
import pathlib
import sys

# executable -> (package, node module, extra modules whose ROS interfaces the node owns). The parameters
# class is the one the node module passes to declare_parameters (parameters_class).
NODES = {
    "sim_cell": ("ur5_driver_sim", "ur5_driver_sim.sim_cell", ()),
    "ur5_driver": ("ur5_driver_rtde", "ur5_driver_rtde.ur5_driver_node", ()),
    "heightmap_node": ("impurity_attention", "impurity_attention.heightmap_node", ()),
    "attention_node": ("impurity_attention", "impurity_attention.attention_node", ()),
    "policy_node": ("impurity_policy", "impurity_policy.policy_node", ()),
    "episode_node": ("impurity_policy", "impurity_policy.episode_node", ("impurity_policy.ros_cell",)),
    "cell_state_publisher": ("impurity_viz", "impurity_viz.cell_state_publisher", ()),
    "decision_markers": ("impurity_viz", "impurity_viz.decision_markers", ()),
    "bag_recorder": ("impurity_bags", "impurity_bags.bag_recorder_node", ()),
    "bag_replay": ("impurity_bags", "impurity_bags.bag_replay_node", ()),
}

BEGIN = "<!-- BEGIN node reference (scripts/node_reference.py) -->"
END = "<!-- END node reference -->"

# call name -> the role of its names.* argument
_ROLES = {
    "create_publisher": "publishes",
    "create_subscription": "subscribes",
    "create_service": "serves",
    "create_client": "calls",
    "ActionServer": "action server",
    "ActionClient": "action client",
    "RaceFreeActionClient": "action client",
}
_ROLE_ORDER = ("publishes", "subscribes", "serves", "calls", "action server", "action client")


def interfaces(module_name: str) -> dict:
    """{role: [ROS name, ...]} of the calls in `module_name`'s source whose name argument is `names.X`
    (impurity_common.names); each name once per role, in the order of the source."""
    from impurity_common import names

    source = pathlib.Path(importlib.util.find_spec(module_name).origin).read_text()
    found: dict = {}
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, ast.Call):
            continue
        func = node.func
        called = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", None)
        role = _ROLES.get(called)
        if role is None:
            continue
        for arg in node.args:
            if (isinstance(arg, ast.Attribute) and isinstance(arg.value, ast.Name) and arg.value.id == "names"
                    and isinstance(getattr(names, arg.attr, None), str)):
                value = getattr(names, arg.attr)
                if value not in found.setdefault(role, []):
                    found[role].append(value)
                break
    return found


def parameters_class(module_name: str):
    """The dataclass the node module passes to `declare_parameters(node, <class>)`, read from its source
    and looked up in the imported module; LookupError when the module declares none."""
    source = pathlib.Path(importlib.util.find_spec(module_name).origin).read_text()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Call) and len(node.args) >= 2 and \
                getattr(node.func, "id", getattr(node.func, "attr", None)) == "declare_parameters":
            value = importlib.import_module(module_name)
            for part in ast.unparse(node.args[1]).split("."):
                value = getattr(value, part)
            return value
    raise LookupError(f"{module_name} calls no declare_parameters(node, <class>)")


def _cell(text) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _default(spec) -> str:
    from impurity_common.parameters import format_value

    return f"`{format_value(spec.default)}`"


def node_section(executable: str) -> list:
    """The Markdown lines of one executable."""
    from impurity_common.parameters import allowed, parameter_specs

    package, target, extra = NODES[executable]
    lines = [f"#### `{executable}` ({package})"]
    roles: dict = {}
    for module in (target, *extra):
        for role, found in interfaces(module).items():
            roles.setdefault(role, [])
            roles[role] += [name for name in found if name not in roles[role]]
    said = [f"{role} " + ", ".join(f"`{name}`" for name in roles[role]) for role in _ROLE_ORDER
            if roles.get(role)]
    lines += ["; ".join(said) if said else "Topics from its parameters.", ""]
    specs = parameter_specs(parameters_class(target))
    lines += ["| parameter | type | default | allowed | description |", "|---|---|---|---|---|"]
    for spec in specs:
        kind = f"{spec.kind}[]" if spec.array else spec.kind
        lines.append(f"| `{spec.name}` | {kind} | {_cell(_default(spec))} | {_cell(allowed(spec))} | "
                     f"{_cell(spec.description)} |")
    return lines + [""]


def reference() -> str:
    """The whole reference, BEGIN and END markers included."""
    lines = [BEGIN, "Generated by `python scripts/node_reference.py --write README.md`; do not edit by hand.",
             ""]
    for executable in NODES:
        lines += node_section(executable)
    return "\n".join(lines + [END])


def replaced(text: str, block: str) -> str:
    """`text` with its BEGIN ... END block replaced by `block`; ValueError when the markers are missing."""
    start, stop = text.find(BEGIN), text.find(END)
    if start < 0 or stop < start:
        raise ValueError(f"no '{BEGIN}' ... '{END}' block")
    return text[:start] + block + text[stop + len(END):]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument("--check", type=pathlib.Path, metavar="FILE",
                      help="exit 1 when FILE's generated block differs from the output")
    mode.add_argument("--write", type=pathlib.Path, metavar="FILE", help="replace FILE's generated block")
    args = parser.parse_args(argv)
    block = reference()
    if args.check is None and args.write is None:
        print(block)
        return 0
    path = args.check or args.write
    text = path.read_text()
    try:
        new = replaced(text, block)
    except ValueError as problem:
        print(f"node_reference: {path}: {problem}", file=sys.stderr)
        return 1
    if args.write:
        path.write_text(new)
        return 0
    if new != text:
        print(f"node_reference: {path}'s node reference is stale: run "
              f"python scripts/node_reference.py --write {path}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
