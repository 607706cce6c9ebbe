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


# module -> the launch classes stood in for by recorders of their arguments
RECORDED = {
    "launch": ("LaunchDescription",),
    "launch.actions": ("DeclareLaunchArgument", "OpaqueFunction", "GroupAction", "IncludeLaunchDescription",
                       "EmitEvent", "RegisterEventHandler"),
    "launch.events": ("matches_action",),
    "launch.launch_description_sources": ("PythonLaunchDescriptionSource",),
    "launch.substitutions": ("PathJoinSubstitution",),
    "launch_ros": (),
    "launch_ros.actions": ("Node", "LifecycleNode", "PushRosNamespace"),
    "launch_ros.event_handlers": ("OnStateTransition",),
    "launch_ros.events": (),
    "launch_ros.events.lifecycle": ("ChangeState",),
    "launch_ros.substitutions": ("FindPackageShare",),
}


def stand_in_modules() -> dict:
    """{module name: module}: launch and launch_ros and the submodules the launch file imports."""
    modules = {name: types.ModuleType(name) for name in RECORDED}
    for name, classes in RECORDED.items():
        for cls in classes:
            setattr(modules[name], cls, _recorder(cls))
    modules["launch.substitutions"].LaunchConfiguration = LaunchConfiguration
    return modules


def declared_arguments(monkeypatch, launch_file: pathlib.Path) -> dict[str, dict]:
    """{name: DeclareLaunchArgument's keyword arguments} of `launch_file`."""
    return {args[0]: kwargs for kind, args, kwargs in _actions(monkeypatch, launch_file)
            if kind == "DeclareLaunchArgument"}


def launched_actions(monkeypatch, launch_file: pathlib.Path, arguments: dict) -> list[tuple]:
    """(kind, args, kwargs) of every action the launch file's OpaqueFunction returns (Node,
    IncludeLaunchDescription, GroupAction, ...), `arguments` over its declared defaults."""
    actions = _actions(monkeypatch, launch_file)
    declared = {args[0]: kwargs["default_value"] for kind, args, kwargs in actions
                if kind == "DeclareLaunchArgument"}
    (function,) = [kwargs["function"] for kind, _, kwargs in actions if kind == "OpaqueFunction"]
    return function({**declared, **arguments})


NODE_ACTIONS = ("Node", "LifecycleNode")


def launched_nodes(monkeypatch, launch_file: pathlib.Path, arguments: dict) -> list[dict]:
    """The keyword arguments of every Node (or LifecycleNode) `launch_file` starts, `arguments` over its
    declared defaults."""
    return [kwargs for kind, _, kwargs in launched_actions(monkeypatch, launch_file, arguments)
            if kind in NODE_ACTIONS]


def _actions(monkeypatch, launch_file: pathlib.Path) -> list[tuple]:
    for name, module in stand_in_modules().items():
        monkeypatch.setitem(sys.modules, name, module)
    spec = importlib.util.spec_from_file_location("cell_launch", launch_file)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    _, (actions,), _ = module.generate_launch_description()
    return actions
