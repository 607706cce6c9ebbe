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
    """{module name: module}: launch, launch.actions, launch.events, launch.substitutions,
    launch_ros(.actions, .event_handlers, .events, .events.lifecycle)."""
    modules = {name: types.ModuleType(name) for name in
               ("launch", "launch.actions", "launch.events", "launch.substitutions", "launch_ros",
                "launch_ros.actions", "launch_ros.event_handlers", "launch_ros.events",
                "launch_ros.events.lifecycle")}
    modules["launch"].LaunchDescription = _recorder("LaunchDescription")
    for action in ("DeclareLaunchArgument", "OpaqueFunction", "EmitEvent", "RegisterEventHandler"):
        setattr(modules["launch.actions"], action, _recorder(action))
    modules["launch.events"].matches_action = _recorder("matches_action")
    modules["launch.substitutions"].LaunchConfiguration = LaunchConfiguration
    modules["launch_ros.actions"].Node = _recorder("Node")
    modules["launch_ros.actions"].LifecycleNode = _recorder("LifecycleNode")
    modules["launch_ros.event_handlers"].OnStateTransition = _recorder("OnStateTransition")
    modules["launch_ros.events.lifecycle"].ChangeState = _recorder("ChangeState")
    return modules


NODE_ACTIONS = ("Node", "LifecycleNode")


def launched_actions(monkeypatch, launch_file: pathlib.Path, arguments: dict) -> list[tuple]:
    """(kind, args, kwargs) of every action `launch_file`'s nodes function returns, `arguments` over its
    declared defaults: Node, LifecycleNode, and the lifecycle events (EmitEvent, RegisterEventHandler)."""
    for name, module in stand_in_modules().items():
        monkeypatch.setitem(sys.modules, name, module)
    spec = importlib.util.spec_from_file_location("cell_launch", launch_file)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    _, (actions,), _ = module.generate_launch_description()
    declared = {args[0]: kwargs["default_value"] for kind, args, kwargs in actions
                if kind == "DeclareLaunchArgument"}
    (function,) = [kwargs["function"] for kind, _, kwargs in actions if kind == "OpaqueFunction"]
    return function({**declared, **arguments})


def launched_nodes(monkeypatch, launch_file: pathlib.Path, arguments: dict) -> list[dict]:
    """The keyword arguments of every Node (or LifecycleNode) `launch_file` starts, `arguments` over its
    declared defaults."""
    return [kwargs for kind, _, kwargs in launched_actions(monkeypatch, launch_file, arguments)
            if kind in NODE_ACTIONS]
