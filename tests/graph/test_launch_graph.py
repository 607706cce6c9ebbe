"""The cell started by its launcher (launch_cell, the pip twin of cell.launch.py: the same node lists,
files and namespace) on this session's domain: under a namespace every node, and every topic, service and
action of theirs, is in it, but for the ROS globals; the pieces still find each other there (the simulated
camera feeds the heightmap node, the episode node answers episode_client --namespace). The real cell
runs as a dry run (its real_cell.yaml default, or dry_run:=true) with no robot, under its namespace too."""

import subprocess
import sys

import pytest
from rclpy.action import ActionClient
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_srvs.srv import Trigger

from impurity_bringup.cell_nodes import CELLS
from impurity_common import names
from impurity_interfaces.action import ExecutePrimitive
from impurity_interfaces.msg import Heightmap
from ros_harness import TopicRecorder, call_service, spin_until

# Names every node has at the root whatever its namespace (rclpy's own, and TF as ROS tools expect it)
GLOBALS = {"/rosout", "/parameter_events", "/clock", "/diagnostics", "/tf", "/tf_static"}
# executable -> its ROS node name
NODE_NAMES = {"sim_cell": "sim_cell", "ur5_driver": "ur5_driver", "heightmap_node": "heightmap",
              "attention_node": "attention", "policy_node": "policy", "episode_node": "episode",
              "cell_state_publisher": "cell_state_publisher", "decision_markers": "decision_markers"}


def nodes_in(ros_node, namespace: str) -> set[str]:
    return {name for name, ns in ros_node.get_node_names_and_namespaces() if ns == namespace}


def names_of(ros_node, node_name: str, namespace: str) -> dict[str, set[str]]:
    """{kind: the names node `node_name` in `namespace` publishes, subscribes to or serves}."""
    graph = {"publishes": ros_node.get_publisher_names_and_types_by_node,
             "subscribes": ros_node.get_subscriber_names_and_types_by_node,
             "serves": ros_node.get_service_names_and_types_by_node}
    return {kind: {name for name, _ in query(node_name, namespace)} for kind, query in graph.items()}


def outside(namespace: str, found: dict[str, set[str]]) -> dict[str, list[str]]:
    """The names of `found` neither under `namespace` nor global."""
    return {kind: sorted(name for name in ros_names
                         if not name.startswith(namespace + "/") and name not in GLOBALS)
            for kind, ros_names in found.items()
            if any(not name.startswith(namespace + "/") and name not in GLOBALS for name in ros_names)}


def start_cell(launch, *arguments):
    return launch("impurity_bringup", "launch_cell", ["--quiet", *arguments])


def wait_for_nodes(ros_node, namespace: str, expected: set[str], cell) -> None:
    spin_until(ros_node, lambda: expected <= nodes_in(ros_node, namespace), 120.0,
               f"the nodes {sorted(expected)} in {namespace}", [cell])


def wait_for_endpoints(ros_node, namespace: str, node_names, cell) -> dict[str, dict[str, set[str]]]:
    """Every node's names once each has created its publishers, subscriptions and services (a node
    appears in the graph before its endpoints)."""
    found = {}

    def complete() -> bool:
        found.update({name: names_of(ros_node, name, namespace) for name in node_names})
        return all(len(kinds["publishes"]) > 2 and kinds["serves"] for kinds in found.values())

    spin_until(ros_node, complete, 120.0, f"the endpoints of the nodes in {namespace}", [cell])
    return found


def test_a_namespaced_simulated_cell_has_every_node_and_name_under_its_namespace(ros_node, launch):
    namespace = "/cell_a"
    node_names = {NODE_NAMES[executable] for _, executable in CELLS["sim"]}
    # what discovery lists at the root before the cell starts is an earlier test's, not this cell's
    earlier = node_names & nodes_in(ros_node, "/")
    cell = start_cell(launch, "--namespace", namespace)
    wait_for_nodes(ros_node, namespace, node_names, cell)
    # none of them at the root
    spin_until(ros_node, lambda: not (node_names & nodes_in(ros_node, "/")) - earlier, 60.0,
               f"no node of the cell at the root (listed there before it started: {sorted(earlier)})",
               [cell])
    found = wait_for_endpoints(ros_node, namespace, node_names, cell)
    stray = {node: outside(namespace, kinds) for node, kinds in found.items()}
    assert {node: names_outside for node, names_outside in stray.items() if names_outside} == {}

    every = set().union(*(kinds["publishes"] | kinds["subscribes"] | kinds["serves"]
                          for kinds in found.values()))
    for name in (names.HEIGHTMAP_TOPIC, names.COLOR_TOPIC, names.PRIMITIVE_TOPIC, names.JOINT_STATES_TOPIC,
                 names.MARKERS_TOPIC, names.ROBOT_DESCRIPTION_TOPIC):
        assert names.absolute(name, namespace) in every, name
    assert names.TF_TOPIC in every  # TF stays global

    # the pieces find each other in the namespace: the simulated camera feeds the heightmap node ...
    heightmaps = TopicRecorder(ros_node, Heightmap, names.absolute(names.HEIGHTMAP_TOPIC, namespace),
                               QoSProfile(depth=5, reliability=ReliabilityPolicy.RELIABLE))
    try:
        heightmaps.wait_for(1, timeout=120.0, processes=[cell])
    finally:
        heightmaps.destroy()
    # ... and the episode node, found under the namespace, sees the simulated driver there
    status = call_service(ros_node, Trigger, names.absolute(names.EPISODE_STATUS_SERVICE, namespace),
                          Trigger.Request(), timeout=60.0, processes=[cell])
    assert status.success, status.message
    # the operator's command line reaches it by the namespace
    stop = episode_client("--namespace", namespace, "--stop")
    assert (stop.returncode, stop.stdout.strip()) == (1, "episode_client: no episode is running"), stop.stderr


def episode_client(*arguments) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "impurity_bringup.episode_client", *arguments],
                          capture_output=True, text=True, timeout=180)


@pytest.mark.parametrize("arguments", [(), ("--dry-run", "true", "--robot-ip", "192.0.2.1")],
                         ids=["real_cell_yaml", "dry_run_true"])
def test_the_real_cell_without_a_robot_runs_as_a_dry_run_under_its_namespace(ros_node, launch, arguments):
    namespace = "/cell_b"
    cell = start_cell(launch, "--cell", "real", "--namespace", namespace, "--only", "ur5_driver", *arguments)
    wait_for_nodes(ros_node, namespace, {"ur5_driver"}, cell)
    found = wait_for_endpoints(ros_node, namespace, {"ur5_driver"}, cell)
    assert outside(namespace, found["ur5_driver"]) == {}
    assert names.absolute(names.JOINT_STATES_TOPIC, namespace) in found["ur5_driver"]["publishes"]
    action = names.absolute(names.EXECUTE_PRIMITIVE_ACTION, namespace)
    client = ActionClient(ros_node, ExecutePrimitive, action)
    try:
        spin_until(ros_node, client.server_is_ready, 60.0, "the dry-run driver's action server", [cell])
    finally:
        client.destroy()
    assert cell.alive  # no robot at the address: a dry run contacts none
