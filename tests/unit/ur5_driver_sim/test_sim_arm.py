"""The UR5 from DH parameters: kinematics against PyBullet, IK, the parked pose, oracle grasps in arm
mode, and agreement of arm and floating-gripper outcomes over seeded primitives."""

import json
import math

import numpy as np
import pytest
from test_sim_world import oracle_grasp, write_single_block

from ur5_driver_sim.core.world import CellWorld, yaw_of_quaternion
from ur5_motion import ur5_kinematics as ur5_model

AGREEMENT_SEEDS = 30


@pytest.fixture(scope="module")
def arm_world():
    world = CellWorld(mode="arm")
    yield world
    world.close()


def test_forward_kinematics_matches_the_pybullet_body(arm_world):
    carrier, pb = arm_world.carrier, arm_world.pb
    rng = np.random.default_rng(0)
    try:
        for _ in range(5):
            q = np.array(ur5_model.HOME_JOINTS) + rng.uniform(-0.8, 0.8, 6)
            for joint, value in zip(carrier.arm_joints, q, strict=True):
                pb.resetJointState(carrier.body, joint, value)
            state = pb.getLinkState(carrier.body, carrier.tcp_link, computeForwardKinematics=True)
            model = ur5_model.tcp_pose(q)
            np.testing.assert_allclose(state[4], model[:3, 3], atol=1e-6)
            rotation = np.reshape(pb.getMatrixFromQuaternion(state[5]), (3, 3))
            np.testing.assert_allclose(rotation, model[:3, :3], atol=1e-6)
    finally:
        arm_world.reset_scene("empty")


def test_ik_reaches_the_workspace_corners_top_down():
    for x in (0.276, 0.724):
        for y in (-0.224, 0.224):
            for z in (0.005, 0.15, 0.27):  # table, highest primitive, highest lift
                q = ur5_model.ik((x, y, z), 0.7, ur5_model.seed_towards((x, y, z)))
                pose = ur5_model.tcp_pose(q)
                np.testing.assert_allclose(pose[:3, 3], (x, y, z), atol=1e-3)
                assert pose[2, 2] > 0.999  # gripper z up: fingers point down
    with pytest.raises(ur5_model.IKError):
        ur5_model.ik((1.5, 0.0, 0.1), 0.0, ur5_model.HOME_JOINTS)


def test_parked_arm_is_out_of_the_camera_view(arm_world):
    arm_world.reset_scene("random", seed=1, num_targets=1, num_objects=4)
    frame = arm_world.render()
    assert not np.any(frame.segmentation == arm_world.carrier.body)
    joints = arm_world.joint_positions()
    assert list(joints) == list(ur5_model.JOINT_NAMES)
    np.testing.assert_allclose(list(joints.values()), ur5_model.HOME_JOINTS, atol=0.01)


def test_oracle_grasp_on_isolated_block_arm(arm_world, tmp_path):
    successes = 0
    for seed in range(20):
        path, shape, dims = write_single_block(tmp_path, seed)
        arm_world.reset_scene("file", scene_file=str(path))
        out = oracle_grasp(arm_world, shape, dims)
        successes += out.success and out.target_grasped
    assert successes >= 19


def test_push_moves_the_touched_block_5cm_arm(arm_world, tmp_path):
    path = tmp_path / "cube.json"
    path.write_text(json.dumps([dict(shape="cube", dims=[0.04] * 3, position=[0.55, 0.1, 0.021])]))
    arm_world.reset_scene("file", scene_file=str(path))
    (body, (before, _)), = arm_world.poses().items()
    yaw = -2.0
    out = arm_world.push(0.55 - 0.05 * math.cos(yaw), 0.1 - 0.05 * math.sin(yaw), 0.01, yaw)
    assert out.success and math.dist(before[:2], arm_world.poses()[body][0][:2]) >= 0.05


def seeded_primitive(world, seed):
    """Even seeds: a grasp at a block's centre across one of its axes (with noise); odd: a push towards
    a block from 5 cm away."""
    rng = np.random.default_rng(1000 + seed)
    poses = world.poses()
    body = sorted(poses)[rng.integers(len(poses))]
    (x, y, z), quat = poses[body]
    if seed % 2 == 0:
        yaw = yaw_of_quaternion(quat) + rng.choice([0.0, math.pi / 2]) + rng.normal(0, 0.15)
        return "grasp", x, y, max(z - 0.015, 0.0), yaw
    direction = rng.uniform(0, 2 * math.pi)
    return "push", x - 0.05 * math.cos(direction), y - 0.05 * math.sin(direction), 0.01, direction


def outcome_class(world, kind, outcome, before):
    """What arm and floating modes must agree on: grasped or not; for a push, the displacement class of the
    block that moved most."""
    if kind == "grasp":
        return ("grasp", outcome.success)
    after = world.poses()
    largest = max(math.dist(before[b][0][:2], after[b][0][:2]) for b in before if b in after)
    return ("push", CellWorld.displacement_class(largest))


def test_arm_and_floating_modes_agree(arm_world):
    floating = CellWorld(mode="floating")
    agreements, disagreements = 0, []
    try:
        for seed in range(AGREEMENT_SEEDS):
            classes = []
            for world in (floating, arm_world):
                world.reset_scene("random", seed=seed, num_targets=1, num_objects=7)
                primitive = seeded_primitive(world, seed)
                before = world.poses()
                classes.append(outcome_class(world, primitive[0], world.execute(*primitive), before))
            if classes[0] == classes[1]:
                agreements += 1
            else:
                disagreements.append((seed, classes))
    finally:
        floating.close()
    assert agreements >= math.ceil(0.9 * AGREEMENT_SEEDS), disagreements
