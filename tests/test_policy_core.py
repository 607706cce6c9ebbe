"""Policy core: TCDD and rewards, rotations and poses, replay, one training step, checkpoints."""

import math

import numpy as np
import pytest
import torch

from impurity_common import cell
from impurity_policy.core import tcdd
from impurity_policy.core.network import (
    GRASP,
    PUSH,
    NetworkConfig,
    QNetwork,
    network_inputs,
    rotation_grid,
    rotation_yaws,
    valid_action_mask,
)
from impurity_policy.core.policy import (
    MODE_NONE,
    MODE_OCCLUDED_REGION,
    MODE_TARGET,
    NO_FILTERS,
    ActionFilters,
    NoActionError,
    Observation,
    Policy,
    TriedActionMemory,
    q_maps_picture,
)
from impurity_policy.core.pose import (
    action_pose,
    finger_kernel,
    grasp_clearance,
    heap_top,
    pixels_near,
    pose_to_action,
    push_end,
    pushes_ending_inside,
    pushes_passing,
    pushes_starting_on_flank,
    target_core,
    target_on_top,
    yaw_to_rotation,
)
from impurity_learning.replay import RankedReplay, Transition
from impurity_learning.trainer import Trainer, TrainerConfig
from impurity_policy.core.checkpoint import CHECKPOINT_FORMAT_VERSION, CheckpointError, load_network
from impurity_policy.core.decision import State

torch.set_num_threads(1)
ETA = cell.GRASP_OPENING
SMALL = NetworkConfig(stem_channels=8, growth=8, block_layers=(2, 2), head_channels=16)


# ---- TCDD (eqs. 2-3) and rewards ------------------------------------------------------------------
def test_isolated_target_has_tcdd_one():
    assert tcdd.tcdd((0.5, 0.0), [(0.5 + ETA, 0.0), (0.5, 0.2), (0.2, -0.2)]) == pytest.approx(1.0)
    assert tcdd.tcdd((0.5, 0.0), [(0.62, 0.0), (0.5, 0.2)]) == 1.0
    assert tcdd.tcdd((0.5, 0.0), []) == 1.0  # K = 1: alone in the scene


def test_touching_neighbours_lower_tcdd():
    # Two 4 cm blocks touching the target, one far away: (0.04 + 0.04 + eta) / (3 eta)
    alpha = tcdd.tcdd((0.5, 0.0), [(0.54, 0.0), (0.5, 0.04), (0.2, 0.2)])
    assert alpha == pytest.approx((0.04 + 0.04 + ETA) / (3 * ETA))
    assert alpha < 1.0


def test_tcdd_clips_each_distance_at_eta():
    assert tcdd.tcdd((0, 0), [(0.01, 0)], eta=0.1) == pytest.approx(0.1)
    assert tcdd.tcdd((0, 0), [(0.05, 0), (5.0, 0)], eta=0.1) == pytest.approx((0.05 + 0.1) / 0.2)
    with pytest.raises(ValueError):
        tcdd.tcdd((0, 0), [(1, 0)], eta=0.0)


def test_reward_rules():
    assert tcdd.grasp_reward(True) == 1.0 and tcdd.grasp_reward(False) == 0.0
    assert tcdd.push_reward_tcdd(0.50, 0.506) == 0.5  # increase > delta = 0.005
    assert tcdd.push_reward_tcdd(0.50, 0.504) == 0.0  # within noise
    assert tcdd.push_reward_tcdd(0.50, 0.40) == 0.0
    before = np.zeros((224, 224), np.float32)
    after = before.copy()
    after[:10, :30] = 0.03  # 300 px changed: not more than tau
    assert tcdd.push_reward_change(before, after) == 0.0
    after[10, :2] = 0.03
    assert tcdd.push_reward_change(before, after) == tcdd.NO_T_PUSH_REWARD


def test_push_outcome_tracks_the_attended_target():
    before = {1: (0.5, 0.0, 0.02), 2: (0.53, 0.0, 0.02), 3: (0.3, 0.2, 0.02)}
    separated = {1: (0.5, 0.0, 0.02), 2: (0.65, 0.0, 0.02), 3: (0.3, 0.2, 0.02)}
    outcome = tcdd.tcdd_push_outcome(1, before, separated, cell.in_workspace)
    assert outcome.alpha_after > outcome.alpha_before and outcome.reward == 0.5
    target_pushed_away = {1: (0.9, 0.0, 0.02), 2: (0.53, 0.0, 0.02), 3: (0.3, 0.2, 0.02)}
    assert tcdd.tcdd_push_outcome(1, before, target_pushed_away, cell.in_workspace).reward == 0.0
    assert tcdd.tcdd_push_outcome(None, before, separated, cell.in_workspace).reward == 0.0


# ---- rotations and poses --------------------------------------------------------------------------
@pytest.mark.parametrize("rotation", [0, 3, 4, 9])
def test_rotated_input_puts_direction_yaw_on_plus_column(rotation):
    size, radius = 112, 30
    yaw = cell.rotation_yaw(rotation)
    centre = (size - 1) / 2.0
    image = torch.zeros(1, 1, size, size)
    row, col = round(centre + radius * math.sin(yaw)), round(centre + radius * math.cos(yaw))
    image[0, 0, row - 2:row + 3, col - 2:col + 3] = 1.0
    grid = rotation_grid(rotation_yaws([rotation]), size, inverse=False)
    rotated = torch.nn.functional.grid_sample(image, grid, align_corners=False)[0, 0].numpy()
    peak_row, peak_col = np.unravel_index(np.argmax(rotated), rotated.shape)
    assert abs(peak_row - centre) <= 3 and abs(peak_col - (centre + radius)) <= 3


def test_rotation_there_and_back_is_identity_inside_the_disk():
    size = 112
    image = torch.rand(1, 1, size, size)
    image = torch.nn.functional.avg_pool2d(image, 5, 1, 2)  # smooth: bilinear resampling is exact-ish
    yaws = rotation_yaws([5])
    there = torch.nn.functional.grid_sample(image, rotation_grid(yaws, size, False), align_corners=False)
    back = torch.nn.functional.grid_sample(there, rotation_grid(yaws, size, True), align_corners=False)
    disk = valid_action_mask(size, margin=4)
    error = np.abs((back - image)[0, 0].numpy()[disk])
    assert error.mean() < 0.02 and error.max() < 0.1  # two bilinear resamplings blur a little


def test_pixel_rotation_pose_round_trip():
    rng = np.random.default_rng(0)
    height = rng.uniform(0, 0.05, (224, 224)).astype(np.float32)
    for _ in range(200):
        origin = (int(rng.integers(-56, 168)), int(rng.integers(-56, 168)))
        pixel = (int(rng.integers(0, 112)), int(rng.integers(0, 112)))
        rotation, primitive = int(rng.integers(0, 16)), int(rng.integers(0, 2))
        hm = (pixel[0] + origin[0], pixel[1] + origin[1])
        if not (0 <= hm[0] < 224 and 0 <= hm[1] < 224):
            with pytest.raises(ValueError):
                action_pose(primitive, rotation, pixel, origin, height)
            continue
        pose = action_pose(primitive, rotation, pixel, origin, height)
        assert cell.in_workspace(pose.x, pose.y)
        assert pose.yaw == pytest.approx(rotation * 2 * math.pi / 16)
        assert pose_to_action(pose.x, pose.y, pose.yaw, origin) == (rotation, pixel)
        assert cell.TABLE_Z < pose.z < cell.TABLE_Z + 0.06


def test_yaw_directions_and_heights():
    height = np.zeros((224, 224), np.float32)
    height[100:120, 100:120] = 0.05
    push0 = action_pose(PUSH, 0, (10, 10), (0, 0), height)
    assert push_end(push0)[0] == pytest.approx(push0.x + cell.PUSH_LENGTH)  # rotation 0: +x
    push4 = action_pose(PUSH, 4, (10, 10), (0, 0), height)
    assert push_end(push4)[1] == pytest.approx(push4.y + cell.PUSH_LENGTH)  # rotation 4: +y (row down)
    assert push0.z == pytest.approx(0.01)  # empty table: minimum tip height
    grasp = action_pose(GRASP, 0, (110, 110), (0, 0), height)
    assert grasp.z == pytest.approx(0.05 - 0.03)  # fingertips 3 cm below the block's top
    assert yaw_to_rotation(-math.pi / 8) == 15 and yaw_to_rotation(2 * math.pi) == 0


# ---- replay -------------------------------------------------------------------------------------
def _state(seed=0, size=112):
    rng = np.random.default_rng(seed)
    height = np.zeros((size, size), np.float32)
    height[40:70, 45:75] = 0.04
    mask = np.zeros((size, size), np.uint8)
    mask[50:62, 50:62] = 255
    color = rng.integers(0, 255, (size, size, 3), dtype=np.uint8)
    return State(color, height, mask)


def test_replay_round_trip_and_rank_priority(tmp_path):
    replay = RankedReplay(capacity=4)
    for i in range(6):  # ring: keeps the last 4
        replay.add(Transition(_state(i), PUSH if i % 2 else GRASP, i, (i, i), float(i % 2), None))
    assert len(replay) == 4
    t = replay.get(0)  # slot 0 now holds transition 4
    assert t.rotation == 4 and t.primitive == GRASP and np.array_equal(t.state.color, _state(4).color)
    assert np.allclose(t.state.height, _state(4).height, atol=1e-4)
    for index in range(4):
        replay.update_priority(index, 10.0 if index == 2 else 0.01)
    rng = np.random.default_rng(0)
    draws = [replay.sample(rng) for _ in range(400)]
    assert draws.count(2) > max(draws.count(i) for i in (0, 1, 3))
    assert all(replay.get(replay.sample(rng, primitive=PUSH)).primitive == PUSH for _ in range(20))
    assert replay.sample(rng, primitive=PUSH, positive=False) is None
    replay.save(tmp_path / "replay.pkl")
    loaded = RankedReplay.load(tmp_path / "replay.pkl")
    assert len(loaded) == 4 and loaded.get(2).rotation == replay.get(2).rotation


# ---- network, training step, checkpoints ---------------------------------------------------------
def test_network_gives_32_maps_of_crop_size():
    net = QNetwork(SMALL).eval()
    with torch.no_grad():
        q = net.q_maps(network_inputs(_state().color, _state().height, _state().mask))
    assert q.shape == (16, 2, 112, 112)


def test_one_training_step_lowers_the_loss_on_a_fixed_batch():
    trainer = Trainer(SMALL, TrainerConfig(learning_rate=1e-3), seed=0)
    batch = [Transition(_state(i), GRASP if i % 2 else PUSH, 3 * i, (55, 60), 1.0, None) for i in range(4)]

    def batch_loss():
        with torch.no_grad():
            return sum(float(trainer.loss(t, t.reward)[0]) for t in batch)

    before = batch_loss()
    trainer.optimizer.zero_grad()
    sum(trainer.loss(t, t.reward)[0] for t in batch).backward()
    trainer.optimizer.step()
    assert batch_loss() < before
    loss, td, label = trainer.update(batch[0])
    assert label == 1.0 and td >= 0 and loss >= 0


def test_target_value_uses_gamma_and_allowed_primitives():
    trainer = Trainer(SMALL, TrainerConfig(), seed=0)
    state = _state()
    assert trainer.target_value(0.5, None) == 0.5
    q = trainer.q_maps(state, use_target=True)
    expected_push = 0.5 + 0.5 * q[:, PUSH][:, valid_action_mask(112)].max()
    assert trainer.target_value(0.5, state, (PUSH,)) == pytest.approx(expected_push, rel=1e-5)


def test_checkpoint_round_trip_and_clear_rejections(tmp_path):
    trainer = Trainer(SMALL, seed=1)
    path = tmp_path / "policy.pt"
    trainer.save(path, extra={"iteration": 7})
    other = Trainer(SMALL, seed=2)
    assert other.load(path) == {"iteration": 7}
    for a, b in zip(trainer.online.parameters(), other.online.parameters(), strict=True):
        assert torch.equal(a, b)
    assert isinstance(load_network(path), QNetwork)

    data = torch.load(path, weights_only=False)
    data["format_version"] = CHECKPOINT_FORMAT_VERSION + 1
    torch.save(data, tmp_path / "future.pt")
    with pytest.raises(CheckpointError, match="format version"):
        load_network(tmp_path / "future.pt")

    data = torch.load(path, weights_only=False)
    name = next(iter(data["online"]))
    data["online"][name] = torch.zeros(3, 3)
    torch.save(data, tmp_path / "bad_shape.pt")
    with pytest.raises(CheckpointError, match="shape"):
        load_network(tmp_path / "bad_shape.pt")

    with pytest.raises(CheckpointError, match="made for network"):
        Trainer(NetworkConfig(stem_channels=8, growth=8, block_layers=(2, 2), head_channels=32)).load(path)
    with pytest.raises(CheckpointError, match="does not exist"):
        load_network(tmp_path / "missing.pt")


# ---- policy decisions ------------------------------------------------------------------------------
def _observation(mode, origin=(50, 60)):
    s = _state()
    height = np.zeros((224, 224), np.float32)
    return Observation(mode, s.color, s.height, s.mask, origin, height)


def test_policy_decides_in_base_link_and_only_pushes_without_target():
    policy = Policy(QNetwork(SMALL))
    choice = policy.decide(_observation(MODE_TARGET))
    assert choice.q_maps.shape == (16, 2, 112, 112)
    assert cell.in_workspace(choice.pose.x, choice.pose.y)
    assert choice.masks[choice.decision.primitive][choice.decision.pixel]
    for _ in range(3):
        assert policy.decide(_observation(MODE_OCCLUDED_REGION)).decision.primitive == PUSH
    with pytest.raises(NoActionError):
        policy.decide(_observation(MODE_NONE))
    # crop hanging over the map's corner: the action stays on the map
    corner = policy.decide(_observation(MODE_TARGET, origin=(-56, -56)))
    assert min(corner.pose.heightmap_pixel) >= 0
    picture = q_maps_picture(choice.q_maps, choice.masks, choice.decision)
    assert picture.shape == (112, 16 * 56, 3) and picture.dtype == np.uint8


def test_policy_rejects_malformed_crops():
    policy = Policy(QNetwork(SMALL))
    obs = _observation(MODE_TARGET)
    obs.height_crop = obs.height_crop.copy()
    obs.height_crop[0, 0] = np.nan
    with pytest.raises(NoActionError, match="NaN"):
        policy.decide(obs)
    obs = _observation(MODE_TARGET)
    obs.color_crop = obs.color_crop[:, :100]
    with pytest.raises(NoActionError, match="colour crop"):
        policy.decide(obs)


def _scene_observation(crop_origin=(100, 50), moved_pixels: int = 0) -> Observation:
    """A 224^2 scene with one 20x20 block; `moved_pixels` extra cells raised (the scene changed)."""
    height = np.zeros((224, 224), np.float32)
    height[100:120, 50:70] = 0.03
    height.flat[len(height.flat) - moved_pixels:] = 0.05 if moved_pixels else 0.0
    size = 20
    return Observation(MODE_OCCLUDED_REGION, np.zeros((size, size, 3), np.uint8),
                       np.zeros((size, size), np.float32), np.full((size, size), 255, np.uint8), crop_origin,
                       height)


def test_tried_action_memory_rules_out_failed_grasps_and_pushes_that_changed_nothing():
    memory = TriedActionMemory(radius_px=3)
    q = np.zeros((16, 2, 20, 20), np.float32)
    obs = _scene_observation()
    memory.record(GRASP, (110, 60), 3, obs.height, success=False)  # crop pixel (10, 10)
    suppressed = memory.suppress(q, obs)
    for rotation in (3, 11):  # a grasp: its rotation and the opposite one (the same closing axis)
        assert np.isneginf(suppressed[rotation, GRASP, 10, 10])
        assert np.isneginf(suppressed[rotation, GRASP, 13, 10])
        assert suppressed[rotation, GRASP, 14, 10] == 0 and suppressed[rotation, GRASP, 10, 14] == 0
    assert np.isfinite(suppressed[[r for r in range(16) if r not in (3, 11)], GRASP]).all()
    assert np.isfinite(suppressed[:, PUSH]).all() and np.isfinite(q).all()  # pushes untouched, input kept
    moved = _scene_observation(moved_pixels=tcdd.CHANGE_PIXELS_TAU + 1)
    assert np.isneginf(memory.suppress(q, moved)[3, GRASP, 10, 10])  # a failed grasp stays ruled out...
    memory.record(PUSH, (105, 55), 6, obs.height, success=True)  # crop pixel (5, 5)
    suppressed = memory.suppress(q, _scene_observation(moved_pixels=tcdd.CHANGE_PIXELS_TAU))
    assert np.isfinite(suppressed[:, GRASP]).all()  # ... until a push
    assert np.isneginf(suppressed[6, PUSH, 5, 5]) and np.isneginf(suppressed[6, PUSH, 8, 5])
    assert np.isfinite(suppressed[[r for r in range(16) if r != 6], PUSH]).all()  # a push: its direction
    assert memory.suppress(q, moved) is q and not memory.tried  # the push moved something after all
    memory.record(GRASP, (110, 60), 3, obs.height, success=False)
    memory.record(GRASP, (30, 30), 5, obs.height, success=True)  # something was lifted
    assert not memory.tried


def test_tried_action_memory_forces_a_push_after_failed_grasps_in_a_row():
    q = np.zeros((16, 2, 20, 20), np.float32)
    obs = _scene_observation()
    memory = TriedActionMemory(radius_px=3, failed_grasps_before_push=2)
    memory.record(GRASP, (110, 60), 3, obs.height, success=False)
    assert np.isfinite(memory.suppress(q, obs)[0, GRASP, 0, 0])  # one failure: other grasps stay open
    memory.record(GRASP, (100, 50), 7, obs.height, success=False)
    suppressed = memory.suppress(q, obs)
    assert np.isneginf(suppressed[:, GRASP]).all() and np.isfinite(suppressed[:, PUSH]).all()
    memory.record(PUSH, (105, 55), 6, obs.height, success=True)
    assert np.isfinite(memory.suppress(q, obs)[:, GRASP]).all()  # the push reopens grasping
    never = TriedActionMemory(radius_px=3, failed_grasps_before_push=0)
    for pixel in ((110, 60), (100, 50), (95, 45)):
        never.record(GRASP, pixel, 3, obs.height, success=False)
    assert np.isfinite(never.suppress(q, obs)[0, GRASP, 0, 0])


def _block(height, centre, half_px, top):
    height[centre[0] - half_px:centre[0] + half_px + 1, centre[1] - half_px:centre[1] + half_px + 1] = top


def test_finger_kernel_puts_the_pads_where_the_open_fingers_land():
    kernel = finger_kernel(0.0)  # closing along +x = +column
    centre = kernel.shape[0] // 2
    pad_cols = np.flatnonzero(kernel[centre]) - centre
    inner, outer = cell.GRASP_OPENING / 2, cell.GRASP_OPENING / 2 + cell.FINGER_THICKNESS
    res = cell.HEIGHTMAP_RESOLUTION
    assert np.all((np.abs(pad_cols) * res >= inner - 1e-9) & (np.abs(pad_cols) * res <= outer + 1e-9))
    assert set(np.sign(pad_cols)) == {-1, 1} and not kernel[:, centre].any()
    pad_rows = np.flatnonzero(kernel[:, centre + pad_cols.max()]) - centre
    assert np.abs(pad_rows).max() * res <= cell.FINGER_WIDTH / 2 + 1e-9
    np.testing.assert_array_equal(finger_kernel(math.pi / 2), kernel.T)  # closing along +y = +row


def test_grasp_clearance_on_hand_built_layouts():
    height = np.zeros((224, 224), np.float32)
    _block(height, (112, 112), 6, 0.026)  # a 26 mm cube alone
    clear = grasp_clearance(height, (56, 56), 112)
    assert clear.shape == (16, 112, 112) and clear[:, 56, 56].all()
    # a taller neighbour 4 mm away along +x: grasps closing along x land a pad on it, along y do not
    _block(height, (112, 112 + 6 + 2 + 7), 6, 0.035)
    clear = grasp_clearance(height, (56, 56), 112)
    assert not clear[0, 56, 56] and not clear[8, 56, 56]  # rotation r and r + 8 close along one axis
    assert clear[4, 56, 56] and clear[12, 56, 56]
    # wedged between neighbours on all four sides: no grasp is clear
    for d_row, d_col in ((0, -15), (15, 0), (-15, 0), (15, 15), (-15, -15), (15, -15), (-15, 15)):
        _block(height, (112 + d_row, 112 + d_col), 6, 0.035)
    assert not grasp_clearance(height, (56, 56), 112)[:, 56, 56].any()
    # off the map counts as table: a crop hanging over the corner is computed, not an error
    assert grasp_clearance(height, (-56, -56), 112).shape == (16, 112, 112)


def test_policy_pushes_when_no_grasp_is_clear_and_clearance_can_be_turned_off():
    torch.manual_seed(0)
    height = np.zeros((224, 224), np.float32)
    for d_row in (-15, 0, 15):
        for d_col in (-15, 0, 15):
            _block(height, (112 + d_row, 112 + d_col), 6, 0.035)  # target wedged in a 3x3 packing
    obs = Observation(MODE_TARGET, np.full((112, 112, 3), 150, np.uint8), height[56:168, 56:168].copy(),
                      np.full((112, 112), 255, np.uint8), (56, 56), height)
    q = np.zeros((16, 2, 112, 112), np.float32)
    q[:, GRASP, 50:62, 50:62] = 1.0  # the network would rather grasp the wedged target
    assert Policy(QNetwork(SMALL), filters=NO_FILTERS).decide(obs, q=q).decision.primitive == GRASP
    assert Policy(QNetwork(SMALL)).decide(obs, q=q).decision.primitive == PUSH


def test_grasp_clearance_keeps_the_palm_off_tall_piles():
    height = np.zeros((224, 224), np.float32)
    _block(height, (112, 112), 6, 0.026)  # a 26 mm cube
    _block(height, (112, 142), 3, 0.08)  # an 80 mm pile 54-66 mm away along +x: past the pads' reach
    clear = grasp_clearance(height, (56, 56), 112)
    assert not clear[0, 56, 56]  # closing along x, the palm (140 mm long) comes down on the pile
    assert clear[4, 56, 56]  # closing along y, the palm (40 mm wide) passes beside it
    _block(height, (112, 142), 3, 0.055)  # lower than the fingers are long: the tips still get down
    assert grasp_clearance(height, (56, 56), 112)[0, 56, 56]


def test_pushes_passing_a_point_and_the_heap_top():
    passing = pushes_passing((56, 56), 112, radius_px=5)
    push_px = round(cell.PUSH_LENGTH / cell.HEIGHTMAP_RESOLUTION)  # 50 px
    assert passing[0, 56, 20]  # 36 px before the point, pushing towards it (+col)
    assert not passing[0, 56, 56 - push_px - 6]  # stops short of it
    assert not passing[8, 56, 20]  # pushing away from it
    assert passing[8, 56, 90] and passing[4, 20, 56]  # from the other side; along +row
    assert not passing[0, 70, 30]  # passes 14 px beside it
    height = np.zeros((112, 112), np.float32)
    _block(height, (30, 80), 10, 0.02)
    _block(height, (30, 80), 4, 0.05)  # a pile: its top is the highest point
    _block(height, (2, 2), 1, 0.2)  # a tall speck outside the action disk does not count
    assert heap_top(height, valid_action_mask(112), 6.0) == (30, 80)


def test_pushes_ending_inside_the_workspace():
    inside = pushes_ending_inside((0, 0), 224, margin=0.06)  # the whole heightmap = the workspace
    push_px, margin_px = 50, 30  # 10 cm push, 6 cm margin at 2 mm / px
    assert inside[0, 112, 112] and inside[8, 112, 112]  # from the centre, any direction
    assert not inside[0, 112, 224 - push_px - margin_px + 2]  # +x: ends within 6 cm of the edge
    assert inside[0, 112, 224 - push_px - margin_px - 2] and inside[8, 112, 224 - push_px - margin_px + 2]
    assert not inside[4, 224 - push_px - margin_px + 2, 112]  # +y likewise


def test_policy_filters_grasps_off_the_target_and_pushes_away_from_the_heap():
    height = np.zeros((224, 224), np.float32)
    _block(height, (112, 112), 6, 0.026)  # the target, free
    _block(height, (112, 140), 6, 0.026)  # a free neighbour, not the target
    mask = np.zeros((112, 112), np.uint8)
    mask[50:63, 50:63] = 255
    obs = Observation(MODE_TARGET, np.full((112, 112, 3), 150, np.uint8), height[56:168, 56:168].copy(), mask,
                      (56, 56), height)
    q = np.zeros((16, 2, 112, 112), np.float32)
    q[:, PUSH] = -1.0
    q[:, GRASP, 56, 84] = 1.0  # the network prefers the neighbour
    decision = Policy(QNetwork(SMALL)).decide(obs, q=q).decision
    assert decision.primitive == GRASP and mask[decision.pixel]
    assert Policy(QNetwork(SMALL), filters=NO_FILTERS).decide(obs, q=q).decision.pixel == (56, 84)
    occluded = Observation(MODE_OCCLUDED_REGION, obs.color_crop, obs.height_crop, np.full_like(mask, 255),
                           (56, 56), height)
    q[:, PUSH] = 0.0
    q[0, PUSH, 100, 10] = 1.0  # the network prefers a push far from the pile
    push = Policy(QNetwork(SMALL)).decide(occluded, q=q).decision
    assert push.primitive == PUSH
    assert pushes_passing(heap_top(occluded.height_crop, valid_action_mask(112), 6.0), 112, 10)[
        push.rotation][push.pixel]


def _covered_heap(top=0.09):
    """A 50 mm slab 41 px wide with a pile on its middle, centred in a 224 px map (crop origin 56, 56)."""
    height = np.zeros((224, 224), np.float32)
    _block(height, (112, 112), 20, 0.05)
    _block(height, (112, 112), 5, top)
    return height


def test_pushes_starting_on_the_heap_flank():
    crop = _covered_heap()[56:168, 56:168]
    flank = pushes_starting_on_flank(crop, (56, 56), (0.5, 0.8), radius_px=3)
    assert flank[56, 40] and flank[40, 70]  # on the slab beside the pile: 50 mm of 90
    assert not flank[56, 56] and not flank[56, 52]  # on the pile, or within 3 px of it
    assert not flank[56, 10]  # on the table
    assert not pushes_starting_on_flank(crop, (56, 56), (0.6, 0.8), radius_px=3).any()  # 56 % is below


def test_policy_starts_occluded_region_pushes_on_the_heap_flank():
    height = _covered_heap()
    occluded = Observation(MODE_OCCLUDED_REGION, np.full((112, 112, 3), 150, np.uint8),
                           height[56:168, 56:168].copy(), np.full((112, 112), 255, np.uint8), (56, 56),
                           height)
    q = np.zeros((16, 2, 112, 112), np.float32)
    q[0, PUSH, 56, 56] = 1.0  # the network prefers to push from the top of the pile
    q[0, PUSH, 56, 40] = 0.5  # from the slab, through the pile
    assert Policy(QNetwork(SMALL)).decide(occluded, q=q).decision.pixel == (56, 40)
    no_band = ActionFilters(occluded_push_start_band=None)
    assert Policy(QNetwork(SMALL), filters=no_band).decide(occluded, q=q).decision.pixel == (56, 56)
    # a heap without a flank in the band (a flat block): the rule gives way instead of leaving no push
    flat = np.zeros((224, 224), np.float32)
    _block(flat, (112, 112), 20, 0.05)
    flat_obs = Observation(MODE_OCCLUDED_REGION, occluded.color_crop, flat[56:168, 56:168].copy(),
                           occluded.mask, (56, 56), flat)
    assert Policy(QNetwork(SMALL)).decide(flat_obs, q=q).decision.primitive == PUSH


def test_target_on_top_and_pixels_near_a_mask():
    height = np.zeros((112, 112), np.float32)
    _block(height, (56, 56), 6, 0.026)  # the target
    _block(height, (56, 70), 6, 0.045)  # a taller block lying against it (+col side)
    mask = np.zeros((112, 112), np.uint8)
    mask[50:63, 50:63] = 255
    on_top = target_on_top(height, mask, radius_px=3, tolerance=0.005)
    assert on_top[56, 52] and on_top[56, 56]  # the grasp height would come from the target
    assert not on_top[56, 61]  # within 3 px of the taller block: the grasp would close on that
    assert target_on_top(height, mask, radius_px=3, tolerance=0.03)[56, 61]
    near = pixels_near(mask, 10)
    assert near[56, 72] and near[40, 56] and not near[56, 74] and not near[30, 30]
    assert (pixels_near(mask, 0) == (mask > 0)).all()


def test_policy_pushes_next_to_the_target_and_grasps_where_it_is_on_top():
    height = np.zeros((224, 224), np.float32)
    _block(height, (112, 112), 6, 0.026)  # the target, free
    _block(height, (112, 126), 6, 0.045)  # a taller block against its +col side
    mask = np.zeros((112, 112), np.uint8)
    mask[50:63, 50:63] = 255
    obs = Observation(MODE_TARGET, np.full((112, 112, 3), 150, np.uint8), height[56:168, 56:168].copy(), mask,
                      (56, 56), height)
    no_clearance = ActionFilters(finger_clearance=False, grasp_core_depth_px=None)
    q = np.full((16, 2, 112, 112), -1.0, np.float32)
    q[4, GRASP, 56, 61] = 1.0  # the net's grasp: by the taller block, which it would lift
    q[4, GRASP, 56, 54] = 0.5
    assert Policy(QNetwork(SMALL), filters=no_clearance).decide(obs, q=q).decision.pixel == (56, 54)
    assert Policy(QNetwork(SMALL), filters=NO_FILTERS).decide(obs, q=q).decision.pixel == (56, 61)
    q[:, GRASP] = -2.0
    q[8, PUSH, 56, 100] = 1.0  # the net's push: far from the target
    q[8, PUSH, 56, 66] = 0.5  # from beside the target
    assert Policy(QNetwork(SMALL), filters=no_clearance).decide(obs, q=q).decision.pixel == (56, 66)
    assert Policy(QNetwork(SMALL), filters=NO_FILTERS).decide(obs, q=q).decision.pixel == (56, 100)


def test_target_core_is_the_middle_of_the_mask():
    mask = np.zeros((112, 112), np.uint8)
    mask[50:63, 50:63] = 255  # 13 px square: 7 px deep at its centre
    core = target_core(mask, 1.0)
    assert core[56, 56] and not core[56, 52] and not core[40, 40]
    assert core.sum() < 13 * 13 / 4
    assert (target_core(mask, 100.0) == (mask > 0)).all()


def test_policy_grasps_the_middle_of_a_free_target():
    height = np.zeros((224, 224), np.float32)
    _block(height, (112, 112), 6, 0.026)  # the target, free
    mask = np.zeros((112, 112), np.uint8)
    mask[50:63, 50:63] = 255
    obs = Observation(MODE_TARGET, np.full((112, 112, 3), 150, np.uint8), height[56:168, 56:168].copy(), mask,
                      (56, 56), height)
    q = np.full((16, 2, 112, 112), -1.0, np.float32)
    q[:, PUSH] = -2.0
    q[4, GRASP, 56, 51] = 1.0  # the net's grasp: at the target's edge
    q[4, GRASP, 56, 56] = 0.5
    middle = ActionFilters(finger_clearance=False)
    assert Policy(QNetwork(SMALL), filters=middle).decide(obs, q=q).decision.pixel == (56, 56)
    assert Policy(QNetwork(SMALL), filters=NO_FILTERS).decide(obs, q=q).decision.pixel == (56, 51)
    q[:, GRASP, 55:58, 55:58] = -np.inf  # e.g. tried already: no grasp at the edge, a push instead
    assert Policy(QNetwork(SMALL), filters=middle).decide(obs, q=q).decision.primitive == PUSH


def test_a_greedy_policy_does_not_repeat_a_failed_grasp():
    torch.manual_seed(0)
    policy = Policy(QNetwork())
    color = np.full((112, 112, 3), 150, np.uint8)
    height = np.zeros((112, 112), np.float32)
    height[40:70, 40:70] = 0.03
    mask = np.zeros((112, 112), np.uint8)
    mask[45:65, 45:65] = 255
    obs = Observation(MODE_TARGET, color, height, mask, (0, 0), np.pad(height, ((0, 112), (0, 112))))
    memory = TriedActionMemory()
    q = policy.q_maps(obs)
    q[:, PUSH] = -np.inf  # only grasps compete
    first = policy.decide(obs, q=memory.suppress(q, obs))
    assert first.decision.primitive == GRASP
    memory.record(GRASP, first.pose.heightmap_pixel, first.pose.rotation, obs.height, success=False)
    second = policy.decide(obs, q=memory.suppress(q, obs))
    assert second.decision.primitive == GRASP
    same_axis = second.pose.rotation % 8 == first.pose.rotation % 8
    distance = math.dist(second.pose.heightmap_pixel, first.pose.heightmap_pixel)
    assert not (same_axis and distance <= memory.radius_px)
