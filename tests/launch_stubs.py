"""cell.launch.py without the launch and launch_ros modules (not among the PyPI wheels): stand-ins whose
actions record their arguments and whose LaunchConfiguration performs to the launch arguments given."""

import importlib.util
import pathlib
import sys
import types


def _recorder(kind):
    return lambda *args, **kwargs: (kind, args, kwargs)


class LaunchConfiguration:
    def __init__(self, name):
        self.name = name

    def perform(self, context):
        return context[self.name]


def stand_in_modules() -> dict:
    """{module name: module}: launch, launch.actions, launch.substitutions, launch_ros(.actions)."""
    modules = {name: types.ModuleType(name) for name in
               ("launch", "launch.actions", "launch.substitutions", "launch_ros", "launch_ros.actions")}
    modules["launch"].LaunchDescription = _recorder("LaunchDescription")
    modules["launch.actions"].DeclareLaunchArgument = _recorder("DeclareLaunchArgument")
    modules["launch.actions"].OpaqueFunction = _recorder("OpaqueFunction")
    modules["launch.substitutions"].LaunchConfiguration = LaunchConfiguration
    modules["launch_ros.actions"].Node = _recorder("Node")
    return modules


def launched_nodes(monkeypatch, launch_file: pathlib.Path, arguments: dict) -> list[dict]:
    """The keyword arguments of every Node `launch_file` starts, `arguments` over its declared defaults."""
    for name, module in stand_in_modules().items():
        monkeypatch.setitem(sys.modules, name, module)
    spec = importlib.util.spec_from_file_location("cell_launch", launch_file)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    _, (actions,), _ = module.generate_launch_description()
    declared = {args[0]: kwargs["default_value"] for kind, args, kwargs in actions
                if kind == "DeclareLaunchArgument"}
    (function,) = [kwargs["function"] for kind, _, kwargs in actions if kind == "OpaqueFunction"]
    return [kwargs for _, _, kwargs in function({**declared, **arguments})]
