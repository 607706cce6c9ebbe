"""Every ROS name of the cell is spelled once (impurity_common.names), and the enums agree with the
message constants and the simulator (no ROS graph)."""

import ast
import pathlib

import pytest

from impurity_common import names
from impurity_common.enums import EPISODE_SCENARIOS, AttentionMode, PrimitiveKind, Scenario
from impurity_interfaces.msg import AttentionResult, Primitive

ROOT = pathlib.Path(__file__).resolve().parents[3]
NAMES_FILE = ROOT / "src" / "impurity_common" / "impurity_common" / "names.py"
FRAMES = {names.BASE_FRAME, names.CAMERA_OPTICAL_FRAME}
GRAPH_NAMES = {value for key, value in vars(names).items()
               if key.isupper() and isinstance(value, str) and value not in FRAMES}
# Sources allowed to spell a frame id (e.g. a robot model whose link name equals one): none today.
FRAME_EXCEPTIONS: set[str] = set()


def string_literals(path: pathlib.Path) -> set:
    return {node.value for node in ast.walk(ast.parse(path.read_text()))
            if isinstance(node, ast.Constant) and isinstance(node.value, str)}


def python_sources() -> list:
    return sorted(p for p in (ROOT / "src").rglob("*.py") if p != NAMES_FILE and "/test/" not in str(p))


def relative(path: pathlib.Path) -> str:
    return str(path.relative_to(ROOT))


# Names ROS and its tools expect at the root whatever a node's namespace (tf2 and rviz2, rclpy's own topics,
# the diagnostic aggregator)
ROS_GLOBALS = {"/tf", "/tf_static", "/clock", "/diagnostics", "/parameter_events", "/rosout"}


def test_the_cells_names_are_relative_and_only_the_ros_globals_absolute():
    """A node started in a namespace has every cell name under it; TF stays where ROS tools look."""
    assert {name for name in GRAPH_NAMES if name.startswith("/")} <= ROS_GLOBALS
    assert {names.TF_TOPIC, names.TF_STATIC_TOPIC} <= ROS_GLOBALS
    assert not any(frame.startswith("/") for frame in FRAMES)


def test_a_relative_name_resolves_under_the_namespace_and_a_global_one_stays():
    assert names.absolute(names.HEIGHTMAP_TOPIC) == "/heightmap"
    assert names.absolute(names.HEIGHTMAP_TOPIC, "/cell_a") == "/cell_a/heightmap"
    assert names.absolute(names.COLOR_TOPIC, "/cell_a/") == "/cell_a/camera/camera/color/image_raw"
    assert names.absolute(names.TF_TOPIC, "/cell_a") == "/tf"


def test_the_episode_topics_resolve_to_the_names_the_committed_bags_hold():
    """Bags hold absolute names: the cell at the root namespace records and replays them unchanged."""
    from impurity_bags.bags import BagReader

    for bag in ("episode_bag", "known_product_bag"):
        with BagReader(ROOT / "tests" / "data" / bag) as reader:
            recorded = set(reader.topics)
        assert recorded <= {names.absolute(topic) for topic in names.EPISODE_TOPICS}, bag


def test_no_two_constants_share_a_name():
    constants = [value for key, value in vars(names).items() if key.isupper() and isinstance(value, str)]
    assert len(constants) == len(set(constants))


# One-word names that are also other things' names: the heightmap node ("heightmap") and its marker namespace
OTHER_WORDS = {"heightmap"}


def test_no_source_outside_names_spells_a_topic_service_or_action():
    spelled = {relative(path): sorted(string_literals(path) & (GRAPH_NAMES - OTHER_WORDS))
               for path in python_sources()}
    assert {path: found for path, found in spelled.items() if found} == {}


def test_no_source_outside_names_spells_a_frame_id():
    spelled = {relative(path): sorted(string_literals(path) & FRAMES) for path in python_sources()
               if relative(path) not in FRAME_EXCEPTIONS}
    assert {path: found for path, found in spelled.items() if found} == {}


# ------------------------------------------------------------------------------------ enums
def test_attention_modes_equal_the_attention_result_constants():
    assert {mode.name: int(mode) for mode in AttentionMode} == {
        "NONE": AttentionResult.MODE_NONE, "TARGET": AttentionResult.MODE_TARGET,
        "OCCLUDED_REGION": AttentionResult.MODE_OCCLUDED_REGION}


def test_primitive_kinds_equal_the_primitive_constants():
    assert {kind.name: int(kind) for kind in PrimitiveKind} == {"PUSH": Primitive.PUSH,
                                                                "GRASP": Primitive.GRASP}


def test_scenarios_are_the_simulators():
    from ur5_driver_sim.core.scenes import SCENARIOS

    assert {scenario.value for scenario in Scenario} == set(SCENARIOS)


def test_episode_scenarios_are_the_ones_an_episode_accepts():
    from impurity_policy.core.episode import SCENARIOS

    assert {scenario.value for scenario in EPISODE_SCENARIOS} == set(SCENARIOS)


def test_parse_takes_a_name_in_any_case():
    assert PrimitiveKind.parse("grasp") is PrimitiveKind.GRASP
    assert AttentionMode.parse("Occluded_Region") is AttentionMode.OCCLUDED_REGION
    assert Scenario.parse("RANDOM") is Scenario.RANDOM


def test_parse_of_an_unknown_name_lists_the_known_ones():
    with pytest.raises(ValueError, match=r"unknown scenario 'tidy' \(expected one of random, challenging, "
                                         r"invisible, file, empty\)"):
        Scenario.parse("tidy")
    with pytest.raises(ValueError, match=r"unknown primitive kind 'poke' \(expected one of push, grasp\)"):
        PrimitiveKind.parse("poke")


def test_parse_can_narrow_the_members_accepted():
    with pytest.raises(ValueError, match="expected one of random, challenging, invisible, file"):
        Scenario.parse("empty", EPISODE_SCENARIOS)


def test_labels_are_the_lower_case_names_used_in_logs_and_records():
    assert PrimitiveKind.PUSH.label == "push"
    assert AttentionMode.OCCLUDED_REGION.label == "occluded_region"
    assert Scenario.CHALLENGING.label == "challenging" == f"{Scenario.CHALLENGING}"
