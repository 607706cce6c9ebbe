"""Specification of the TCP <-> ur-rtde pose conversion: it agrees with the UR5 kinematics (DH model,
base_link vs the controller's base frame, tool0 vs the gripper TCP)."""

import math

import numpy as np
import pytest

from impurity_common import cell
from ur5_driver_rtde.core.poses import rotation_matrix, tcp_from_ur_pose, ur_tool0_pose
from ur5_motion import ur5_kinematics

TCP_POSES = [((0.5, 0.0, 0.05), 0.0), ((0.3, -0.2, 0.12), math.pi / 3), ((0.7, 0.2, 0.02), -2.5),
             ((0.45, 0.1, 0.25), math.pi / 2)]


@pytest.mark.parametrize("position,yaw", TCP_POSES)
def test_commanded_tool0_pose_is_where_the_kinematics_put_tool0(position, yaw):
    q = ur5_kinematics.ik(position, yaw, ur5_kinematics.seed_towards(position))
    frames = ur5_kinematics.joint_frames(q)
    tool0_in_controller_base = np.linalg.inv(frames[0]) @ frames[6]  # DH frame 0 is the UR `base`
    pose = ur_tool0_pose(position, yaw)
    assert pose[:3] == pytest.approx(tool0_in_controller_base[:3, 3].tolist(), abs=1e-4)
    assert np.allclose(rotation_matrix(pose[3:]), tool0_in_controller_base[:3, :3], atol=1e-4)


@pytest.mark.parametrize("position,yaw", TCP_POSES)
def test_tcp_from_ur_pose_inverts_the_conversion(position, yaw):
    back, back_yaw = tcp_from_ur_pose(ur_tool0_pose(position, yaw))
    assert back == pytest.approx(position, abs=1e-9)
    assert math.remainder(back_yaw - yaw, 2 * math.pi) == pytest.approx(0.0, abs=1e-9)


def test_tool0_is_flange_to_tcp_above_the_tcp_and_base_is_turned_by_pi():
    pose = ur_tool0_pose((0.5, 0.1, 0.02), 0.0)
    assert pose[:3] == pytest.approx([-0.5, -0.1, 0.02 + cell.FLANGE_TO_TCP])


def test_another_gripper_length_shifts_tool0_along_its_axis():
    pose = ur_tool0_pose((0.5, 0.1, 0.02), 0.7, flange_to_tcp=0.16)
    assert pose[2] == pytest.approx(0.18)
    back, _ = tcp_from_ur_pose(pose, flange_to_tcp=0.16)
    assert back == pytest.approx((0.5, 0.1, 0.02))


def test_bad_poses_are_refused():
    with pytest.raises(ValueError, match="non-finite"):
        ur_tool0_pose((0.5, float("nan"), 0.0), 0.0)
    with pytest.raises(ValueError, match="6 values"):
        tcp_from_ur_pose([0.0, 0.0, 0.0])
