"""ur5_driver: the ExecutePrimitive action on a real UR5 through ur-rtde, with a Robotiq 2F-85.

    action  /ur5/execute_primitive  (impurity_interfaces/ExecutePrimitive)  the motion plan of
            ur5_motion.motion, the same the simulated arm executes (core/executor.py)
    topic   /joint_states           (sensor_msgs/JointState, UR joint names, measured)

dry_run (the default): no robot is contacted; a recording stand-in for ur-rtde and the gripper logs every
command the driver would send (to the ROS log and, with dry_run_log, a JSONL file) and simulates success.
A goal outside the workspace or the arm's reach, in another frame, or arriving while another runs, while
the controller is unreachable or while it is not in normal operation (a protective or emergency stop,
the robot not running: core/arm.py, UrArm.unavailable, naming the safety and robot modes) is rejected
(the reason is logged) and nothing moves. A connection lost mid-motion aborts the goal with a message
starting "driver_lost:" after telling the arm to stop; a protective stop mid-motion aborts it with
"motion failed: protective stop during <move> (safety mode 3 PROTECTIVE_STOP, ...)".
"""

from __future__ import annotations

from dataclasses import dataclass

from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from sensor_msgs.msg import JointState

from impurity_common import cell, names
from impurity_common.enums import PrimitiveKind
from impurity_common.node_main import spin_node
from impurity_common.parameters import ParameterError, declare_parameters, param
from impurity_interfaces.action import ExecutePrimitive
from ur5_driver_rtde.core.arm import DriverLost, UrArm
from ur5_driver_rtde.core.executor import BIN_POSITION, PlanExecutor
from ur5_driver_rtde.core.gripper import URCAP_PORT, GripperError, Robotiq2F85
from ur5_driver_rtde.core.recording import CommandLog, DryRunGripper, DryRunRobot
from ur5_motion import motion, ur5_kinematics

GRIPPERS = ("robotiq_2f85", "dry_run")


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
                                        "detection, which needs PolyScope 5.4+: the only contact sensing on "
                                        "a CB3); the UR5's force estimate is noisy without an F/T sensor")
    bin_position: tuple[float, ...] = param(BIN_POSITION, "TCP position in base_link (m) where a held object "
                                            "is released after a grasp; within the UR5's reach",
                                            length=3, low=-2.0, high=2.0, check=motion.reach_problem)
    joint_state_rate: float = param(50.0, f"{names.JOINT_STATES_TOPIC} messages per second",
                                    low=0.1, high=500.0)


class Ur5DriverNode(Node):
    def __init__(self):
        super().__init__("ur5_driver")
        params = self.params = declare_parameters(self, Ur5DriverParameters)
        self._log = CommandLog(params.dry_run_log or None,
                               echo=self.get_logger().info if params.dry_run else None)
        control, receive, gripper = self._connect(params)
        self._arm = UrArm(control, receive, joint_speed=params.joint_speed,
                          force_threshold_check=params.force_threshold_check,
                          flange_to_tcp=params.flange_to_tcp)
        self._gripper = gripper
        try:
            self._arm.prepare()
        except DriverLost as error:
            raise ParameterError(self.get_name(), f"the controller does not answer: {error}", "robot_ip",
                                 params.robot_ip) from None
        self._executor = PlanExecutor(self._arm, gripper, self._log, params.speed_scale, params.bin_position)
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
        mode = "DRY RUN (nothing is sent to a robot)" if params.dry_run else f"UR5 at {params.robot_ip}"
        logged = params.dry_run and params.dry_run_log
        where = f", commands appended to {params.dry_run_log}" if logged else ""
        self.get_logger().info(f"ready: {mode}, gripper {params.gripper if not params.dry_run else 'dry run'}"
                               f", speed scale {params.speed_scale:g}{where}")

    def _connect(self, params: Ur5DriverParameters):
        """(control, receive, gripper): recording stand-ins in a dry run, else ur-rtde and the gripper."""
        if params.dry_run:
            robot = DryRunRobot(self._log, drop_after=None if params.dry_run_drop_after < 0
                                else params.dry_run_drop_after, held_width=params.dry_run_held_width,
                                contact_height=None if params.dry_run_contact_height < 0
                                else params.dry_run_contact_height, flange_to_tcp=params.flange_to_tcp)
            return robot.control, robot.receive, robot.gripper
        import rtde_control  # ur-rtde (requirements.txt); only a real cell needs it
        import rtde_receive
        try:
            control = rtde_control.RTDEControlInterface(params.robot_ip, params.rtde_frequency)
            receive = rtde_receive.RTDEReceiveInterface(params.robot_ip, params.rtde_frequency)
        except RuntimeError as error:
            raise ParameterError(self.get_name(), f"cannot connect to the UR controller: {error}", "robot_ip",
                                 params.robot_ip) from None
        if params.gripper == "dry_run":
            return control, receive, DryRunGripper(CommandLog(echo=self.get_logger().info))
        try:
            gripper = Robotiq2F85(params.robot_ip, params.gripper_port)
            gripper.activate()
        except GripperError as error:
            raise ParameterError(self.get_name(), f"gripper: {error}", "gripper", params.gripper) from None
        return control, receive, gripper

    def destroy_node(self):
        self._log.echo = None  # rosout may already be gone; the JSONL file still gets every record
        self._arm.stop()
        for close in (self._gripper.disconnect, self._arm.control.disconnect, self._log.close):
            try:
                close()
            except RuntimeError as error:
                self.get_logger().warning(f"shutdown: {error}")
        return super().destroy_node()

    # ------------------------------------------------------------------------------------ joint states
    def _publish_joints(self) -> None:
        """Measured joints, UR names; skipped (reported once) while the controller does not answer."""
        if not self.context.ok():
            return
        try:
            if not self._arm.connected():
                raise DriverLost("not connected")
            positions = self._arm.joint_positions()
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
        """Accept one valid primitive at a time; reject anything else with its reason in the log."""
        primitive = goal.primitive
        p = primitive.position
        reason = self._claim.refuse_or_claim(primitive.kind, p.x, p.y, p.z, primitive.yaw,
                                             primitive.header.frame_id, self._arm.unavailable)
        if reason is not None:
            self.get_logger().warning(f"goal rejected: {reason}")
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

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

        try:
            self._goals += 1
            plan = motion.plan_primitive(kind, p.x, p.y, p.z, float(primitive.yaw))
            outcome = self._executor.execute(plan, self._goals, phase,
                                             lambda: goal_handle.is_cancel_requested)
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


def main(args=None):
    spin_node(Ur5DriverNode, args=args, executor_factory=lambda: MultiThreadedExecutor(num_threads=3))


if __name__ == "__main__":
    main()
