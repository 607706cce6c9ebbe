"""Every node of the cell reports on /diagnostics, in one graph: the simulated cell's nodes (sim_cell in its
floating-gripper mode, heightmap, attention, policy, episode, cell_state_publisher, decision_markers), the
UR5 driver in its dry run (configured and activated as the launchers do), and the bag nodes (a recorder
and a looping replay). Each status is named after its node and carries the named values; the driver's
says its lifecycle state, robot mode, safety mode and gripper state, the camera path's (heightmap) its
frame rate and pairs dropped, the policy's its decision latency. The values are measured by the nodes,
not judged here."""

from bag_helpers import write_sample_bag
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus

from impurity_bags.bags import cell_typestore
from impurity_common import names
from impurity_common.diagnostics import values_of
from ros_harness import ROOT, TopicRecorder, activate, ros_args, spin_until

CONFIG = ROOT / "bringup" / "config" / "cell.yaml"
# node name -> the values its status must carry
EXPECTED = {
    "sim_cell": {"frame rate (Hz)"},
    "ur5_driver": {"lifecycle state", "robot mode", "safety mode", "gripper state"},
    "heightmap": {"frame rate (Hz)", "pairs dropped"},
    "attention": {"attention rate (Hz)"},
    "policy": {"decision latency (s)", "mean decision latency (s)"},
    "episode": {"episode"},
    "cell_state_publisher": {"joint state rate (Hz)"},
    "decision_markers": {"marker arrays"},
    "bag_recorder": {"messages"},
    "bag_replay": {"messages"},
}


def test_every_node_of_the_cell_reports_its_status_on_diagnostics(ros_node, launch, tmp_path):
    write_sample_bag(tmp_path / "bag", cell_typestore(), count=4)
    cell = [("ur5_driver_sim", "sim_cell", {"mode": "floating"}),
            ("impurity_attention", "heightmap_node", {}), ("impurity_attention", "attention_node", {}),
            ("impurity_policy", "policy_node", {}),
            ("impurity_policy", "episode_node", {"record_dir": str(tmp_path / "records")}),
            ("impurity_viz", "cell_state_publisher", {}), ("impurity_viz", "decision_markers", {})]
    procs = [launch(package, executable, ros_args(overrides, params_file=CONFIG))
             for package, executable, overrides in cell]
    procs.append(launch("impurity_bags", "bag_recorder", ros_args(
        {"topics": ["/chatter"], "output": str(tmp_path / "recorded")})))
    procs.append(launch("impurity_bags", "bag_replay", ros_args(
        {"bag": str(tmp_path / "bag"), "loop": True, "topics": ["/chatter"]})))
    driver = launch("ur5_driver_rtde", "ur5_driver", ros_args({"dry_run": True}))
    procs.append(driver)
    activate(ros_node, "/ur5_driver", processes=[driver])

    diagnostics = TopicRecorder(ros_node, DiagnosticArray, names.DIAGNOSTICS_TOPIC, 50)
    latest: dict[str, DiagnosticStatus] = {}

    def all_reported() -> bool:
        for msg in diagnostics.messages:
            for status in msg.status:
                latest[status.name] = status
        diagnostics.messages.clear()
        return set(EXPECTED) <= set(latest) and latest["ur5_driver"].level == DiagnosticStatus.OK

    spin_until(ros_node, all_reported, 120.0, f"a status from each of {sorted(EXPECTED)} on /diagnostics",
               procs)
    for name, keys in EXPECTED.items():
        assert keys <= set(values_of(latest[name])), (name, values_of(latest[name]))
    driver_values = values_of(latest["ur5_driver"])
    assert latest["ur5_driver"].message == "active: accepting goals"
    assert (driver_values["lifecycle state"], driver_values["robot mode"], driver_values["safety mode"]) == (
        "active", "7 RUNNING", "1 NORMAL")
    assert driver_values["gripper state"] == "empty"
    diagnostics.destroy()
