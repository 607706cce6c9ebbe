"""Policy core: rotations and poses, the pose geometry behind the rules, the network and its checkpoints,
the policy's decisions; also the learning pieces they were trained with (TCDD and rewards, replay, one
training step). The test-time rules: test_rules.py."""

import math

import numpy as np
import pytest
import torch
from height_scenes import block, covered_heap

from impurity_common import cell
from impurity_common.grid import HeightmapGrid
from impurity_learning import tcdd
from impurity_learning.replay import RankedReplay, Transition
from impurity_learning.trainer import Trainer, TrainerConfig
from impurity_policy.core.checkpoint import CHECKPOINT_FORMAT_VERSION, CheckpointError, load_network
from impurity_policy.core.decision import State
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
    NoActionError,
    Observation,
    Policy,
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
    pushes_not_toward_near_edge,
    pushes_passing,
    pushes_starting_on_flank,
    target_core,
    target_on_top,
    yaw_to_rotation,
)
from impurity_policy.core.rules import RulePipeline

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


# ---- pose geometry the rules are built on (rules.py; the rules themselves: test_rules.py) ----------

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
    block(height, (112, 112), 6, 0.026)  # a 26 mm cube alone
    clear = grasp_clearance(height, (56, 56), 112)
    assert clear.shape == (16, 112, 112) and clear[:, 56, 56].all()
    # a taller neighbour 4 mm away along +x: grasps closing along x land a pad on it, along y do not
    block(height, (112, 112 + 6 + 2 + 7), 6, 0.035)
    clear = grasp_clearance(height, (56, 56), 112)
    assert not clear[0, 56, 56] and not clear[8, 56, 56]  # rotation r and r + 8 close along one axis
    assert clear[4, 56, 56] and clear[12, 56, 56]
    # wedged between neighbours on all four sides: no grasp is clear
    for d_row, d_col in ((0, -15), (15, 0), (-15, 0), (15, 15), (-15, -15), (15, -15), (-15, 15)):
        block(height, (112 + d_row, 112 + d_col), 6, 0.035)
    assert not grasp_clearance(height, (56, 56), 112)[:, 56, 56].any()
    # off the map counts as table: a crop hanging over the corner is computed, not an error
    assert grasp_clearance(height, (-56, -56), 112).shape == (16, 112, 112)


def test_grasp_clearance_keeps_the_palm_off_tall_piles():
    height = np.zeros((224, 224), np.float32)
    block(height, (112, 112), 6, 0.026)  # a 26 mm cube
    block(height, (112, 142), 3, 0.08)  # an 80 mm pile 54-66 mm away along +x: past the pads' reach
    clear = grasp_clearance(height, (56, 56), 112)
    assert not clear[0, 56, 56]  # closing along x, the palm (140 mm long) comes down on the pile
    assert clear[4, 56, 56]  # closing along y, the palm (40 mm wide) passes beside it
    block(height, (112, 142), 3, 0.055)  # lower than the fingers are long: the tips still get down
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
    block(height, (30, 80), 10, 0.02)
    block(height, (30, 80), 4, 0.05)  # a pile: its top is the highest point
    block(height, (2, 2), 1, 0.2)  # a tall speck outside the action disk does not count
    assert heap_top(height, valid_action_mask(112), 6.0) == (30, 80)


def test_pushes_ending_inside_the_workspace():
    inside = pushes_ending_inside((0, 0), 224, margin=0.06)  # the whole heightmap = the workspace
    push_px, margin_px = 50, 30  # 10 cm push, 6 cm margin at 2 mm / px
    assert inside[0, 112, 112] and inside[8, 112, 112]  # from the centre, any direction
    assert not inside[0, 112, 224 - push_px - margin_px + 2]  # +x: ends within 6 cm of the edge
    assert inside[0, 112, 224 - push_px - margin_px - 2] and inside[8, 112, 224 - push_px - margin_px + 2]
    assert not inside[4, 224 - push_px - margin_px + 2, 112]  # +y likewise



def test_pushes_not_toward_a_near_edge():
    kept = pushes_not_toward_near_edge((0, 0), 224, margin=0.12)  # the whole heightmap = the workspace
    push_px, margin_px = 50, 60  # 10 cm push, 12 cm margin at 2 mm / px
    assert kept.all(axis=0)[112, 112]  # from the centre, any direction ends 12 cm from every edge
    col = 224 - push_px - margin_px  # +x from here ends 12 cm (less half a pixel) from the +x edge
    assert kept[0, 112, col - 2] and not kept[0, 112, col + 2]
    assert kept[4, 112, 220] and kept[12, 112, 220]  # along that edge (+y, -y): kept however close
    assert kept[8, 112, 220]  # away from it
    assert not kept[4, 220, 112] and kept[12, 220, 112]  # by the +y edge: towards it no, away yes
    # 67.5 degrees (rotation 3) from col 150 ends 9.3 cm from the +x edge: its component towards it is 0.38 >=
    # EDGE_APPROACH, so it counts as heading there; +y (rotation 4) from the same pixel does not
    assert not kept[3, 112, 150] and kept[4, 112, 150]


def test_pushes_starting_on_the_heap_flank():
    crop = covered_heap()[56:168, 56:168]
    flank = pushes_starting_on_flank(crop, (56, 56), (0.5, 0.8), radius_px=3)
    assert flank[56, 40] and flank[40, 70]  # on the slab beside the pile: 50 mm of 90
    assert not flank[56, 56] and not flank[56, 52]  # on the pile, or within 3 px of it
    assert not flank[56, 10]  # on the table
    assert not pushes_starting_on_flank(crop, (56, 56), (0.6, 0.8), radius_px=3).any()  # 56 % is below


def test_target_on_top_and_pixels_near_a_mask():
    height = np.zeros((112, 112), np.float32)
    block(height, (56, 56), 6, 0.026)  # the target
    block(height, (56, 70), 6, 0.045)  # a taller block lying against it (+col side)
    mask = np.zeros((112, 112), np.uint8)
    mask[50:63, 50:63] = 255
    on_top = target_on_top(height, mask, radius_px=3, tolerance=0.005)
    assert on_top[56, 52] and on_top[56, 56]  # the grasp height would come from the target
    assert not on_top[56, 61]  # within 3 px of the taller block: the grasp would close on that
    assert target_on_top(height, mask, radius_px=3, tolerance=0.03)[56, 61]
    near = pixels_near(mask, 10)
    assert near[56, 72] and near[40, 56] and not near[56, 74] and not near[30, 30]
    assert (pixels_near(mask, 0) == (mask > 0)).all()


def test_target_core_is_the_middle_of_the_mask():
    mask = np.zeros((112, 112), np.uint8)
    mask[50:63, 50:63] = 255  # 13 px square: 7 px deep at its centre
    core = target_core(mask, 1.0)
    assert core[56, 56] and not core[56, 52] and not core[40, 40]
    assert core.sum() < 13 * 13 / 4
    assert (target_core(mask, 100.0) == (mask > 0)).all()


# ---- policy decisions ------------------------------------------------------------------------------
def _observation(mode, origin=(50, 60)):
    s = _state()
    height = np.zeros((224, 224), np.float32)
    return Observation(mode, s.color, s.height, s.mask, origin, height)


def test_policy_decides_in_base_link_and_only_pushes_without_target():
    policy = Policy(QNetwork(SMALL), rules=RulePipeline.preset("cell"))
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
    policy = Policy(QNetwork(SMALL), rules=RulePipeline.preset("cell"))
    obs = _observation(MODE_TARGET)
    obs.height_crop = obs.height_crop.copy()
    obs.height_crop[0, 0] = np.nan
    with pytest.raises(NoActionError, match="NaN"):
        policy.decide(obs)
    obs = _observation(MODE_TARGET)
    obs.color_crop = obs.color_crop[:, :100]
    with pytest.raises(NoActionError, match="colour crop"):
        policy.decide(obs)


def test_a_policy_without_rules_takes_the_argmax_over_the_valid_actions():
    policy = Policy(QNetwork(SMALL))  # rules: none, the paper's method
    obs = _observation(MODE_TARGET)
    q = np.zeros((16, 2, 112, 112), np.float32)
    q[3, GRASP, 0, 0] = 5.0  # outside the crop's inscribed disk: not every rotation sees it
    q[2, GRASP, 20, 20] = 4.0  # on the table: grasps need an object under them
    q[5, PUSH, 60, 60] = 2.0
    q[7, GRASP, 56, 56] = 1.0
    choice = policy.decide(obs, q=q)
    assert (choice.decision.primitive, choice.decision.rotation, choice.decision.pixel) == (PUSH, 5, (60, 60))
    assert choice.q_maps is q  # nothing ruled out
    q[5, PUSH, 60, 60] = 0.0
    assert policy.decide(obs, q=q).decision.pixel == (56, 56)


def test_policy_poses_lie_on_the_observations_grid():
    policy = Policy(QNetwork(SMALL))
    q = np.zeros((16, 2, 112, 112), np.float32)
    q[4, GRASP, 56, 56] = 1.0
    default = policy.decide(_observation(MODE_TARGET), q=q).pose
    obs = _observation(MODE_TARGET)
    obs.grid = HeightmapGrid(x_min=0.3, x_max=0.748, y_min=-0.2, y_max=0.248, table_z=0.05)
    shifted = policy.decide(obs, q=q).pose
    assert shifted.heightmap_pixel == default.heightmap_pixel == (56 + 50, 56 + 60)
    assert shifted.x - default.x == pytest.approx(0.3 - cell.WORKSPACE_X[0])
    assert shifted.y - default.y == pytest.approx(-0.2 - cell.WORKSPACE_Y[0])
    assert shifted.z - default.z == pytest.approx(0.05 - cell.TABLE_Z)
