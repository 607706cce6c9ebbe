"""CellWorld core (no ROS): scenario invariants, determinism, oracle grasps, pushes, refusals."""

import json
import math

import numpy as np
import pytest

from impurity_common import cell
from ur5_driver_sim.core.scenes import save_scene_file
from ur5_driver_sim.core.shapes import SHAPES, random_dims
from ur5_driver_sim.core.world import CellWorld, yaw_of_quaternion


@pytest.fixture(scope="module")
def world():
    w = CellWorld(mode="floating")
    yield w
    w.close()


def write_single_block(tmp_path, seed):
    """One block of a seed-chosen shape at a seeded pose; returns (scene file, shape, dims)."""
    rng = np.random.default_rng(seed)
    shape = SHAPES[seed % len(SHAPES)]
    dims = random_dims(shape, rng)
    x, y, yaw = rng.uniform(0.38, 0.62), rng.uniform(-0.12, 0.12), rng.uniform(0, math.pi)
    path = tmp_path / f"single_{seed}.json"
    path.write_text(json.dumps([dict(shape=shape, dims=dims, position=[x, y, dims[2] / 2 + 0.001], yaw=yaw,
                                     is_target=True)]))
    return path, shape, dims


def oracle_grasp(world, shape, dims):
    """True centre, closing across the block's short horizontal axis (a prism across its flat ends)."""
    (body, (pos, quat)), = world.poses().items()
    across_y = dims[1] < dims[0] or shape == "prism"
    yaw = yaw_of_quaternion(quat) + (math.pi / 2 if across_y else 0.0)
    return world.grasp(pos[0], pos[1], max(pos[2] - 0.015, 0.0), yaw)


@pytest.mark.parametrize("scenario", ["random", "challenging", "invisible"])
def test_scenario_counts_and_workspace(world, scenario):
    info = world.reset_scene(scenario, seed=5, num_targets=2, num_objects=20)
    gt = world.ground_truth()
    assert (info.num_targets, info.num_objects) == (2, 20)
    assert (gt.targets_remaining, gt.objects_remaining) == (2, 20)
    assert gt.targets_removed == gt.non_targets_removed == 0


@pytest.mark.parametrize("scenario", ["random", "challenging", "invisible"])
def test_same_seed_same_scene(world, scenario):
    world.reset_scene(scenario, seed=11)
    first = world.poses()
    world.grasp(0.5, 0.0, 0.01, 0.0)  # history must not matter
    world.reset_scene(scenario, seed=11)
    second = world.poses()
    assert first.keys() == second.keys()
    for body in first:
        np.testing.assert_allclose(first[body][0], second[body][0], atol=1e-9)
    world.reset_scene(scenario, seed=12)
    third = world.poses()
    assert any(not np.allclose(first[b][0], third[b][0]) for b in first if b in third)


def test_same_seed_same_actions_same_outcomes(world):
    """Training reproducibility: a seeded scene and the same primitives give the same end state."""
    primitives = [("push", 0.42, -0.05, 0.01, 0.3), ("grasp", 0.5, 0.0, 0.01, 1.2),
                  ("push", 0.55, 0.1, 0.02, 3.5)]
    runs = []
    for _ in range(2):
        world.reset_scene("random", seed=21, num_targets=2, num_objects=12)
        outcomes = [world.execute(*p) for p in primitives]
        runs.append(([(o.success, o.object_id) for o in outcomes], world.poses()))
    assert runs[0][0] == runs[1][0]
    assert runs[0][1].keys() == runs[1][1].keys()
    for body, (position, _) in runs[0][1].items():
        np.testing.assert_allclose(position, runs[1][1][body][0], atol=1e-9)


def test_scene_file_round_trip(world, tmp_path):
    world.reset_scene("challenging", seed=8, num_targets=2, num_objects=10)
    path = tmp_path / "scene.json"
    save_scene_file(path, world.scene_specs())
    before = world.poses()
    info = world.reset_scene("file", scene_file=str(path))
    assert (info.num_targets, info.num_objects) == (2, 10)
    after = world.poses()
    for body in before:
        assert math.dist(before[body][0], after[body][0]) < 0.003


def test_invisible_hides_every_target_in_20_seeds(world):
    for seed in range(20):
        world.reset_scene("invisible", seed=seed)
        assert world.ground_truth().visible_target_pixels == 0, f"seed {seed}"
        assert len(world.scene.target_ids) == 2


def test_random_scene_shows_targets_and_no_targets_allowed(world):
    world.reset_scene("random", seed=3, num_targets=0, num_objects=10)
    gt = world.ground_truth()
    assert gt.target_ids == [] and gt.objects_remaining == 10 and gt.visible_target_pixels == 0
    world.reset_scene("random", seed=3, num_targets=3, num_objects=5)
    assert world.ground_truth().visible_target_pixels > 0


def test_render_contract(world):
    world.reset_scene("challenging", seed=2)
    frame = world.render()
    assert frame.color.shape == (cell.CAMERA_HEIGHT, cell.CAMERA_WIDTH, 3) and frame.color.dtype == np.uint8
    assert frame.depth.shape == (cell.CAMERA_HEIGHT, cell.CAMERA_WIDTH) and frame.depth.dtype == np.float32
    assert frame.segmentation.dtype == np.int32
    # The table at the image centre is CAMERA_POSITION[2] away along the optical axis.
    assert abs(float(np.median(frame.depth[frame.segmentation == world.table])) - 0.75) < 0.01
    # A target's pixels project back to its pose: back-project its mean pixel at its depth.
    target = world.scene.target_ids[0]
    rows, cols = np.nonzero(frame.segmentation == target)
    z = float(np.median(frame.depth[rows, cols]))
    k = frame.intrinsics
    ray = np.array([(cols.mean() - k[0, 2]) / k[0, 0] * z, (rows.mean() - k[1, 2]) / k[1, 1] * z, z, 1.0])
    point = frame.camera_pose @ ray
    pos = world.poses()[target][0]
    assert math.dist(point[:2], pos[:2]) < 0.01


def test_oracle_grasp_on_isolated_block_floating(world, tmp_path):
    successes = 0
    for seed in range(20):
        path, shape, dims = write_single_block(tmp_path, seed)
        world.reset_scene("file", scene_file=str(path))
        out = oracle_grasp(world, shape, dims)
        successes += out.success and out.target_grasped
    assert successes >= 19  # >= 95 %
    gt = world.ground_truth()
    assert gt.targets_removed == 1 and gt.targets_remaining == 0


def test_push_moves_the_touched_block_5cm(world, tmp_path):
    for yaw in (0.0, 1.3, 3.0, 4.5):
        path = tmp_path / "cube.json"
        cube = dict(shape="cube", dims=[0.04] * 3, position=[0.5, 0.0, 0.021], yaw=0.2)
        path.write_text(json.dumps([cube]))
        world.reset_scene("file", scene_file=str(path))
        (body, (before, _)), = world.poses().items()
        out = world.push(0.5 - 0.05 * math.cos(yaw), -0.05 * math.sin(yaw), 0.01, yaw)
        after = world.poses()[body][0]
        assert out.success
        assert math.dist(before[:2], after[:2]) >= 0.05


@pytest.mark.parametrize("kind,args,needle", [
    ("grasp", (float("nan"), 0.0, 0.01, 0.0), "not finite"),
    ("grasp", (0.9, 0.0, 0.01, 0.0), "outside the workspace"),
    ("push", (0.5, 0.0, -0.05, 0.0), "below the table"),
    ("push", (0.5, 0.0, 0.01, float("inf")), "not finite"),
    ("lift", (0.5, 0.0, 0.01, 0.0), "unknown primitive"),
])
def test_invalid_requests_are_refused_without_motion(world, kind, args, needle):
    world.reset_scene("random", seed=4)
    before = world.poses()
    steps = world.steps
    reason = world.validate_primitive(kind, *args)
    assert reason is not None and needle in reason
    out = world.execute(kind, *args)
    assert not out.success and needle in out.message
    assert world.steps == steps and world.poses() == before


def test_bad_scene_requests_raise_clear_errors(world, tmp_path):
    with pytest.raises(ValueError, match="unknown scenario"):
        world.reset_scene("tidy")
    with pytest.raises(ValueError, match="scene_file"):
        world.reset_scene("file")
    bad = tmp_path / "bad.json"
    bad.write_text("[{\"shape\": \"sphere\"}]")
    with pytest.raises(ValueError, match="unknown shape"):
        world.reset_scene("file", scene_file=str(bad))
    world.reset_scene("random", seed=1, num_targets=1, num_objects=3)
    with pytest.raises(ValueError, match="at least 10 non-target blocks"):
        world.reset_scene("invisible", num_targets=2, num_objects=4)
    with pytest.raises(ValueError, match="at most 60"):
        world.reset_scene("random", num_targets=2, num_objects=100)
    assert len(world.poses()) == 4  # a refused reset leaves the scene as it was


def test_mesh_shapes_face_outwards():
    """Inward-wound triangles render as the shape's inside (a prism looked flat and dark)."""
    import numpy as np

    from ur5_driver_sim.core.shapes import _half_cylinder_mesh, _prism_mesh

    for mesh in (_prism_mesh, _half_cylinder_mesh):
        vertices, indices = mesh((0.04, 0.05, 0.03))
        vertices = np.array(vertices)
        centre = vertices.mean(axis=0)
        for t in range(0, len(indices), 3):
            a, b, c = vertices[indices[t:t + 3]]
            assert np.dot(np.cross(b - a, c - a), (a + b + c) / 3 - centre) > 0, (mesh.__name__, t // 3)


def write_scene_with_a_target_outside(tmp_path):
    """A scene with one target inside the workspace, a second impurity at x = 0.74 m (outside
    x <= 0.724 and out of the camera's heightmap), a target near the +x edge and a product block."""
    blocks = [dict(shape="cube", dims=[0.04] * 3, position=[0.50, 0.0, 0.021], is_target=True),
              dict(shape="cube", dims=[0.03] * 3, position=[0.74, 0.0, 0.016], is_target=True),
              dict(shape="cube", dims=[0.04] * 3, position=[0.68, 0.12, 0.021], is_target=True),
              dict(shape="cube", dims=[0.04] * 3, position=[0.40, -0.10, 0.021], is_target=False)]
    path = tmp_path / "outside.json"
    path.write_text(json.dumps(blocks))
    return path


def test_targets_outside_the_workspace_are_counted_apart_at_the_start_and_when_pushed_out(world, tmp_path):
    info = world.reset_scene("file", scene_file=str(write_scene_with_a_target_outside(tmp_path)))
    assert (info.num_targets, info.targets_outside_workspace) == (3, 1)  # all of them, and those outside
    assert (info.num_objects, info.objects_outside_workspace) == (1, 0)
    gt = world.ground_truth()
    assert (gt.targets_remaining, gt.targets_out_of_workspace) == (2, 1)
    # Pushed out during an episode: the target at the +x edge, pushed along +x.
    assert world.push(0.68 - 0.05, 0.12, 0.01, 0.0).success
    gt = world.ground_truth()
    assert (gt.targets_remaining, gt.targets_out_of_workspace) == (1, 2)
    assert gt.targets_remaining + gt.targets_out_of_workspace + gt.targets_removed == info.num_targets


def test_the_fast_sim_cell_counts_targets_outside_the_workspace_apart(world, tmp_path):
    """The evaluation's cell (impurity_learning.evaluate.SimCell) counts as sim_cell's services do: the
    episode picks the target it can reach and says that one lies outside the workspace."""
    from impurity_learning.agents import SalientGraspHeuristic
    from impurity_learning.evaluate import run_episode
    from impurity_policy.core.episode import TERMINATION_REACHABLE_PICKED, EpisodeRequest

    path = tmp_path / "two_targets.json"
    products = [dict(shape="cube", dims=[0.04] * 3, position=[x, y, 0.021], is_target=False)
                for x, y in ((0.40, -0.10), (0.60, 0.10), (0.45, 0.12))]  # saliency needs some clutter
    path.write_text(json.dumps([
        dict(shape="cube", dims=[0.04] * 3, position=[0.50, 0.0, 0.021], is_target=True),
        dict(shape="cube", dims=[0.03] * 3, position=[0.74, 0.0, 0.016], is_target=True), *products]))
    summary = run_episode(world, SalientGraspHeuristic(),
                          EpisodeRequest("file", num_targets=2, scene_file=str(path), max_actions=4))
    assert (summary["targets_total"], summary["targets_outside"]) == (2, 1)
    assert summary["termination_reason"] == TERMINATION_REACHABLE_PICKED
    assert summary["targets_picked"] == 1 and not summary["completed"]
