"""sim_cell: one process owning the PyBullet cell, standing in for the RealSense camera, the UR driver
and the gripper driver.

    camera  -> /camera/camera/color/image_raw (rgb8), /camera/camera/aligned_depth_to_color/image_raw
               (16UC1 mm or 32FC1 m), /camera/camera/color/camera_info   [wall-clock stamps]
    driver  <- action /ur5/execute_primitive, -> /joint_states (UR joint names)
    sim     <- /cell/reset_scene, /cell/ground_truth

Thin shell around ur5_driver_sim.core.world.CellWorld. PyBullet is not thread-safe, so one lock
guards the world: the camera skips a frame while a primitive runs (a real camera would show the arm
anyway) and resumes as soon as the motion is over, so the first frame after a result is fresh.
"""

from __future__ import annotations

import sys
import threading
import time
from dataclasses import dataclass

import numpy as np
from geometry_msgs.msg import Pose
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import CameraInfo, Image, JointState
from std_msgs.msg import Header

from impurity_common import cell, names
from impurity_common.conversions import numpy_to_image
from impurity_common.diagnostics import OK, Diagnostics, RateMeter, Status
from impurity_common.enums import PrimitiveKind, Scenario
from impurity_common.node_main import spin_node
from impurity_common.parameters import (
    ParameterError,
    camera_orientation_param,
    camera_position_param,
    declare_parameters,
    param,
)
from impurity_interfaces.action import ExecutePrimitive
from impurity_interfaces.srv import GetGroundTruth, ResetScene
from ur5_driver_sim.core.camera import CameraModel
from ur5_driver_sim.core.config import TIME_STEP
from ur5_driver_sim.core.scenes import MAX_BLOCKS
from ur5_driver_sim.core.world import MODES, CellWorld
from ur5_motion import motion
from ur5_motion.ur5_kinematics import JOINT_NAMES

DEPTH_ENCODINGS = ("16UC1", "32FC1")
MAX_CAMERA_RATE = 30.0
SERVICE_LOCK_TIMEOUT = 30.0  # s a reset or ground-truth query waits for a running primitive
SHUTDOWN_LOCK_TIMEOUT = 5.0  # s shutdown waits for a running primitive before leaving anyway
GIL_YIELD_EVERY = 2  # physics steps between explicit GIL hand-overs
GIL_SWITCH_INTERVAL = 0.001  # s (Python's default 0.005 starves the executor threads during motions)


@dataclass(frozen=True)
class SimCellParameters:
    """Every parameter of the node (bringup/config/cell.yaml, section sim_cell)."""

    mode: str = param("arm", "arm: the UR5 (DH model, IK + joint motion) carries the gripper; floating: "
                      "gripper only", choices=MODES)
    camera_rate: float = param(5.0, "Camera frames per second; a 640x480 render costs ~60 ms",
                               low=0.1, high=MAX_CAMERA_RATE)
    depth_encoding: str = param("16UC1", "Aligned depth encoding: 16UC1 (mm, realsense default) or 32FC1 (m)",
                                choices=DEPTH_ENCODINGS)
    depth_noise_std: float = param(0.0, "Gaussian depth noise (m); 0 = none", low=0.0, high=0.1)
    camera_position: tuple[float, ...] = camera_position_param()
    camera_orientation: tuple[float, ...] = camera_orientation_param()
    initial_scenario: Scenario = param(Scenario.RANDOM, "Scene built at start")
    initial_seed: int = param(0, "Seed of the initial scene", low=0)
    initial_scene_file: str = param("", "JSON scene when initial_scenario is file")
    initial_palette: str = param("", "Appearance of the initial scene: a named palette or random-<seed> "
                                 "(\"\" = blocks, blue product and red impurities)")
    num_targets: int = param(-1, "Targets in the initial scene (-1: scenario default)",
                             low=-1, high=MAX_BLOCKS)
    num_objects: int = param(-1, "Basic blocks in the initial scene (-1: scenario default)",
                             low=-1, high=MAX_BLOCKS)
    joint_state_rate: float = param(50.0, f"{names.JOINT_STATES_TOPIC} messages per second",
                                    low=0.1, high=1000.0)
    solver_iterations: int = param(20, "PyBullet solver iterations per physics step", low=1, high=1000)
    real_time_factor: float = param(0.0, "Pace motions: 1.0 = as fast as a real arm, 0 = as fast as the CPU "
                                    "allows", low=0.0, high=100.0)


def depth_image(depth_m: np.ndarray, encoding: str) -> np.ndarray:
    """Metric depth -> the array for the chosen encoding (16UC1: mm, 0 where invalid or too far)."""
    if encoding == "32FC1":
        return depth_m.astype(np.float32)
    mm = np.nan_to_num(depth_m * 1000.0, nan=0.0, posinf=0.0, neginf=0.0)
    return np.clip(np.rint(mm), 0, 65535).astype(np.uint16)


def camera_info_msg(camera: CameraModel, header: Header) -> CameraInfo:
    info = CameraInfo(header=header, width=camera.width, height=camera.height, distortion_model="plumb_bob")
    info.d = [0.0] * 5
    info.k = [float(v) for v in camera.intrinsics.reshape(-1)]
    info.r = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    info.p = [camera.fx, 0.0, camera.cx, 0.0, 0.0, camera.fy, camera.cy, 0.0, 0.0, 0.0, 1.0, 0.0]
    return info


class SimCellNode(Node):
    def __init__(self):
        super().__init__("sim_cell")
        params = self.params = declare_parameters(self, SimCellParameters)
        mode, rate = params.mode, params.camera_rate
        self._depth_encoding = params.depth_encoding
        camera = CameraModel(position=params.camera_position, orientation=params.camera_orientation)

        self._real_time_factor = params.real_time_factor
        self._pace_start, self._pace_steps = time.monotonic(), 0
        self._world_lock = threading.Lock()
        self._claim = motion.ArmClaim()  # one primitive at a time
        self._world = CellWorld(mode=mode, camera=camera, depth_noise_std=params.depth_noise_std,
                                solver_iterations=params.solver_iterations)
        self._joint_snapshot = self._world.joint_positions()
        self._world.step_hook = self._on_physics_step
        scenario = params.initial_scenario
        try:
            info = self._world.reset_scene(scenario, seed=params.initial_seed, num_targets=params.num_targets,
                                           num_objects=params.num_objects,
                                           scene_file=params.initial_scene_file or None,
                                           palette=params.initial_palette)
        except ValueError as refused:  # e.g. scenario file without a scene file, too many blocks
            self._world.close()
            raise ParameterError(self.get_name(), f"initial scene: {refused}") from None
        self._joint_snapshot = self._world.joint_positions()

        reliable = QoSProfile(depth=2, reliability=ReliabilityPolicy.RELIABLE)
        self._color_pub = self.create_publisher(Image, names.COLOR_TOPIC, reliable)
        self._depth_pub = self.create_publisher(Image, names.DEPTH_TOPIC, reliable)
        self._info_pub = self.create_publisher(CameraInfo, names.CAMERA_INFO_TOPIC, reliable)
        self._joint_pub = self.create_publisher(JointState, names.JOINT_STATES_TOPIC, 10)

        timers = MutuallyExclusiveCallbackGroup()
        self.create_timer(1.0 / rate, self._publish_frame, callback_group=timers)
        self.create_timer(1.0 / params.joint_state_rate, self._publish_joints,
                          callback_group=MutuallyExclusiveCallbackGroup())
        services = MutuallyExclusiveCallbackGroup()
        self.create_service(ResetScene, names.RESET_SCENE_SERVICE, self._on_reset, callback_group=services)
        self.create_service(GetGroundTruth, names.GROUND_TRUTH_SERVICE, self._on_ground_truth,
                            callback_group=services)
        self._action = ActionServer(
            self, ExecutePrimitive, names.EXECUTE_PRIMITIVE_ACTION, execute_callback=self._execute,
            goal_callback=self._on_goal, cancel_callback=lambda _goal: CancelResponse.ACCEPT,
            callback_group=ReentrantCallbackGroup())
        self._frames = RateMeter()
        self.diagnostics = Diagnostics(self, lambda: Status(
            OK, f"simulated cell ({mode}): camera at {self._frames.rate():.1f} Hz",
            {"mode": mode, "frame rate (Hz)": self._frames.rate(), "frames published": self._frames.count}),
            hardware_id="pybullet", callback_group=MutuallyExclusiveCallbackGroup())
        self.get_logger().info(
            f"ready: mode {mode}, {scenario} scene seed {info.seed} ({info.num_targets} targets, "
            f"{info.num_objects} blocks), camera {rate:g} Hz {self._depth_encoding}")

    def destroy_node(self):
        if self._world_lock.acquire(timeout=SHUTDOWN_LOCK_TIMEOUT):  # let a running motion finish
            try:
                self._world.close()
            finally:
                self._world_lock.release()
        return super().destroy_node()

    # ------------------------------------------------------------------------------------ publishing
    def _on_physics_step(self, world) -> None:
        """Runs inside the world (lock held): keep a snapshot for the joint-state timer, cheaply, and
        hand the GIL over (PyBullet keeps it during a step) so cancels, feedback and joint states flow
        while a primitive runs."""
        self._pace_steps += 1
        if world.steps % GIL_YIELD_EVERY == 0:
            time.sleep(self._seconds_ahead_of_wall_clock())
        if world.steps % 8 == 0:
            self._joint_snapshot = world.joint_positions()

    def _seconds_ahead_of_wall_clock(self) -> float:
        """How far the motion's sim time runs ahead of real_time_factor x wall time (0 when unpaced)."""
        if self._real_time_factor <= 0:
            return 0.0
        sim_elapsed = self._pace_steps * TIME_STEP / self._real_time_factor
        return max(0.0, sim_elapsed - (time.monotonic() - self._pace_start))

    def _publish_joints(self) -> None:
        if not self.context.ok():
            return
        positions = self._joint_snapshot
        msg = JointState()
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.name = list(JOINT_NAMES)
        msg.position = [float(positions.get(name, 0.0)) for name in JOINT_NAMES]
        self._joint_pub.publish(msg)

    def _publish_frame(self) -> None:
        if not self.context.ok():
            return
        camera_pubs = (self._color_pub, self._depth_pub, self._info_pub)
        if not any(pub.get_subscription_count() for pub in camera_pubs):
            return  # nobody looks: save the ~60 ms render (the CPU is shared with training)
        if not self._world_lock.acquire(blocking=False):
            return  # a primitive or a reset is running; the next tick after it publishes
        try:
            stamp = self.get_clock().now().to_msg()
            frame = self._world.render()
        finally:
            self._world_lock.release()
        header = Header(stamp=stamp, frame_id=names.CAMERA_OPTICAL_FRAME)
        self._color_pub.publish(numpy_to_image(frame.color, "rgb8", header))
        self._depth_pub.publish(numpy_to_image(depth_image(frame.depth, self._depth_encoding),
                                               self._depth_encoding, header))
        self._info_pub.publish(camera_info_msg(self._world.camera, header))
        self._frames.tick()

    # ------------------------------------------------------------------------------------ driver
    def _on_goal(self, goal: ExecutePrimitive.Goal) -> GoalResponse:
        primitive = goal.primitive
        p = primitive.position
        reason = self._claim.refuse_or_claim(primitive.kind, p.x, p.y, p.z, primitive.yaw,
                                             primitive.header.frame_id)
        if reason is not None:
            self.get_logger().warning(f"goal rejected: {reason}")
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def _execute(self, goal_handle) -> ExecutePrimitive.Result:
        primitive = goal_handle.request.primitive
        kind = PrimitiveKind(primitive.kind).label
        p = primitive.position
        feedback = ExecutePrimitive.Feedback()

        def phase(name: str, progress: float) -> None:
            feedback.phase, feedback.progress = name, float(progress)
            if self.context.ok():  # not during shutdown
                goal_handle.publish_feedback(feedback)

        try:
            with self._world_lock:
                self._pace_start, self._pace_steps = time.monotonic(), 0
                self._world.cancel_check = lambda: goal_handle.is_cancel_requested
                try:
                    outcome = self._world.execute(kind, p.x, p.y, p.z, float(primitive.yaw), phase)
                finally:
                    self._world.cancel_check = None
                    self._joint_snapshot = self._world.joint_positions()
        except Exception as error:  # a physics failure must not kill the driver
            self.get_logger().error(f"{kind} failed: {error!r}")
            goal_handle.abort()
            return ExecutePrimitive.Result(success=False, motion_completed=False, gripper_opening=-1.0,
                                           grasped_object_id=-1, message=f"error: {error}",
                                           finished=self.get_clock().now().to_msg())
        finally:
            self._claim.release()
        result = ExecutePrimitive.Result(
            success=bool(outcome.success), motion_completed=bool(outcome.motion_completed),
            gripper_opening=float(outcome.gripper_opening), holding=bool(outcome.holding),
            target_grasped=bool(outcome.target_grasped), grasped_object_id=int(outcome.object_id),
            message=outcome.message,
            finished=self.get_clock().now().to_msg())
        if goal_handle.is_cancel_requested:
            goal_handle.canceled()
        else:
            goal_handle.succeed()
        self.get_logger().info(f"{kind} at ({p.x:.3f}, {p.y:.3f}, {p.z:.3f}) yaw {primitive.yaw:.2f}: "
                               f"{'ok' if outcome.success else 'failed'} ({outcome.message})")
        return result

    # ------------------------------------------------------------------------------------ sim services
    def _on_reset(self, request: ResetScene.Request, response: ResetScene.Response) -> ResetScene.Response:
        if not self._world_lock.acquire(timeout=SERVICE_LOCK_TIMEOUT):
            response.success, response.message = False, "busy: a primitive is still running"
            return response
        try:
            info = self._world.reset_scene(Scenario.parse(request.scenario), seed=int(request.seed),
                                           num_targets=request.num_targets, num_objects=request.num_objects,
                                           scene_file=request.scene_file or None, palette=request.palette)
            self._joint_snapshot = self._world.joint_positions()
        except (ValueError, RuntimeError) as error:
            response.success, response.message = False, str(error)
            self.get_logger().warning(f"reset refused: {error}")
            return response
        finally:
            self._world_lock.release()
        response.success = True
        response.num_targets, response.num_objects = info.num_targets, info.num_objects
        response.targets_outside_workspace = info.targets_outside_workspace
        response.objects_outside_workspace = info.objects_outside_workspace
        outside = _outside_note(info.targets_outside_workspace, info.objects_outside_workspace)
        response.message = (f"{info.scenario} seed {info.seed} ({info.palette}): {info.num_targets} targets, "
                            f"{info.num_objects} blocks{f' ({outside})' if outside else ''} in "
                            f"{info.generation_seconds:.2f} s")
        if outside:
            self.get_logger().warning(
                f"scene {info.scenario} seed {info.seed}: {outside} (x in [{cell.WORKSPACE_X[0]:.3f}, "
                f"{cell.WORKSPACE_X[1]:.3f}] m, y in [{cell.WORKSPACE_Y[0]:.3f}, "
                f"{cell.WORKSPACE_Y[1]:.3f}] m, on the table): they cannot be picked and are counted apart")
        return response

    def _on_ground_truth(self, _request, response: GetGroundTruth.Response) -> GetGroundTruth.Response:
        if not self._world_lock.acquire(timeout=SERVICE_LOCK_TIMEOUT):
            response.success, response.message = False, (
                f"world busy: a primitive is still running after {SERVICE_LOCK_TIMEOUT:.0f} s")
            self.get_logger().warning(f"ground truth: {response.message}")
            return response
        try:
            gt = self._world.ground_truth()
        finally:
            self._world_lock.release()
        response.success = True
        response.targets_remaining, response.objects_remaining = gt.targets_remaining, gt.objects_remaining
        response.targets_outside_workspace = gt.targets_out_of_workspace
        response.objects_outside_workspace = gt.objects_out_of_workspace
        response.targets_removed, response.non_targets_removed = gt.targets_removed, gt.non_targets_removed
        response.visible_target_pixels = gt.visible_target_pixels
        response.target_poses = [_pose(*gt.poses[b]) for b in gt.target_ids if b in gt.poses]
        return response


def _outside_note(targets: int, objects: int) -> str:
    """"1 target(s) and 2 block(s) outside the workspace", or "" when everything is inside."""
    parts = [f"{n} {what}(s)" for n, what in ((targets, "target"), (objects, "block")) if n]
    return f"{' and '.join(parts)} outside the workspace" if parts else ""


def _pose(position, orientation) -> Pose:
    pose = Pose()
    pose.position.x, pose.position.y, pose.position.z = (float(v) for v in position)
    (pose.orientation.x, pose.orientation.y, pose.orientation.z,
     pose.orientation.w) = (float(v) for v in orientation)
    return pose


def main(args=None):
    sys.setswitchinterval(GIL_SWITCH_INTERVAL)
    spin_node(SimCellNode, args=args, executor_factory=lambda: MultiThreadedExecutor(num_threads=4))


if __name__ == "__main__":
    main()
