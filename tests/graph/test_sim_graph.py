"""sim_cell as a process, driven through its ROS interfaces: camera topics, /joint_states, the
ExecutePrimitive action (grasp, busy, invalid, cancel) and the sim services, in arm mode."""

import json
import math

import numpy as np
from action_msgs.msg import GoalStatus
from geometry_msgs.msg import Point
from sensor_msgs.msg import CameraInfo, Image, JointState

from impurity_common import cell, names
from impurity_common.conversions import image_to_numpy, time_to_ns
from impurity_common.enums import Scenario
from impurity_interfaces.action import ExecutePrimitive
from impurity_interfaces.msg import Primitive
from impurity_interfaces.srv import GetGroundTruth, ResetScene
from ros_harness import ActionHelper, TopicRecorder, call_service, ros_args, spin_until

UR_JOINTS = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
             "wrist_3_joint"]


def primitive(kind, x, y, z, yaw):
    msg = Primitive(kind=kind, position=Point(x=x, y=y, z=z), yaw=yaw)
    msg.header.frame_id = names.BASE_FRAME
    return ExecutePrimitive.Goal(primitive=msg)


def test_sim_cell_through_its_interfaces(ros_node, launch, tmp_path):
    sim = launch("ur5_driver_sim", "sim_cell", ros_args({
        "mode": "arm", "camera_rate": 10.0, "initial_scenario": Scenario.EMPTY, "depth_encoding": "16UC1",
        "real_time_factor": 1.0}))  # real arm speed: a goal sent during a motion surely meets a busy driver
    procs = [sim]
    color = TopicRecorder(ros_node, Image, names.COLOR_TOPIC, 5)
    depth = TopicRecorder(ros_node, Image, names.DEPTH_TOPIC, 5)
    info = TopicRecorder(ros_node, CameraInfo, names.CAMERA_INFO_TOPIC, 5)
    joints = TopicRecorder(ros_node, JointState, names.JOINT_STATES_TOPIC, 50)

    # One block at a known pose, from a scene file.
    scene = tmp_path / "one_block.json"
    block = {"shape": "cube", "dims": [0.04, 0.04, 0.04], "position": [0.52, 0.05, 0.021], "is_target": True}
    scene.write_text(json.dumps([block]))
    reset = call_service(ros_node, ResetScene, names.RESET_SCENE_SERVICE,
                         ResetScene.Request(scenario=Scenario.FILE, scene_file=str(scene)), processes=procs,
                         resend_after=5.0)  # the same file scene again: idempotent
    assert reset.success, reset.message
    assert (reset.num_targets, reset.num_objects) == (1, 0)
    reset_done_ns = ros_node.get_clock().now().nanoseconds
    bad = call_service(ros_node, ResetScene, names.RESET_SCENE_SERVICE, ResetScene.Request(scenario="tidy"),
                       processes=procs)
    assert not bad.success and "unknown scenario" in bad.message

    # Camera: realsense-like topics, consistent sizes and intrinsics, the block in the depth image.
    first_color = color.wait_for(1, 60.0, processes=procs)[0]
    first_depth = depth.wait_for(1, 60.0, processes=procs)[0]
    first_info = info.wait_for(1, 60.0, processes=procs)[0]
    assert first_color.encoding == "rgb8" and (first_color.height, first_color.width) == (480, 640)
    assert first_depth.encoding == "16UC1"
    assert first_color.header.frame_id == names.CAMERA_OPTICAL_FRAME
    assert first_info.k[0] == cell.CAMERA_FX and first_info.width == 640
    after_reset = depth.wait_for(1, 60.0, predicate=lambda m: time_to_ns(m.header.stamp) > reset_done_ns,
                                 processes=procs)[0]
    depth_mm = image_to_numpy(after_reset)
    assert depth_mm.min() < 750 - 30 and abs(int(np.median(depth_mm)) - 750) <= 2  # block top vs table

    joint_msg = joints.wait_for(1, 30.0, processes=procs)[0]
    assert list(joint_msg.name) == UR_JOINTS
    home = np.array(joint_msg.position)

    # Invalid and busy goals are rejected; a valid grasp lifts the target.
    action = ActionHelper(ros_node, ExecutePrimitive, names.EXECUTE_PRIMITIVE_ACTION, processes=procs)
    # server_is_ready() covers the action's services, not the feedback topic, which each side discovers
    # on its own: warm up with pushes far from the block until feedback flows.
    for _ in range(5):
        action.run(primitive(Primitive.PUSH, 0.30, -0.20, 0.01, 0.0), timeout=120.0)
        if action.feedback:
            break
    assert action.feedback, "no feedback from the driver after 5 primitives"
    assert not action.send_goal(primitive(Primitive.GRASP, 1.5, 0.0, 0.01, 0.0)).accepted
    assert not action.send_goal(primitive(Primitive.GRASP, 0.5, 0.0, float("nan"), 0.0)).accepted
    joints.messages.clear()
    action.feedback.clear()
    handle = action.send_goal(primitive(Primitive.GRASP, 0.52, 0.05, 0.006, 0.0))
    assert handle.accepted
    assert not action.send_goal(primitive(Primitive.PUSH, 0.5, 0.0, 0.01, 0.0)).accepted  # busy
    wrapped = action.get_result(handle, timeout=120.0)
    assert wrapped.status == GoalStatus.STATUS_SUCCEEDED
    result = wrapped.result
    assert result.success and result.target_grasped and result.grasped_object_id >= 0, result.message
    assert time_to_ns(result.finished) > time_to_ns(first_color.header.stamp)
    # Feedback and result travel on different topics: wait for the last phase rather than assume order.
    spin_until(ros_node, lambda: any(f.phase == "done" for f in action.feedback), 30.0, "feedback 'done'",
               procs)
    phases = [f.phase for f in action.feedback]
    assert phases[0] == "approach" and "close" in phases and phases[-1] == "done"
    # The arm really moved (joint states during the motion differ from home) and came back.
    moved = max(float(np.max(np.abs(np.array(m.position) - home))) for m in joints.messages)
    assert moved > 0.2
    joints.wait_for(1, 30.0, predicate=lambda m: np.allclose(m.position, home, atol=0.02), processes=procs)
    # A fresh frame after the motion shows an empty table.
    fresh = depth.wait_for(1, 60.0, processes=procs,
                           predicate=lambda m: time_to_ns(m.header.stamp) > time_to_ns(result.finished))[0]
    assert image_to_numpy(fresh).min() >= 750 - 5

    truth = call_service(ros_node, GetGroundTruth, names.GROUND_TRUTH_SERVICE, GetGroundTruth.Request(),
                         processes=procs, resend_after=5.0)
    assert (truth.targets_removed, truth.targets_remaining, truth.non_targets_removed) == (1, 0, 0)

    # Cancel: the motion stops, the goal ends canceled, and the driver takes the next goal.
    reset = call_service(ros_node, ResetScene, names.RESET_SCENE_SERVICE,
                         ResetScene.Request(scenario=Scenario.RANDOM, seed=2, num_targets=1, num_objects=4),
                         processes=procs)
    assert reset.success
    handle = action.send_goal(primitive(Primitive.PUSH, 0.45, -0.1, 0.01, math.pi / 4))
    assert handle.accepted
    action.cancel(handle)
    wrapped = action.get_result(handle, timeout=120.0)
    assert wrapped.status == GoalStatus.STATUS_CANCELED
    assert not wrapped.result.success and "cancel" in wrapped.result.message
    _, after_cancel = action.run(primitive(Primitive.PUSH, 0.45, -0.1, 0.01, math.pi / 4), timeout=120.0)
    assert after_cancel.status == GoalStatus.STATUS_SUCCEEDED and after_cancel.result.success
    action.destroy()
    for recorder in (color, depth, info, joints):
        recorder.destroy()


def test_depth_encodings_and_camera_info():
    from std_msgs.msg import Header

    from ur5_driver_sim.core.camera import CameraModel
    from ur5_driver_sim.sim_cell import camera_info_msg, depth_image

    depth = np.array([[0.75, 0.7004], [np.nan, 70.0]], dtype=np.float32)
    mm = depth_image(depth, "16UC1")
    assert mm.dtype == np.uint16 and mm.tolist() == [[750, 700], [0, 65535]]
    metres = depth_image(depth, "32FC1")
    assert metres.dtype == np.float32 and metres[0, 1] == np.float32(0.7004)
    info = camera_info_msg(CameraModel(), Header(frame_id=names.CAMERA_OPTICAL_FRAME))
    assert (info.width, info.height) == (cell.CAMERA_WIDTH, cell.CAMERA_HEIGHT)
    expected_k = [cell.CAMERA_FX, 0.0, cell.CAMERA_CX, 0.0, cell.CAMERA_FY, cell.CAMERA_CY, 0.0, 0.0, 1.0]
    assert list(info.k) == expected_k
