"""ur5_driver: the ExecutePrimitive action on a real UR5 through ur-rtde, with a Robotiq 2F-85.

    action  /ur5/execute_primitive  (impurity_interfaces/ExecutePrimitive)  the motion plan of
            ur5_motion.motion, the same the simulated arm executes (core/executor.py)
    topic   /joint_states           (sensor_msgs/JointState, UR joint names, measured)
    topic   /diagnostics            (diagnostic_msgs/DiagnosticArray: lifecycle state, robot mode, safety
                                     mode, gripper state)

A lifecycle node (rclpy.lifecycle; the launchers configure and activate it): configure connects to the
controller and the gripper, or fails (FAILURE, the reason in the log and on /diagnostics, the node stays
unconfigured and configure can be tried again); activate lets goals in; deactivate refuses them again and
cancels a running primitive; cleanup and shutdown stop the arm and disconnect. Joint states are published
while connected (inactive or active); goals are refused unless active.

dry_run (the default): no robot is contacted; a recording stand-in for ur-rtde and the gripper logs every
command the driver would send (to the ROS log and, with dry_run_log, a JSONL file) and simulates success.
A goal outside the workspace or the arm's reach, in another frame, or arriving while another runs, while
the controller is unreachable or while it is not in normal operation (a protective or emergency stop,
the robot not running: core/arm.py, UrArm.unavailable, naming the safety and robot modes) is rejected
(the reason is logged) and nothing moves. A connection lost mid-motion aborts the goal with a message
starting "driver_lost:" after telling the arm to stop; a protective stop mid-motion aborts it with
"motion failed: protective stop during <move> (safety mode 3 PROTECTIVE_STOP, ...)".

configure also reads the controller's PolyScope version (the dashboard server; the dry run's stand-in
reports an e-Series one) and logs it and puts it on /diagnostics: below 5.4 (a CB3) the controller has no
contact detection, and unless force_threshold_check is true every goal (each has a guarded descent) is
refused, the reason naming the version and force_threshold_check (core/arm.py, contact_sensing_problem).
"""

from __future__ import annotations

from dataclasses import dataclass

from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from rclpy.lifecycle import LifecycleNode, LifecycleState, TransitionCallbackReturn
from sensor_msgs.msg import JointState

from impurity_common import cell, names
from impurity_common.diagnostics import ERROR, OK, WARN, Diagnostics, Status
from impurity_common.enums import PrimitiveKind
from impurity_common.node_main import spin_node
from impurity_common.parameters import declare_parameters, param
from impurity_interfaces.action import ExecutePrimitive
from ur5_driver_rtde.core.arm import ROBOT_MODES, SAFETY_MODES, DriverLost, UrArm
from ur5_driver_rtde.core.executor import BIN_POSITION, PlanExecutor
from ur5_driver_rtde.core.gripper import URCAP_PORT, GripperError, Robotiq2F85
from ur5_driver_rtde.core.recording import CommandLog, DryRunGripper, DryRunRobot
from ur5_motion import motion, ur5_kinematics

GRIPPERS = ("robotiq_2f85", "dry_run")
# the lifecycle states (lifecycle_msgs/State labels)
UNCONFIGURED, INACTIVE, ACTIVE, FINALIZED = "unconfigured", "inactive", "active", "finalized"


@dataclass(frozen=True)
class Ur5DriverParameters:
    """Every parameter of the node (bringup/config/real_cell.yaml, section ur5_driver)."""

    robot_ip: str = param("192.168.1.10", "Address of the UR controller (ur-rtde and the gripper's URCap)")
    dry_run: bool = param(True, "Record the commands instead of sending them: no robot is contacted")
    dry_run_log: str = param("", "JSONL file the dry run appends every command to ('' = the ROS log only)")
    dry_run_held_width: float = param(0.03, "Dry run: opening (m) the gripper reports after closing; "
                                      "0 = closed on nothing", low=0.0, high=0.085)
    dry_run_drop_after: int = param(-1, "Dry run: the connection drops at motion command n + 1 "
                                    "(-1 = never; for tests of the driver_lost path)", low=-1)
    dry_run_contact_height: float = param(-1.0, "Dry run: TCP height (m, base_link) where guarded descents "
                                          "meet an object (-1 = they never do)", low=-1.0, high=1.0)
    gripper: str = param("robotiq_2f85", "Gripper driver: robotiq_2f85 (URCap socket) or dry_run (record "
                         "only, e.g. a first run of the arm without the gripper)", choices=GRIPPERS)
    gripper_port: int = param(URCAP_PORT, "TCP port of the Robotiq URCap's socket", low=1, high=65535)
    rtde_frequency: float = param(125.0, "RTDE frequency (Hz): 125 for a CB3 UR5, up to 500 on e-Series",
                                  low=1.0, high=500.0)
    flange_to_tcp: float = param(cell.FLANGE_TO_TCP, "The mounted gripper's TCP (between the fingertips) "
                                 "from the flange along tool0 z (m); the simulator's RG2-like default",
                                 low=0.0, high=0.5)
    speed_scale: float = param(1.0, "Plan speeds times this (e.g. 0.25 for a first run)", low=0.05, high=1.0)
    joint_speed: float = param(1.05, "Joint speed of the move home (rad/s)", low=0.1, high=3.0)
    force_threshold_check: bool = param(False, "Guarded descents also stop when the measured TCP force along "
                                        "+z exceeds the plan's threshold (besides the controller's contact "
                                        "detection, which needs PolyScope 5.4+: on a CB3 the only contact "
                                        "sensing, and goals are refused without it); the UR5's force "
                                        "estimate is noisy without an F/T sensor")
    bin_position: tuple[float, ...] = param(BIN_POSITION, "TCP position in base_link (m) where a held object "
                                            "is released after a grasp; within the UR5's reach",
                                            length=3, low=-2.0, high=2.0, check=motion.reach_problem)
    joint_state_rate: float = param(50.0, f"{names.JOINT_STATES_TOPIC} messages per second",
                                    low=0.1, high=500.0)


class ConnectionFailed(RuntimeError):
    """The controller or the gripper could not be reached; str() says which, why, and the parameter."""


def _rtde_interfaces(robot_ip: str, frequency: float):
    """(control, receive, polyscope): ur-rtde's interfaces to the controller at robot_ip (RuntimeError when
    it does not answer), and the PolyScope version its dashboard server reports (None when that cannot be
    read)."""
    import rtde_control  # ur-rtde (requirements.txt); only a real cell needs it
    import rtde_receive

    control = rtde_control.RTDEControlInterface(robot_ip, frequency)
    try:
        receive = rtde_receive.RTDEReceiveInterface(robot_ip, frequency)
    except RuntimeError:
        control.disconnect()
        raise
    return control, receive, _polyscope(robot_ip)


def _polyscope(robot_ip: str) -> str | None:
    """The controller's PolyScope version from its dashboard server (port 29999), or None."""
    import dashboard_client  # ur-rtde

    dashboard = dashboard_client.DashboardClient(robot_ip)
    try:
        dashboard.connect()
        return dashboard.polyscopeVersion()
    except RuntimeError:
        return None
    finally:
        try:
            dashboard.disconnect()
        except RuntimeError:
            pass


class Ur5DriverNode(LifecycleNode):
    """The driver as a lifecycle node: configure connects (ur-rtde and the gripper, or the dry run's
    stand-ins), activate lets goals in, deactivate refuses them again (and cancels a running one),
    cleanup and shutdown disconnect. `rtde_interfaces(robot_ip, frequency) -> (control, receive,
    polyscope)` and
    `gripper_factory(host, port)` are ur-rtde's and Robotiq2F85 unless a test passes stand-ins;
    `node_options` go to rclpy's Node (context, parameter_overrides)."""

    def __init__(self, rtde_interfaces=_rtde_interfaces, gripper_factory=Robotiq2F85, **node_options):
        super().__init__("ur5_driver", **node_options)
        params = self.params = declare_parameters(self, Ur5DriverParameters)
        self._rtde_interfaces, self._gripper_factory = rtde_interfaces, gripper_factory
        self._log = CommandLog(params.dry_run_log or None,
                               echo=self.get_logger().info if params.dry_run else None)
        self._arm: UrArm | None = None
        self._gripper = None
        self._executor: PlanExecutor | None = None
        self.state = UNCONFIGURED  # the lifecycle state this node is in
        self.failure: str | None = None  # why the last transition failed (the log and /diagnostics say it)
        self._claim = motion.ArmClaim()  # one primitive at a time
        self._goals = 0
        self._lost_reported = False

        self._joint_pub = self.create_publisher(JointState, names.JOINT_STATES_TOPIC, 10)
        self.create_timer(1.0 / params.joint_state_rate, self._publish_joints,
                          callback_group=MutuallyExclusiveCallbackGroup())
        self._action = ActionServer(
            self, ExecutePrimitive, names.EXECUTE_PRIMITIVE_ACTION, execute_callback=self._execute,
            goal_callback=self._on_goal, cancel_callback=lambda _goal: CancelResponse.ACCEPT,
            callback_group=ReentrantCallbackGroup())
        self.diagnostics = Diagnostics(self, self._status, hardware_id="dry_run" if params.dry_run
                                       else params.robot_ip, callback_group=MutuallyExclusiveCallbackGroup())
        target = "the dry run's stand-ins" if params.dry_run else f"the UR5 at {params.robot_ip}"
        self.get_logger().info(f"unconfigured: configure connects to {target}, activate accepts goals "
                               "(docs/real_cell.md, \"Lifecycle and diagnostics\")")

    # ------------------------------------------------------------------------------------ lifecycle
    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Connect to the arm and the gripper; FAILURE, with the reason logged and on /diagnostics, when
        either cannot be reached (the node stays unconfigured; configure may be tried again)."""
        try:
            self._connect(self.params)
        except ConnectionFailed as error:
            return self._failed("configure", str(error))
        self.failure = None
        self.state = INACTIVE
        params = self.params
        mode = "DRY RUN (nothing is sent to a robot)" if params.dry_run else f"UR5 at {params.robot_ip}"
        logged = params.dry_run and params.dry_run_log
        where = f", commands appended to {params.dry_run_log}" if logged else ""
        gripper = params.gripper if not params.dry_run else "dry run"
        self.get_logger().info(f"configured: {mode}, PolyScope {self._arm.polyscope or 'unknown'}, gripper "
                               f"{gripper}, speed scale {params.speed_scale:g}{where}; goals refused until "
                               "activated")
        problem = self._arm.contact_sensing_problem()
        if problem is not None:
            self.get_logger().error(problem)
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        if not self._arm.connected():
            return self._failed("activate", "the UR controller does not answer")
        self.state = ACTIVE
        self.get_logger().info("active: accepting goals")
        return super().on_activate(state)

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self.state = INACTIVE  # a running primitive sees it as a cancel
        self.get_logger().info("inactive: goals refused until activated")
        return super().on_deactivate(state)

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._disconnect()
        self.state = UNCONFIGURED
        self.get_logger().info("unconfigured: disconnected")
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._disconnect()
        self.state = FINALIZED
        return TransitionCallbackReturn.SUCCESS

    def on_error(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._disconnect()
        self.state = UNCONFIGURED
        return TransitionCallbackReturn.SUCCESS

    def _failed(self, transition: str, reason: str) -> TransitionCallbackReturn:
        self.failure = f"{transition} failed: {reason}"
        self.get_logger().error(self.failure)
        return TransitionCallbackReturn.FAILURE

    def _connect(self, params: Ur5DriverParameters) -> None:
        """Recording stand-ins in a dry run, else ur-rtde and the gripper; the TCP offset zeroed.
        ConnectionFailed names what could not be reached and the parameter to check; nothing stays
        connected then."""
        if params.dry_run:
            robot = DryRunRobot(self._log, drop_after=None if params.dry_run_drop_after < 0
                                else params.dry_run_drop_after, held_width=params.dry_run_held_width,
                                contact_height=None if params.dry_run_contact_height < 0
                                else params.dry_run_contact_height, flange_to_tcp=params.flange_to_tcp)
            control, receive, gripper = robot.control, robot.receive, robot.gripper
            polyscope = robot.polyscope
        else:
            try:
                control, receive, polyscope = self._rtde_interfaces(params.robot_ip, params.rtde_frequency)
            except RuntimeError as error:
                raise ConnectionFailed(f"cannot connect to the UR controller at {params.robot_ip}: {error} "
                                       "(check robot_ip, and that the controller is on and in remote "
                                       "control)") from None
            if params.gripper == "dry_run":
                gripper = DryRunGripper(CommandLog(echo=self.get_logger().info))
            else:
                try:
                    gripper = self._gripper_factory(params.robot_ip, params.gripper_port)
                    gripper.activate()
                except GripperError as error:
                    if "gripper" in locals():
                        gripper.disconnect()
                    _close(control, receive)
                    raise ConnectionFailed(f"gripper: {error} (check gripper and gripper_port)") from None
        arm = UrArm(control, receive, joint_speed=params.joint_speed,
                    force_threshold_check=params.force_threshold_check, polyscope=polyscope,
                    flange_to_tcp=params.flange_to_tcp)
        try:
            arm.prepare()
        except DriverLost as error:
            gripper.disconnect()
            _close(control, receive)
            raise ConnectionFailed(f"the controller does not answer: {error} (check robot_ip)") from None
        self._arm, self._gripper = arm, gripper
        self._executor = PlanExecutor(arm, gripper, self._log, params.speed_scale, params.bin_position)

    def _disconnect(self) -> None:
        """Stop the arm and close the gripper's and the controller's connections (when connected)."""
        arm, gripper = self._arm, self._gripper
        self._arm = self._gripper = self._executor = None
        if arm is None:
            return
        arm.stop()
        for close in (gripper.disconnect, arm.control.disconnect, arm.receive.disconnect):
            try:
                close()
            except RuntimeError as error:
                self.get_logger().warning(f"disconnect: {error}")

    def destroy_node(self):
        self._log.echo = None  # rosout may already be gone; the JSONL file still gets every record
        self._disconnect()
        self._log.close()
        # rclpy's destroy_node leaves the action server and the lifecycle state machine's services behind
        # (still discoverable, never answering); both go first
        self._action.destroy()
        destroyed = super().destroy_node()
        self._state_machine.destroy_when_not_in_use()
        return destroyed

    # ------------------------------------------------------------------------------------ diagnostics
    def _status(self) -> Status:
        """Lifecycle state, robot and safety modes, the gripper's state: OK while active and able to move."""
        values = {"lifecycle state": self.state, "robot mode": "unknown (not connected)",
                  "safety mode": "unknown (not connected)", "PolyScope version": "unknown (not connected)",
                  "gripper": "dry_run" if self.params.dry_run else self.params.gripper,
                  "gripper state": "not connected", "goals": self._goals}
        arm, gripper = self._arm, self._gripper
        if arm is None:
            if self.failure is not None:
                return Status(ERROR, f"{self.state}: {self.failure}", values)
            return Status(WARN, f"{self.state}: not connected (configure and activate the driver)", values)
        problems = []
        values["PolyScope version"] = arm.polyscope or "unknown"
        try:
            safety, robot = arm.modes()
            values["safety mode"] = f"{safety} {SAFETY_MODES.get(safety, 'UNKNOWN')}"
            values["robot mode"] = f"{robot} {ROBOT_MODES.get(robot, 'UNKNOWN')}"
            problem = arm.unavailable()
            if problem is not None:
                problems.append(problem)
        except DriverLost as error:
            problems.append(f"driver_lost: {error}")
        try:
            holding, opening = gripper.holding(), gripper.width()
            values["gripper state"] = "holding an object" if holding else "empty"
            values["gripper opening (m)"] = float(opening)
        except GripperError as error:
            values["gripper state"] = f"cannot be read: {error}"
            problems.append(f"gripper: {error}")
        if problems:
            return Status(ERROR, f"{self.state}: " + "; ".join(problems), values)
        if self.state != ACTIVE:
            return Status(WARN, f"{self.state}: connected, goals refused until activated", values)
        return Status(OK, "active: accepting goals", values)

    # ------------------------------------------------------------------------------------ joint states
    def _publish_joints(self) -> None:
        """Measured joints, UR names; skipped (reported once) while the controller does not answer."""
        arm = self._arm
        if not self.context.ok() or arm is None:  # unconfigured: nothing to read
            return
        try:
            if not arm.connected():
                raise DriverLost("not connected")
            positions = arm.joint_positions()
        except DriverLost as error:
            if not self._lost_reported:
                self.get_logger().error(f"joint states stopped: {error}")
                self._lost_reported = True
            return
        self._lost_reported = False
        msg = JointState(name=list(ur5_kinematics.JOINT_NAMES), position=positions)
        msg.header.stamp = self.get_clock().now().to_msg()
        self._joint_pub.publish(msg)

    # ------------------------------------------------------------------------------------ action
    def _on_goal(self, goal: ExecutePrimitive.Goal) -> GoalResponse:
        """Accept one valid primitive at a time while active; reject anything else with its reason in
        the log."""
        primitive = goal.primitive
        p = primitive.position
        reason = self._claim.refuse_or_claim(primitive.kind, p.x, p.y, p.z, primitive.yaw,
                                             primitive.header.frame_id, self.unavailable)
        if reason is not None:
            self.get_logger().warning(f"goal rejected: {reason}")
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def unavailable(self) -> str | None:
        """Why no goal can start now: the driver is not active, or the arm cannot move (UrArm.unavailable)."""
        arm = self._arm
        if self.state != ACTIVE or arm is None:
            return (f"the driver is {self.state}, not active: goals are accepted once it is configured and "
                    "activated (docs/real_cell.md, \"Lifecycle and diagnostics\")")
        return arm.unavailable()

    def _execute(self, goal_handle) -> ExecutePrimitive.Result:
        """Run the primitive's plan; the result holds what the arm and gripper report."""
        primitive = goal_handle.request.primitive
        kind = PrimitiveKind(primitive.kind).label
        p = primitive.position
        feedback = ExecutePrimitive.Feedback()

        def phase(name: str, progress: float) -> None:
            feedback.phase, feedback.progress = name, float(progress)
            if self.context.ok():
                goal_handle.publish_feedback(feedback)

        executor = self._executor
        try:
            if executor is None:  # cleaned up between the goal's acceptance and its start
                goal_handle.abort()
                return ExecutePrimitive.Result(success=False,
                                               message=f"driver_lost: the driver is {self.state}")
            self._goals += 1
            plan = motion.plan_primitive(kind, p.x, p.y, p.z, float(primitive.yaw))
            # deactivating the driver stops a running primitive as a cancel does
            outcome = executor.execute(plan, self._goals, phase,
                                        lambda: goal_handle.is_cancel_requested or self.state != ACTIVE)
        finally:
            self._claim.release()
        result = ExecutePrimitive.Result(
            success=outcome.success, motion_completed=outcome.motion_completed,
            gripper_opening=float(outcome.gripper_opening), holding=outcome.holding, target_grasped=False,
            grasped_object_id=-1, message=outcome.message, finished=self.get_clock().now().to_msg())
        if goal_handle.is_cancel_requested and not outcome.motion_completed:
            goal_handle.canceled()
        elif outcome.motion_completed:
            goal_handle.succeed()
        else:
            goal_handle.abort()
        text = f"{kind} at ({p.x:.3f}, {p.y:.3f}, {p.z:.3f}) yaw {primitive.yaw:.2f}: {outcome.message}"
        if outcome.motion_completed:  # one call site per severity: rclpy refuses a severity change
            self.get_logger().info(text)
        else:
            self.get_logger().error(text)
        return result


def _close(control, receive) -> None:
    for close in (control.disconnect, receive.disconnect):
        try:
            close()
        except RuntimeError:
            pass


def main(args=None):
    spin_node(Ur5DriverNode, args=args, executor_factory=lambda: MultiThreadedExecutor(num_threads=4))


if __name__ == "__main__":
    main()
