"""The UR5 model without the simulator: URDF angles, the ROS frames of /robot_description, IK against FK
(PyBullet agreement lives in tests/unit/ur5_driver_sim/test_sim_arm.py)."""

import math

import numpy as np
import pytest

from ur5_motion import ur5_kinematics as kin


@pytest.mark.parametrize("seed", range(5))
def test_matrix_rpy_inverts_rpy_matrix(seed):
    rng = np.random.default_rng(seed)
    for _ in range(50):
        rpy = (rng.uniform(-math.pi, math.pi), rng.uniform(-1.5, 1.5), rng.uniform(-math.pi, math.pi))
        rotation = kin.rpy_matrix(*rpy)
        np.testing.assert_allclose(kin.rpy_matrix(*kin.matrix_rpy(rotation)), rotation, atol=1e-12)


def test_rpy_matrix_is_fixed_axis_roll_then_pitch_then_yaw():
    # roll pi/2 takes y to z; a following yaw pi/2 takes that z to z: y -> z overall
    np.testing.assert_allclose(kin.rpy_matrix(math.pi / 2, 0, math.pi / 2) @ [0, 1, 0], [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(kin.rpy_matrix(0, 0, math.pi / 2) @ [1, 0, 0], [0, 1, 0], atol=1e-12)


def test_matrix_rpy_at_gimbal_lock_still_reproduces_the_rotation():
    rotation = kin.rpy_matrix(0.3, math.pi / 2, -0.4)
    np.testing.assert_allclose(kin.rpy_matrix(*kin.matrix_rpy(rotation)), rotation, atol=1e-9)


def test_the_ros_frames_flange_is_the_ur_descriptions():
    """ur_description: wrist_3 -> flange rpy (0, -pi/2, -pi/2), flange -> tool0 rpy (pi/2, 0, pi/2)."""
    text = kin.urdf_text(ros_frames=True)
    assert '<child link="flange"/>' in text and '<child link="base_link_inertia"/>' in text
    flange = kin.rpy_matrix(kin.DH_ALPHA[5], 0, 0) @ kin.rpy_matrix(*kin.FLANGE_TO_TOOL0_RPY).T
    np.testing.assert_allclose(flange, kin.rpy_matrix(0, -math.pi / 2, -math.pi / 2), atol=1e-12)


def test_the_simulators_urdf_has_no_ros_only_frames():
    text = kin.urdf_text()
    assert "flange\"/>" not in text.replace('name="wrist_3-flange"', "")
    assert "base_link_inertia" not in text


@pytest.mark.parametrize("position", [(0.3, -0.2, 0.05), (0.7, 0.2, 0.02), (0.5, 0.0, 0.2)])
def test_ik_reaches_workspace_corners_and_fk_agrees(position):
    q = kin.ik(position, 0.4, kin.seed_towards(position))
    pose = kin.tcp_pose(q)
    np.testing.assert_allclose(pose[:3, 3], position, atol=1e-3)
    np.testing.assert_allclose(pose[:3, :3], kin.gripper_rotation(0.4), atol=1e-2)


def test_ik_out_of_reach_says_where():
    with pytest.raises(kin.IKError, match=r"no IK solution for TCP \(1\.5, 0\.0, 0\.1\)"):
        kin.ik((1.5, 0.0, 0.1), 0.0, kin.HOME_JOINTS)
