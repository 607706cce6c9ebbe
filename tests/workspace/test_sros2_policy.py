"""bringup/config/sros2/policy.xml, the cell's SROS2 access-control policy: in the form sros2's
`generate_artifacts -p` / `create_permission` reads, one enclave per process, each granted exactly the topics,
services and actions its node's code creates (read from the node modules as scripts/node_reference.py reads
them) plus what rclpy creates for any node; only the episode node may send the arm goals and only the arm
drivers publish /joint_states. The policy is checked against the code only: nothing here runs with DDS
security (the PyPI Fast DDS is built without it)."""

import dataclasses
import importlib.util
import pathlib
import xml.etree.ElementTree as ET

import pytest
from launch_stubs import launched_nodes

from impurity_bringup.cell_nodes import CELLS, SECURITY_POLICY_NAME, config_dir, enclave
from impurity_common import names

ROOT = pathlib.Path(__file__).resolve().parents[2]
POLICY = ROOT / "bringup" / "config" / SECURITY_POLICY_NAME
LAUNCH_FILE = ROOT / "bringup" / "launch" / "cell.launch.py"

_spec = importlib.util.spec_from_file_location("node_reference", ROOT / "scripts" / "node_reference.py")
node_reference = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(node_reference)

CELL_EXECUTABLES = sorted({executable for nodes in CELLS.values() for _, executable in nodes})
EPISODE_CLIENT = "impurity_bringup.episode_client"  # the operator's command line; a client, not a node module
# executable -> the modules whose code creates its ROS names (node_reference.NODES: the node module and the
# modules it owns the interfaces of)
MODULES = {executable: (node_reference.NODES[executable][1], *node_reference.NODES[executable][2])
           for executable in (*CELL_EXECUTABLES, "bag_recorder")}
MODULES["episode_client"] = (EPISODE_CLIENT,)
DRIVERS = ("sim_cell", "ur5_driver")

# node_reference.interfaces' roles -> the sros2 permission that grants them
PERMISSION_OF_ROLE = {"publishes": "publish", "subscribes": "subscribe", "serves": "reply",
                      "calls": "request", "action server": "execute", "action client": "call"}
# sros2 policy element -> its item element and the permissions it may carry (sros2's policy.xsd)
ITEMS = {"topics": ("topic", {"publish", "subscribe"}), "services": ("service", {"reply", "request"}),
         "actions": ("action", {"call", "execute"})}
# What rclpy creates for every node, granted to every enclave as sros2's own common/node policies grant it:
# logging, parameter events, the clock, the parameter services (and Jazzy's type-description service).
NODE_SERVICES = ("describe_parameters", "get_parameter_types", "get_parameters", "get_type_description",
                 "list_parameters", "set_parameters", "set_parameters_atomically")
ROS_NODE_GRANTS = {("publish", "/rosout"), ("publish", "/parameter_events"),
                   ("subscribe", "/parameter_events"), ("subscribe", "/clock")} | {
                      (permission, f"~/{service}") for service in NODE_SERVICES
                      for permission in ("reply", "request")}


def parsed(path: pathlib.Path = POLICY) -> ET.Element:
    """The policy's root element, comments kept (sros2 takes every child of <enclaves> for an enclave)."""
    return ET.parse(path, parser=ET.XMLParser(target=ET.TreeBuilder(insert_comments=True))).getroot()


def profiles() -> dict[str, ET.Element]:
    """{enclave path: its (only) profile element}."""
    return {element.get("path"): element.find("profiles/profile") for element in parsed().find("enclaves")}


def grants(profile: ET.Element) -> set[tuple[str, str]]:
    """{(permission, name)} a profile ALLOWs: ("publish", "/heightmap"), ("call", "/ur5/execute_primitive"),
    ..."""
    found = set()
    for element in profile:
        item, permissions = ITEMS[element.tag]
        for permission in permissions:
            if element.get(permission) == "ALLOW":
                found |= {(permission, child.text) for child in element.iter(item)}
    return found


def all_grants() -> dict[str, set[tuple[str, str]]]:
    return {path: grants(profile) for path, profile in profiles().items()}


def module_source(module: str) -> str:
    return pathlib.Path(importlib.util.find_spec(module).origin).read_text()


def imported_names(module: str) -> list[str]:
    """The impurity_common.names constants `module` imports by name (from impurity_common.names import X)."""
    import ast

    return [alias.name for node in ast.walk(ast.parse(module_source(module)))
            if isinstance(node, ast.ImportFrom) and node.module == "impurity_common.names"
            for alias in node.names]


def node_name(module: str) -> str:
    """The ROS node name `module` creates: the string its Node subclass passes to `super().__init__`, or its
    `rclpy.create_node` call's."""
    import ast

    found = {node.args[0].value for node in ast.walk(ast.parse(module_source(module)))
             if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.args
             and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)
             and (node.func.attr == "create_node" or (node.func.attr == "__init__" and isinstance(
                 node.func.value, ast.Call) and getattr(node.func.value.func, "id", None) == "super"))}
    if len(found) != 1:
        raise LookupError(f"{module} creates {len(found)} named nodes, expected one: {sorted(found)}")
    return found.pop()


# What a lifecycle node (rclpy.lifecycle.LifecycleNode) creates besides: its lifecycle services and
# transition events (rcl_lifecycle).
LIFECYCLE_GRANTS = {("reply", f"~/{service}") for service in (
    "change_state", "get_available_states", "get_available_transitions", "get_state",
    "get_transition_graph")} | {("publish", "~/transition_event")}


def code_grants(executable: str) -> set[tuple[str, str]]:
    """{(permission, name)} of what `executable`'s code creates under the names of impurity_common.names:
    its modules' publishers, subscriptions, service servers and clients, action servers and clients; the
    topics bag_recorder records by default (its `topics` parameter); the services episode_client calls and
    the action it sends goals to (the names it imports); /diagnostics for a node that reports its status
    (impurity_common.diagnostics.Diagnostics) and the lifecycle services of a LifecycleNode."""
    found = set()
    for module in MODULES[executable]:
        for role, ros_names in node_reference.interfaces(module).items():
            found |= {(PERMISSION_OF_ROLE[role], name) for name in ros_names}
        if "Diagnostics(self" in module_source(module):
            found.add(("publish", names.DIAGNOSTICS_TOPIC))
        if "(LifecycleNode)" in module_source(module):
            found |= LIFECYCLE_GRANTS
    if executable == "bag_recorder":
        parameters = node_reference.parameters_class(MODULES[executable][0])
        (topics,) = [field.default for field in dataclasses.fields(parameters) if field.name == "topics"]
        found |= {("subscribe", topic) for topic in topics}
    if executable == "episode_client":
        for constant in imported_names(EPISODE_CLIENT):
            permission = {"_SERVICE": "request", "_ACTION": "call"}.get(constant[constant.rfind("_"):])
            if permission:
                found.add((permission, getattr(names, constant)))
    return found


# ------------------------------------------------------------------------------------------ the file's form
def test_the_policy_is_sros2s_version_0_2_0_with_only_enclaves_under_enclaves():
    root = parsed()
    assert root.tag == "policy" and root.get("version") == "0.2.0"
    assert [child.tag for child in root] == ["enclaves"]
    assert {child.tag for child in root.find("enclaves")} == {"enclave"}  # no comment either


def test_every_enclave_has_one_profile_in_the_root_namespace():
    for element in parsed().find("enclaves"):
        assert [child.tag for child in element] == ["profiles"]
        assert [child.tag for child in element.find("profiles")] == ["profile"]
        assert element.find("profiles/profile").get("ns") == "/"


def test_profiles_hold_only_allowed_topics_services_and_actions_by_exact_name():
    for path, profile in profiles().items():
        for element in profile:
            item, permissions = ITEMS[element.tag]
            assert set(element.attrib) <= permissions and set(element.attrib.values()) == {"ALLOW"}, path
            assert {child.tag for child in element} == {item}, path
            # DDS permissions read names as fnmatch patterns: a wildcard would grant names of other nodes
            assert all(not set(child.text) & set("*?[]") for child in element), path


# ------------------------------------------------------------------------------------- against the code
def test_there_is_one_enclave_per_process_of_the_cell_the_recorder_and_the_episode_client():
    assert set(profiles()) == {enclave(executable) for executable in MODULES}


def test_each_profile_names_the_node_its_executable_creates():
    assert {path: profile.get("node") for path, profile in profiles().items()} == \
        {enclave(executable): node_name(modules[0]) for executable, modules in MODULES.items()}


def test_every_enclave_is_granted_what_rclpy_creates_for_any_node():
    assert all(ROS_NODE_GRANTS <= granted for granted in all_grants().values())


@pytest.mark.parametrize("executable", sorted(MODULES))
def test_an_enclave_is_granted_exactly_the_names_its_code_creates(executable):
    expected = code_grants(executable)
    assert expected, f"{executable}: nothing read from its code"
    assert all_grants()[enclave(executable)] - ROS_NODE_GRANTS == expected


def test_only_the_episode_node_may_send_the_arm_goals():
    goal = ("call", names.EXECUTE_PRIMITIVE_ACTION)
    assert {path for path, granted in all_grants().items() if goal in granted} == {enclave("episode_node")}


def test_only_the_arm_drivers_execute_arm_goals_and_publish_joint_states():
    drivers = {enclave(executable) for executable in DRIVERS}
    for grant in (("execute", names.EXECUTE_PRIMITIVE_ACTION), ("publish", names.JOINT_STATES_TOPIC)):
        assert {path for path, granted in all_grants().items() if grant in granted} == drivers


def test_only_the_simulator_serves_scene_resets_and_ground_truth():
    for service in (names.RESET_SCENE_SERVICE, names.GROUND_TRUTH_SERVICE):
        assert {path for path, g in all_grants().items() if ("reply", service) in g} == {enclave("sim_cell")}


# ---------------------------------------------------------------------------------- sros2 and the install
def test_the_policy_is_valid_for_sros2():
    """sros2's own reader: XInclude, then its policy.xsd (needs sros2 and lxml, i.e. a ROS install)."""
    pytest.importorskip("lxml", reason="lxml is not in the pip environment (sros2 validates with it)")
    policy = pytest.importorskip("sros2.policy", reason="sros2 is not in the pip environment (ROS installs)")
    assert policy.load_policy(POLICY).getroot().tag == "policy"


def test_the_policy_is_installed_in_impurity_bringups_share():
    assert (config_dir() / SECURITY_POLICY_NAME).read_bytes() == POLICY.read_bytes()


# ------------------------------------------------------------------------------------------- the launch file
@pytest.mark.parametrize("cell", sorted(CELLS))
def test_with_security_the_launch_runs_every_node_in_its_enclave_of_the_policy(monkeypatch, cell):
    nodes = launched_nodes(monkeypatch, LAUNCH_FILE,
                           {"cell": cell, "security": "true", "keystore": "/cell/keystore"})
    assert [node["ros_arguments"] for node in nodes] == \
        [["--enclave", enclave(executable)] for _, executable in CELLS[cell]]
    assert {node["ros_arguments"][1] for node in nodes} <= set(profiles())
    environment = {"ROS_SECURITY_KEYSTORE": "/cell/keystore", "ROS_SECURITY_ENABLE": "true",
                   "ROS_SECURITY_STRATEGY": "Enforce"}
    assert all(node["additional_env"] == environment for node in nodes)


def test_without_security_the_launch_adds_no_enclave_and_no_environment(monkeypatch):
    nodes = launched_nodes(monkeypatch, LAUNCH_FILE, {})
    assert all(node["ros_arguments"] is None and node["additional_env"] is None for node in nodes)


def test_security_without_a_keystore_is_refused(monkeypatch):
    with pytest.raises(ValueError, match="keystore"):
        launched_nodes(monkeypatch, LAUNCH_FILE, {"security": "true", "keystore": ""})


# ------------------------------------------------------------------------------------- a namespaced cell
GLOBAL_NAMES = {"/rosout", "/parameter_events", "/clock", "/tf", "/tf_static", "/diagnostics"}


def sros2_resolved(name: str, ns: str, node: str) -> str:
    """A policy name as sros2's permissions template resolves it in a profile: absolute as it is, `~/x` the
    node's own (ns/node/x), anything else under the profile's ns."""
    if name.startswith("/"):
        return name
    prefix = ns if ns.endswith("/") else ns + "/"
    return prefix + node + name[1:] if name.startswith("~") else prefix + name


def namespaced_profiles(namespace: str) -> dict[str, ET.Element]:
    """The profiles of the policy made for a cell in `namespace` as the policy's comment says: every
    profile's ns set to it."""
    text = POLICY.read_text().replace('ns="/"', f'ns="{namespace}"')
    root = ET.fromstring(text, parser=ET.XMLParser(target=ET.TreeBuilder(insert_comments=True)))
    return {element.get("path"): element.find("profiles/profile") for element in root.find("enclaves")}


@pytest.mark.parametrize("executable", sorted(MODULES))
def test_in_a_namespace_an_enclave_is_granted_its_codes_names_under_it_and_the_globals(executable):
    namespace = "/cell_a"
    profile = namespaced_profiles(namespace)[enclave(executable)]
    node = profile.get("node")
    granted = {(permission, sros2_resolved(name, profile.get("ns"), node))
               for permission, name in grants(profile)}
    code = {(permission, sros2_resolved(name, namespace, node) if name.startswith("~") else
             names.absolute(name, namespace)) for permission, name in code_grants(executable)}
    rclpy_own = {(permission, sros2_resolved(name, namespace, node)) for permission, name in ROS_NODE_GRANTS}
    assert granted == code | rclpy_own
    assert {name for _, name in granted if not name.startswith(namespace + "/")} <= GLOBAL_NAMES
