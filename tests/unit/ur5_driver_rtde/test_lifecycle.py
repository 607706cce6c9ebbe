"""Specification of the driver's lifecycle against the fakes of its protocols: ur-rtde's interfaces (the
dry run's recording stand-ins) and the Robotiq URCap's socket server (test_robotiq.FakeUrcap).

configure connects (a connection that fails is FAILURE with the reason, nothing left connected, and
configure can be tried again); goals are refused until activate; deactivate refuses them again; cleanup
and shutdown stop the arm and disconnect. /diagnostics says the state, the robot and safety modes and the
gripper's state."""

import socket

import pytest
from rclpy.lifecycle import TransitionCallbackReturn
from rclpy.parameter import Parameter
from test_robotiq import FakeUrcap

from impurity_common.diagnostics import ERROR, OK, WARN
from ur5_driver_rtde.core.gripper import Robotiq2F85
from ur5_driver_rtde.core.recording import DRY_RUN_POLYSCOPE, CommandLog, DryRunRobot
from ur5_driver_rtde.ur5_driver_node import Ur5DriverNode

SUCCESS, FAILURE = TransitionCallbackReturn.SUCCESS, TransitionCallbackReturn.FAILURE
ROBOT_IP = "10.0.0.2"


class Controller:
    """The UR controller as ur-rtde's interfaces see it: the dry run's stand-ins and the PolyScope version
    its dashboard server reports (`polyscope`, None: it could not be read), or a refusal to connect as
    RTDEControlInterface raises it."""

    def __init__(self, refuse: str | None = None, polyscope: str | None = DRY_RUN_POLYSCOPE):
        self.log = CommandLog()
        self.robot = DryRunRobot(self.log)
        self.refuse, self.polyscope = refuse, polyscope
        self.connections = 0

    def __call__(self, robot_ip, frequency):
        if self.refuse is not None:
            raise RuntimeError(self.refuse)
        self.connections += 1
        return self.robot.control, self.robot.receive, self.polyscope

    def commands(self):
        return [record["command"] for record in self.log.records]


@pytest.fixture
def driver(rcl_context):
    """A driver node built with `parameters` over its defaults and the given controller and gripper;
    destroyed at teardown."""
    made = []

    def make(controller=None, gripper_factory=Robotiq2F85, **parameters):
        node = Ur5DriverNode(rtde_interfaces=controller or Controller(), gripper_factory=gripper_factory,
                             context=rcl_context,
                             parameter_overrides=[Parameter(k, value=v) for k, v in parameters.items()])
        made.append(node)
        return node

    yield make
    for node in made:
        node.destroy_node()


@pytest.fixture
def urcap():
    fake = FakeUrcap()
    yield fake
    fake.close()


def quick_robotiq(host, port):
    return Robotiq2F85(host, port, timeout=0.5, sleep=lambda s: None)


def test_goals_are_refused_until_the_driver_is_configured_and_activated(driver):
    node = driver(dry_run=True)
    assert node.state == "unconfigured" and "not active" in node.unavailable()
    assert node.trigger_configure() == SUCCESS and node.state == "inactive"
    assert "the driver is inactive, not active" in node.unavailable()
    assert node.trigger_activate() == SUCCESS and node.state == "active"
    assert node.unavailable() is None
    assert node.trigger_deactivate() == SUCCESS
    assert "the driver is inactive, not active" in node.unavailable()


def test_a_controller_that_refuses_the_connection_fails_configure_with_the_reason(driver):
    controller = Controller(refuse="Connection refused")
    node = driver(controller, dry_run=False, robot_ip=ROBOT_IP, gripper="dry_run")
    assert node.trigger_configure() == FAILURE
    assert node.state == "unconfigured"
    assert node.failure.startswith(f"configure failed: cannot connect to the UR controller at {ROBOT_IP}: "
                                   "Connection refused (check robot_ip")
    status = node.diagnostics.current()
    assert status.level == ERROR and node.failure in status.message
    assert status.values["robot mode"] == "unknown (not connected)"
    # The controller comes up: configure is tried again and succeeds.
    controller.refuse = None
    assert node.trigger_configure() == SUCCESS and node.failure is None and node.state == "inactive"


def test_an_unreachable_gripper_fails_configure_and_leaves_the_controller_disconnected(driver):
    with socket.socket() as held:  # bound, never listening: connections refused, no other test can take it
        held.bind(("127.0.0.1", 0))
        port = held.getsockname()[1]
        controller = Controller()
        node = driver(controller, quick_robotiq, dry_run=False, robot_ip="127.0.0.1", gripper_port=port)
        assert node.trigger_configure() == FAILURE
    assert node.failure.startswith(f"configure failed: gripper: cannot reach the Robotiq URCap at "
                                   f"127.0.0.1:{port}")
    assert controller.connections == 1 and controller.commands() == ["disconnect"]
    assert node.diagnostics.current().level == ERROR


def test_configure_activates_the_gripper_and_cleanup_closes_both_connections(driver, urcap):
    controller = Controller()
    node = driver(controller, quick_robotiq, dry_run=False, robot_ip="127.0.0.1", gripper_port=urcap.port)
    assert node.trigger_configure() == SUCCESS
    assert "SET ACT 1" in urcap.lines and urcap.values["STA"] == 3
    assert controller.commands() == ["setTcp"]  # the TCP offset zeroed, nothing moved
    assert node.trigger_cleanup() == SUCCESS and node.state == "unconfigured"
    assert controller.commands()[-2:] == ["stopL", "disconnect"]
    urcap.thread.join(5.0)
    assert not urcap.thread.is_alive()  # the URCap's server saw its client close the socket


def test_shutdown_of_an_active_driver_stops_the_arm_and_disconnects(driver):
    controller = Controller()
    node = driver(controller, dry_run=False, robot_ip=ROBOT_IP, gripper="dry_run")
    assert node.trigger_configure() == SUCCESS and node.trigger_activate() == SUCCESS
    assert node.trigger_shutdown() == SUCCESS and node.state == "finalized"
    assert controller.commands()[-2:] == ["stopL", "disconnect"]
    assert "finalized" in node.unavailable()


def test_diagnostics_name_the_lifecycle_state_robot_mode_safety_mode_and_gripper_state(driver):
    controller = Controller()
    node = driver(controller, dry_run=False, robot_ip=ROBOT_IP, gripper="dry_run")
    status = node.diagnostics.current()
    assert status.level == WARN and status.message.startswith("unconfigured: not connected")
    node.trigger_configure()
    assert node.diagnostics.current().level == WARN  # connected, not yet accepting goals
    node.trigger_activate()
    status = node.diagnostics.current()
    assert (status.level, status.message) == (OK, "active: accepting goals")
    assert status.values["lifecycle state"] == "active"
    assert status.values["robot mode"] == "7 RUNNING" and status.values["safety mode"] == "1 NORMAL"
    assert status.values["gripper"] == "dry_run" and status.values["gripper state"] == "empty"
    controller.robot.state.safety_mode = 3
    status = node.diagnostics.current()
    assert status.level == ERROR and "protective stop" in status.message
    assert status.values["safety mode"] == "3 PROTECTIVE_STOP"


# ------------------------------------------------------------------------------------ contact sensing
CB3_POLYSCOPE = "3.15.7.106331"  # a CB3 controller: no tool_contact, so no contact detection


def test_on_a_cb3_goals_are_refused_without_force_threshold_check_naming_it_and_the_version(driver):
    node = driver(Controller(polyscope=CB3_POLYSCOPE), dry_run=False, robot_ip=ROBOT_IP, gripper="dry_run")
    assert node.trigger_configure() == SUCCESS and node.trigger_activate() == SUCCESS
    reason = node.unavailable()
    assert reason.startswith("guarded descents refused") and "PolyScope 3.15.7" in reason
    assert "force_threshold_check" in reason
    status = node.diagnostics.current()
    assert status.level == ERROR and "force_threshold_check" in status.message
    assert status.values["PolyScope version"] == CB3_POLYSCOPE


def test_on_a_cb3_with_force_threshold_check_goals_are_accepted(driver):
    node = driver(Controller(polyscope=CB3_POLYSCOPE), dry_run=False, robot_ip=ROBOT_IP, gripper="dry_run",
                  force_threshold_check=True)
    assert node.trigger_configure() == SUCCESS and node.trigger_activate() == SUCCESS
    assert node.unavailable() is None
    assert node.diagnostics.current().level == OK


def test_a_controller_whose_version_cannot_be_read_counts_as_one_without_contact_detection(driver):
    node = driver(Controller(polyscope=None), dry_run=False, robot_ip=ROBOT_IP, gripper="dry_run")
    assert node.trigger_configure() == SUCCESS and node.trigger_activate() == SUCCESS
    assert "PolyScope version is unknown" in node.unavailable()
    assert node.diagnostics.current().values["PolyScope version"] == "unknown"


def test_an_e_series_controller_and_the_dry_run_report_their_version_and_accept_goals(driver):
    for node in (driver(Controller(polyscope="5.11.1.108318"), dry_run=False, robot_ip=ROBOT_IP,
                        gripper="dry_run"), driver(dry_run=True)):
        assert node.trigger_configure() == SUCCESS and node.trigger_activate() == SUCCESS
        assert node.unavailable() is None
    assert node.diagnostics.current().values["PolyScope version"] == DRY_RUN_POLYSCOPE
