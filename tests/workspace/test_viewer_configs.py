"""The shipped viewer configurations, bringup/config/cell.rviz (rviz2, started by cell.launch.py rviz:=true)
and bringup/config/cell.foxglove.json (a Foxglove layout to import): they show the cell's own names in
base_link. RViz's topics are relative, as impurity_common.names spells them, so an rviz2 started in a
cell's namespace shows that cell; a Foxglove layout holds absolute names, the cell's at the root. Neither
viewer runs here: these check the files, not a drawing."""

import json
import pathlib

import yaml

from impurity_common import names

CONFIG = pathlib.Path(__file__).resolve().parents[2] / "bringup" / "config"
CELL_NAMES = {value for key, value in vars(names).items() if key.isupper() and isinstance(value, str)}


def rviz_displays() -> list[dict]:
    return yaml.safe_load((CONFIG / "cell.rviz").read_text())["Visualization Manager"]["Displays"]


def rviz_topics() -> dict[str, str]:
    """{display name: its topic}."""
    found = {}
    for display in rviz_displays():
        for key in ("Topic", "Description Topic"):
            if isinstance(display.get(key), dict):
                found[display["Name"]] = display[key]["Value"]
    return found


def foxglove_topics(value) -> list[str]:
    """Every topic a layout names: panel topic keys and the values of imageTopic, topic and topicPath."""
    found = []
    if isinstance(value, dict):
        for key, item in value.items():
            if key in ("imageTopic", "topic", "topicPath") and isinstance(item, str):
                found.append(item)
            elif key == "topics" and isinstance(item, dict):
                found += list(item)
            else:
                found += foxglove_topics(item)
    elif isinstance(value, list):
        for item in value:
            found += foxglove_topics(item)
    return found


def test_rviz_shows_the_cell_in_base_link_with_tf_the_robot_model_and_the_decisions():
    config = yaml.safe_load((CONFIG / "cell.rviz").read_text())["Visualization Manager"]
    assert config["Global Options"]["Fixed Frame"] == names.BASE_FRAME
    classes = {display["Class"] for display in rviz_displays()}
    assert {"rviz_default_plugins/TF", "rviz_default_plugins/RobotModel",
            "rviz_default_plugins/MarkerArray", "rviz_default_plugins/Image"} <= classes
    assert set(rviz_topics().values()) >= {names.ROBOT_DESCRIPTION_TOPIC, names.MARKERS_TOPIC,
                                           names.COLOR_TOPIC, names.ATTENTION_DEBUG_TOPIC}


def test_rvizs_topics_are_the_cells_relative_names_so_they_follow_its_namespace():
    topics = rviz_topics()
    assert set(topics.values()) <= CELL_NAMES, topics
    assert not [topic for topic in topics.values() if topic.startswith("/")]


def test_the_latched_topics_are_asked_for_transient_local_as_they_are_published():
    durability = {display[key]["Value"]: display[key]["Durability Policy"] for display in rviz_displays()
                  for key in ("Topic", "Description Topic") if isinstance(display.get(key), dict)}
    assert durability[names.ROBOT_DESCRIPTION_TOPIC] == durability[names.MARKERS_TOPIC] == "Transient Local"


def test_the_foxglove_layout_shows_the_root_cells_names_in_base_link():
    layout = json.loads((CONFIG / "cell.foxglove.json").read_text())
    topics = foxglove_topics(layout["configById"])
    assert topics and set(topics) <= {names.absolute(name) for name in CELL_NAMES}, topics
    assert {names.absolute(names.ROBOT_DESCRIPTION_TOPIC), names.absolute(names.MARKERS_TOPIC),
            names.absolute(names.COLOR_TOPIC), names.absolute(names.EPISODE_STEPS_TOPIC)} <= set(topics)
    assert layout["configById"]["3D!cell"]["followTf"] == names.BASE_FRAME


def test_the_foxglove_layout_places_exactly_its_configured_panels():
    layout = json.loads((CONFIG / "cell.foxglove.json").read_text())

    def panels(node) -> list[str]:
        return [node] if isinstance(node, str) else panels(node["first"]) + panels(node["second"])

    assert sorted(panels(layout["layout"])) == sorted(layout["configById"])
