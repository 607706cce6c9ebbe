"""CellWorld: the simulated cell (table, blocks, gripper or UR5, overhead camera) behind one small API.

    world = CellWorld(mode="floating")          # "arm": the full UR5 carries the gripper
    info = world.reset_scene("random", seed=3)  # seeded: the same seed gives the same scene
    frame = world.render()                      # colour, metric depth, body-id segmentation
    out = world.grasp(x, y, z, yaw)             # or world.push(...); invalid requests never move

Not thread-safe (PyBullet is not): the node serialises calls with one lock. Every reset rebuilds the
physics world from scratch so a scene depends only on its seed, never on what ran before.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import pybullet
from pybullet_utils import bullet_client

from impurity_common import cell
from ur5_motion.ur5_kinematics import IKError

from . import appearance, config, scenes
from .camera import CameraFrame, CameraModel
from .gripper import FloatingCarrier, MotionCancelled
from .primitives import GRASP, PUSH, PrimitiveOutcome, execute_grasp, execute_push, validate_primitive
from .shapes import BlockSpec, spawn_block

MODES = ("floating", "arm")
MAX_SCENE_ATTEMPTS = 12
FALLEN_Z = cell.TABLE_Z - 0.05  # below this a block has left the table
ABORT_RETREAT_MAX_Z = 0.25  # m: an aborted primitive lifts the gripper at most this high (arm reach)


@dataclass
class SceneInfo:
    scenario: str
    seed: int
    num_targets: int  # in the scene, in and outside the workspace
    num_objects: int
    target_ids: list
    object_ids: list
    attempts: int = 1
    generation_seconds: float = 0.0
    targets_outside_workspace: int = 0  # of num_targets: outside the workspace or off the table
    objects_outside_workspace: int = 0
    palette: str = "blocks"  # appearance.Palette name
    piece_heights: tuple | None = None  # m, lowest and highest (reset_scene's); None: the shapes' own sizes


@dataclass
class GroundTruth:
    target_ids: list
    object_ids: list  # non-targets
    targets_remaining: int  # in the workspace
    objects_remaining: int
    targets_removed: int  # grasped into the impurity bin
    non_targets_removed: int  # false rejects
    visible_target_pixels: int
    poses: dict = field(default_factory=dict)  # id -> (position, quaternion), bodies still in the world
    targets_out_of_workspace: int = 0  # outside the workspace or off the table (from the start or pushed)
    objects_out_of_workspace: int = 0


class CellWorld:
    def __init__(self, mode: str = "floating", gui: bool = False, camera: CameraModel | None = None,
                 solver_iterations: int = config.SOLVER_ITERATIONS,
                 depth_noise_std: float = 0.0):
        if mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
        self.mode = mode
        self.camera = camera or CameraModel()
        self.palette = appearance.palette_named("")  # set by reset_scene
        self.solver_iterations = int(solver_iterations)
        self.depth_noise_std = float(depth_noise_std)
        self.pb = bullet_client.BulletClient(connection_mode=pybullet.GUI if gui else pybullet.DIRECT)
        self._noise_rng = np.random.default_rng(0)
        self.step_hook = None  # called every physics step (e.g. to publish joint states)
        self.cancel_check = None  # returns True to stop the running motion
        self.scene: SceneInfo | None = None
        self.specs: dict[int, BlockSpec] = {}
        self.removed: dict[int, bool] = {}  # body id -> was a target
        self.steps = 0
        self._build_world()
        self.reset_scene("empty")

    # ---------------------------------------------------------------------------------------- world
    def close(self) -> None:
        try:
            self.pb.disconnect()
        except pybullet.error:
            pass

    def _build_world(self) -> None:
        pb = self.pb
        pb.resetSimulation()
        pb.setGravity(0, 0, config.GRAVITY)
        pb.setPhysicsEngineParameter(fixedTimeStep=config.TIME_STEP,
                                     numSolverIterations=self.solver_iterations,
                                     deterministicOverlappingPairs=1)
        half = config.TABLE_HALF_EXTENTS
        table_col = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=half)
        table_vis = pb.createVisualShape(pb.GEOM_BOX, halfExtents=half,
                                         rgbaColor=list(config.TABLE_COLOR) + [1])
        self.table = pb.createMultiBody(0, table_col, table_vis, basePosition=(
            config.TABLE_CENTER_XY[0], config.TABLE_CENTER_XY[1], cell.TABLE_Z - half[2]))
        pb.changeDynamics(self.table, -1, lateralFriction=config.TABLE_LATERAL_FRICTION)
        if self.mode == "floating":
            self.carrier = FloatingCarrier(pb, self.step)
        else:
            from .ur5 import ArmCarrier  # only the driver needs the arm
            self.carrier = ArmCarrier(pb, self.step)
        self.specs, self.removed = {}, {}

    def step(self) -> None:
        """One physics step; runs the step hook and raises MotionCancelled when asked to stop."""
        self.pb.stepSimulation()
        self.steps += 1
        if self.step_hook is not None:
            self.step_hook(self)
        if self.cancel_check is not None and self.cancel_check():
            raise MotionCancelled()

    def _settle(self, max_steps: int = config.SETTLE_MAX_STEPS) -> int:
        bodies = list(self.specs)
        for i in range(1, max_steps + 1):
            self.pb.stepSimulation()
            if i % config.SETTLE_CHECK_EVERY == 0:
                speeds = [np.linalg.norm(self.pb.getBaseVelocity(b)[0]) for b in bodies]
                if not speeds or max(speeds) < config.SETTLE_SPEED:
                    return i
        return max_steps

    # ---------------------------------------------------------------------------------------- scenes
    def reset_scene(self, scenario: str = "random", seed: int = 0, num_targets: int = -1,
                    num_objects: int = -1, scene_file: str | None = None,
                    palette: str | appearance.Palette = "", piece_heights: tuple | None = None) -> SceneInfo:
        """Build a new scene under `palette` (a Palette, or a name for appearance.palette_named: "" is
        the default). piece_heights (m, lowest and highest; random and challenging only): every piece stands
        upright with a height in that range (scenes.random_layout); None: the shapes' own sizes. Raises
        ValueError for an unknown scenario or palette, impossible counts or heights."""
        if scenario not in scenes.SCENARIOS:
            raise ValueError(f"unknown scenario {scenario!r} (expected one of {scenes.SCENARIOS})")
        if piece_heights is not None:
            scenes.check_piece_heights(piece_heights)
            if scenario not in scenes.UPRIGHT_LAYOUTS + ("empty",):
                raise ValueError(f"piece_heights applies to the {' and '.join(scenes.UPRIGHT_LAYOUTS)} "
                                 f"scenarios, not {scenario!r}")
        chosen = palette if isinstance(palette, appearance.Palette) else appearance.palette_named(palette)
        started = time.perf_counter()
        if scenario == "file":
            if not scene_file:
                raise ValueError("scenario 'file' needs scene_file")
            file_specs = scenes.load_scene_file(scene_file)
            n_targets = sum(s.is_target for s in file_specs)
            n_objects = len(file_specs) - n_targets
        else:
            n_targets, n_objects = scenes.resolve_counts(scenario, num_targets, num_objects)
        self.palette = chosen
        rng = np.random.default_rng(seed)
        colours = chosen.colours(seed)
        attempts = 0
        for attempts in range(1, MAX_SCENE_ATTEMPTS + 1):  # noqa: B007 (reported in SceneInfo)
            self._build_world()
            if scenario == "file":
                self._spawn(file_specs)
                self._settle()
                break
            if scenario == "empty" or n_targets + n_objects == 0:
                break
            if scenario == "random":
                self._spawn(scenes.random_layout(rng, n_targets, n_objects, colours, piece_heights))
                self._settle()
                if self._keep_inside_workspace(rng, upright=piece_heights is not None):
                    break
            elif scenario == "challenging":
                self._spawn(scenes.challenging_layout(rng, n_targets, n_objects, colours, piece_heights))
                self._settle(200)
                if self._all_in_workspace():
                    break
            elif scenario == "invisible":
                self._spawn(scenes.invisible_layout(rng, n_targets, n_objects, colours))
                self._settle()
                if self._keep_inside_workspace(rng) and self.visible_target_pixels() == 0:
                    break
        else:
            raise RuntimeError(f"{scenario} scene with seed {seed}: invariants not met after "
                               f"{MAX_SCENE_ATTEMPTS} attempts")
        self.carrier.go_home()
        targets = [b for b, s in self.specs.items() if s.is_target]
        others = [b for b, s in self.specs.items() if not s.is_target]
        self.scene = SceneInfo(scenario, int(seed), len(targets), len(others), targets, others, attempts,
                               time.perf_counter() - started,
                               targets_outside_workspace=sum(not self._in_workspace(b) for b in targets),
                               objects_outside_workspace=sum(not self._in_workspace(b) for b in others),
                               palette=chosen.name,
                               piece_heights=tuple(piece_heights) if piece_heights is not None else None)
        return self.scene

    def _spawn(self, specs) -> None:
        for spec in specs:
            self.specs[spawn_block(self.pb, spec)] = spec

    def _in_workspace(self, body: int) -> bool:
        pos = self.pb.getBasePositionAndOrientation(body)[0]
        return cell.in_workspace(pos[0], pos[1]) and pos[2] > FALLEN_Z

    def _all_in_workspace(self) -> bool:
        return all(self._in_workspace(b) for b in self.specs)

    def _keep_inside_workspace(self, rng, rounds: int = 4, upright: bool = False) -> bool:
        """Random drops: re-drop any block that bounced out of the workspace (upright: with a random yaw
        only, as pieces of a given height are dropped)."""
        for _ in range(rounds):
            outside = [b for b in self.specs if not self._in_workspace(b)]
            if not outside:
                return True
            for body in outside:
                x = scenes.CENTER[0] + rng.uniform(-scenes.DROP_HALF_SIZE, scenes.DROP_HALF_SIZE)
                y = scenes.CENTER[1] + rng.uniform(-scenes.DROP_HALF_SIZE, scenes.DROP_HALF_SIZE)
                orientation = (scenes.yaw_quaternion(rng.uniform(0, math.pi)) if upright
                               else scenes.random_quaternion(rng))
                self.pb.resetBasePositionAndOrientation(body, (x, y, 0.15), orientation)
                self.pb.resetBaseVelocity(body, (0, 0, 0), (0, 0, 0))
            self._settle()
        return self._all_in_workspace()

    def scene_specs(self) -> list:
        """Current blocks as BlockSpecs with their present poses (to save as a scene file)."""
        out = []
        for body, spec in self.specs.items():
            pos, orn = self.pb.getBasePositionAndOrientation(body)
            out.append(BlockSpec(spec.shape, spec.dims, spec.color, spec.is_target, tuple(pos), tuple(orn)))
        return out

    # ---------------------------------------------------------------------------------------- sensing
    def render(self) -> CameraFrame:
        rng = self._noise_rng if self.depth_noise_std > 0 else None
        return self.camera.render(self.pb, self.depth_noise_std, rng, palette=self.palette)

    def visible_target_pixels(self, frame: CameraFrame | None = None) -> int:
        frame = frame or self.render()
        targets = [b for b, s in self.specs.items() if s.is_target]
        return int(np.isin(frame.segmentation, targets).sum()) if targets else 0

    def poses(self) -> dict:
        return {b: tuple(map(tuple, self.pb.getBasePositionAndOrientation(b))) for b in self.specs}

    def ground_truth(self, frame: CameraFrame | None = None) -> GroundTruth:
        targets = [b for b, s in self.specs.items() if s.is_target]
        others = [b for b, s in self.specs.items() if not s.is_target]
        inside = {b: self._in_workspace(b) for b in self.specs}
        return GroundTruth(
            target_ids=targets, object_ids=others,
            targets_remaining=sum(inside[b] for b in targets),
            objects_remaining=sum(inside[b] for b in others),
            targets_removed=sum(1 for was_target in self.removed.values() if was_target),
            non_targets_removed=sum(1 for was_target in self.removed.values() if not was_target),
            visible_target_pixels=self.visible_target_pixels(frame),
            poses=self.poses(),
            targets_out_of_workspace=sum(not inside[b] for b in targets),
            objects_out_of_workspace=sum(not inside[b] for b in others))

    def joint_positions(self) -> dict:
        return self.carrier.joint_positions()

    # ---------------------------------------------------------------------------------------- primitives
    def validate_primitive(self, kind: str, x: float, y: float, z: float, yaw: float) -> str | None:
        return validate_primitive(kind, x, y, z, yaw)

    def _body_heights(self) -> dict:
        return {b: self.pb.getBasePositionAndOrientation(b)[0][2] for b in self.specs}

    def _remove_to_bin(self, body: int) -> None:
        self.removed[body] = self.specs[body].is_target
        del self.specs[body]
        self.pb.removeBody(body)

    def grasp(self, x: float, y: float, z: float, yaw: float,
              phase=lambda name, progress: None) -> PrimitiveOutcome:
        reason = validate_primitive(GRASP, x, y, z, yaw)
        if reason is not None:
            return PrimitiveOutcome(False, message=reason, motion_completed=False)
        try:
            lifted, opening, message = execute_grasp(self.carrier, x, y, z, yaw, self._body_heights, phase)
        except MotionCancelled:
            return self._abort("grasp cancelled")
        except IKError as error:
            return self._abort(f"grasp unreachable: {error}")
        target = lifted != -1 and self.specs[lifted].is_target
        if lifted != -1:
            phase("bin", 0.9)
            self._remove_to_bin(lifted)
        phase("retreat", 0.95)
        self.carrier.go_home()
        self._settle(config.RETREAT_SETTLE_STEPS)
        phase("done", 1.0)
        return PrimitiveOutcome(lifted != -1, target, lifted, message, gripper_opening=float(opening),
                                holding=lifted != -1)

    def push(self, x: float, y: float, z: float, yaw: float,
             phase=lambda name, progress: None) -> PrimitiveOutcome:
        reason = validate_primitive(PUSH, x, y, z, yaw)
        if reason is not None:
            return PrimitiveOutcome(False, message=reason, motion_completed=False)
        try:
            message = execute_push(self.carrier, x, y, z, yaw, phase)
        except MotionCancelled:
            return self._abort("push cancelled")
        except IKError as error:
            return self._abort(f"push unreachable: {error}")
        phase("retreat", 0.95)
        self.carrier.go_home()
        self._settle(config.RETREAT_SETTLE_STEPS)
        phase("done", 1.0)
        return PrimitiveOutcome(True, message=message or "pushed")

    def _abort(self, message: str) -> PrimitiveOutcome:
        """After a cancel or an unreachable pose: open the fingers, leave upwards and park, without further
        cancel checks (a second cancel must not leave the gripper in the clutter)."""
        check, self.cancel_check = self.cancel_check, None
        try:
            self.carrier.move_fingers(cell.GRIPPER_MAX_OPENING, steps=30)
            tip = self.carrier.tcp_position()
            up = max(tip[2], min(tip[2] + config.APPROACH_HEIGHT, ABORT_RETREAT_MAX_Z))
            self.carrier.move_linear((tip[0], tip[1], up), self.carrier.yaw, config.CONTACT_SPEED)
            self.carrier.go_home()
        finally:
            self.cancel_check = check
        return PrimitiveOutcome(False, message=message, motion_completed=False)

    def execute(self, kind: str, x: float, y: float, z: float, yaw: float, phase=lambda n, p: None):
        if kind == GRASP:
            return self.grasp(x, y, z, yaw, phase)
        if kind == PUSH:
            return self.push(x, y, z, yaw, phase)
        return PrimitiveOutcome(False, message=f"unknown primitive {kind!r}", motion_completed=False)

    @staticmethod
    def displacement_class(distance: float) -> str:
        still, nudged = config.DISPLACEMENT_CLASSES
        return "still" if distance < still else "nudged" if distance < nudged else "moved"


def yaw_of_quaternion(q) -> float:
    x, y, z, w = q
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
