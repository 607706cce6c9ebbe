"""Policy node: /attention/result -> /policy/primitive (+ /policy/q_maps_image).

Thin shell around impurity_policy.core.policy.Policy: it decodes the attention crops, runs the 32 Q
maps, and publishes the best primitive in base_link with the attention result's stamp. Stale input
(older than `max_age` or older than what was already answered), a wrong frame, malformed images and
NONE results get one log line and no decision, never a crash.
"""

import pathlib
import time

import numpy as np
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Image

from impurity_common import cell
from impurity_common.conversions import ImageFormatError, image_to_numpy, numpy_to_image, time_to_ns
from impurity_common.node_main import spin_node
from impurity_common.parameters import describe
from impurity_interfaces.msg import AttentionResult, EpisodeStep, Primitive
from impurity_policy.core.checkpoint import CheckpointError, load_network
from impurity_policy.core.network import GRASP, PUSH, QNetwork
from impurity_policy.core.policy import (
    FAILED_GRASPS_BEFORE_PUSH,
    ActionFilters,
    NoActionError,
    Observation,
    Policy,
    TriedActionMemory,
    q_maps_picture,
)
from impurity_policy.core.pose import PoseRules

ATTENTION_TOPIC = "/attention/result"
PRIMITIVE_TOPIC = "/policy/primitive"
Q_MAPS_TOPIC = "/policy/q_maps_image"
EPISODE_STEPS_TOPIC = "/episode/steps"
DECISIONS_KEPT = 16  # answered attention results whose height maps wait for their episode step
PACKAGE_DIR = pathlib.Path(__file__).resolve().parents[1]  # src/impurity_policy with --symlink-install


def default_checkpoint() -> str:
    """The shipped checkpoint: the package's share dir (ROS install) or the source tree."""
    candidates = []
    try:
        from ament_index_python.packages import get_package_share_directory

        share = pathlib.Path(get_package_share_directory("impurity_policy"))
        candidates.append(share / "checkpoints" / "policy.pt")
    except Exception:  # noqa: BLE001 - no ament index: only the source tree
        pass
    candidates.append(PACKAGE_DIR / "checkpoints" / "policy.pt")
    for path in candidates:
        if path.is_file():
            return str(path)
    return str(candidates[-1])


def parameter_table() -> dict:
    """name -> (default, description): everything bringup/config/cell.yaml may set."""
    rules, filters = PoseRules(), ActionFilters()
    return {
        "checkpoint": (default_checkpoint(), "Trained network (.pt)"),
        "allow_untrained": (False, "Without a checkpoint, decide with seeded random weights (wiring tests "
                                   "only) instead of exiting"),
        "seed": (0, "Seed of the untrained network"),
        "max_age": (5.0, "s: older attention results are stale and not answered"),
        "publish_q_maps": (True, "Publish the 32 Q maps as an image"),
        "threads": (1, "torch CPU threads (1: robust when the cell's other processes share the cores)"),
        "grasp_depth": (rules.grasp_depth, "Grasp fingertips below the local top (m)"),
        "grasp_min_tip": (rules.grasp_min_tip, "Lowest grasp fingertip height above the table (m)"),
        "push_depth": (rules.push_depth, "Push fingertips below the local top (m)"),
        "push_min_tip": (rules.push_min_tip, "Lowest push fingertip height above the table (m)"),
        "finger_clearance": (filters.finger_clearance, "Rule out grasps whose open finger pads would land "
                                                       "on something (the descent would stop above it)"),
        "finger_overlap": (rules.finger_overlap, "Finger clearance: the pads must reach this far below the "
                                                 "local top at the grasp pixel (m)"),
        "grasp_on_target": (filters.grasp_on_target, "Rule out grasps off the attended target's mask"),
        "occluded_push_radius_px": (filters.occluded_push_radius_px, "No target in view: pushes pass this "
                                                                     "close (px) to the crop's highest "
                                                                     "pile (0: any push)"),
        "push_end_margin": (filters.push_end_margin, "Pushes end at least this far inside the workspace "
                                                     "(m; negative: no limit)"),
        "occluded_push_start_low": (filters.occluded_push_start_band[0], "No target in view: pushes start "
                                                                         "where the local top is at least "
                                                                         "this fraction of the pile's top"),
        "occluded_push_start_high": (filters.occluded_push_start_band[1], "... and below this fraction "
                                                                          "(not above low: no such rule)"),
        "target_push_radius_px": (filters.target_push_radius_px, "Target in view: pushes start this close "
                                                                 "(px) to its mask (negative: anywhere)"),
        "target_on_top_tolerance": (filters.target_on_top_tolerance, "Grasps where the target is the local "
                                                                     "top, give or take this (m; negative: "
                                                                     "anywhere on the target)"),
        "grasp_core_depth_px": (filters.grasp_core_depth_px, "Grasps where the target's mask is this close "
                                                             "(px) to its deepest (the middle; negative: "
                                                             "anywhere on the target)"),
        "avoid_tried_actions": (True, "Rule out a failed grasp until a push or a lift, and a push while "
                                      "the scene is unchanged (same place and direction; grasps also the "
                                      "opposite rotation); executed actions from /episode/steps"),
        "tried_action_radius_px": (TriedActionMemory().radius_px, "Heightmap pixels around a tried action "
                                                                  "that are ruled out"),
        "failed_grasps_before_push": (FAILED_GRASPS_BEFORE_PUSH, "Failed grasps in a row after which only "
                                                                 "pushes are chosen (0: never)"),
    }



class PolicyNode(Node):
    def __init__(self):
        super().__init__("policy")
        for name, (default, text) in parameter_table().items():
            self.declare_parameter(name, default, describe(text))
        import torch

        torch.set_num_threads(int(self._param("threads")))
        rules = PoseRules(grasp_depth=self._param("grasp_depth"), grasp_min_tip=self._param("grasp_min_tip"),
                          push_depth=self._param("push_depth"), push_min_tip=self._param("push_min_tip"),
                          finger_overlap=self._param("finger_overlap"))
        margin = float(self._param("push_end_margin"))
        band = (float(self._param("occluded_push_start_low")), float(self._param("occluded_push_start_high")))
        push_radius = int(self._param("target_push_radius_px"))
        on_top = float(self._param("target_on_top_tolerance"))
        core = float(self._param("grasp_core_depth_px"))
        filters = ActionFilters(finger_clearance=bool(self._param("finger_clearance")),
                                grasp_on_target=bool(self._param("grasp_on_target")),
                                occluded_push_radius_px=int(self._param("occluded_push_radius_px")),
                                push_end_margin=margin if margin >= 0 else None,
                                occluded_push_start_band=band if band[1] > band[0] else None,
                                target_push_radius_px=push_radius if push_radius >= 0 else None,
                                target_on_top_tolerance=on_top if on_top >= 0 else None,
                                grasp_core_depth_px=core if core >= 0 else None)
        self.policy = Policy(self._network(), rules, filters=filters)
        self._last_answered_ns = -1
        self._last_warning = {}
        self.memory = TriedActionMemory(int(self._param("tried_action_radius_px")),
                                        failed_grasps_before_push=int(self._param("failed_grasps_before_push")))
        self._memory_episode = ""
        self._decided_on = {}  # stamp (ns) of an answered attention result -> its full height map

        reliable = QoSProfile(depth=5, reliability=ReliabilityPolicy.RELIABLE)
        self._primitive_pub = self.create_publisher(Primitive, PRIMITIVE_TOPIC, reliable)
        self._q_maps_pub = self.create_publisher(Image, Q_MAPS_TOPIC,
                                                 QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE))
        self.create_subscription(AttentionResult, ATTENTION_TOPIC, self._on_attention, reliable)
        if self._param("avoid_tried_actions"):
            self.create_subscription(EpisodeStep, EPISODE_STEPS_TOPIC, self._on_episode_step, 10)
        self.get_logger().info(f"ready: {ATTENTION_TOPIC} -> {PRIMITIVE_TOPIC}")

    def _param(self, name):
        return self.get_parameter(name).value

    def _network(self) -> QNetwork:
        path = self._param("checkpoint")
        try:
            network = load_network(path)
            self.get_logger().info(f"loaded checkpoint {path}")
            return network
        except CheckpointError as error:
            if not self._param("allow_untrained"):
                raise SystemExit(f"policy: {error} (set allow_untrained:=true to run untrained)") from error
            import torch

            torch.manual_seed(int(self._param("seed")))
            self.get_logger().warn(f"{error}: deciding with UNTRAINED seeded weights (allow_untrained)")
            return QNetwork()

    def _warn(self, key: str, text: str, period: float = 5.0) -> None:
        now = time.monotonic()
        if now - self._last_warning.get(key, -1e9) >= period:
            self._last_warning[key] = now
            self.get_logger().warn(text)

    # ---- input checks -------------------------------------------------------------------------
    def _rejection(self, msg: AttentionResult) -> str | None:
        stamp_ns = time_to_ns(msg.header.stamp)
        if stamp_ns <= 0:
            return "attention result has no stamp"
        age = (self.get_clock().now().nanoseconds - stamp_ns) * 1e-9
        if age > self._param("max_age"):
            return f"stale attention result: {age:.2f} s old (max_age {self._param('max_age'):.1f} s)"
        if stamp_ns <= self._last_answered_ns:
            return "attention result older than one already answered"
        if msg.header.frame_id not in ("", cell.BASE_FRAME):
            return f"attention result in frame '{msg.header.frame_id}', expected '{cell.BASE_FRAME}'"
        if msg.mode == AttentionResult.MODE_NONE:
            return "attention mode NONE: no target and no occluded region to act on"
        if msg.mode not in (AttentionResult.MODE_TARGET, AttentionResult.MODE_OCCLUDED_REGION):
            return f"unknown attention mode {msg.mode}"
        return None

    def _observation(self, msg: AttentionResult) -> tuple:
        color = image_to_numpy(msg.color_crop, ("rgb8",))
        height_crop = image_to_numpy(msg.height_crop, ("32FC1",))
        mask = image_to_numpy(msg.mask, ("mono8",))
        height = image_to_numpy(msg.heightmap.height, ("32FC1",))
        resolution = float(msg.heightmap.resolution)
        if not (np.isfinite(resolution) and resolution > 0):
            raise ImageFormatError(f"heightmap resolution {resolution} is not usable")
        origin = msg.heightmap.origin
        grid = {"resolution": resolution, "x_min": float(origin.x), "y_min": float(origin.y),
                "table_z": float(origin.z)}
        obs = Observation(int(msg.mode), color, height_crop, mask, (int(msg.crop_row0), int(msg.crop_col0)),
                          np.nan_to_num(height.astype(np.float32), nan=0.0))
        return obs, grid

    # ---- outcomes ------------------------------------------------------------------------------
    def _on_episode_step(self, step: EpisodeStep) -> None:
        if step.episode_id != self._memory_episode:
            self.memory.clear()
            self._memory_episode = step.episode_id
        height = self._decided_on.get(time_to_ns(step.primitive.header.stamp))
        if height is None:
            self._warn("unknown step", f"episode step {step.step} executed a primitive this node did not "
                                       "answer recently: not remembered as tried")
            return
        primitive = GRASP if step.primitive.kind == Primitive.GRASP else PUSH
        self.memory.record(primitive, (step.primitive.pixel_row, step.primitive.pixel_col),
                           step.primitive.rotation_index, height, step.success)

    # ---- decision ------------------------------------------------------------------------------
    def _on_attention(self, msg: AttentionResult) -> None:
        reason = self._rejection(msg)
        if reason is not None:
            self._warn(reason.split(":")[0], f"no decision: {reason}")
            return
        started = time.perf_counter()
        try:
            obs, grid = self._observation(msg)
            q = self.memory.suppress(self.policy.q_maps(obs), obs)
            choice = self.policy.decide(obs, q=q, grid=grid)
        except (ImageFormatError, NoActionError, ValueError) as error:
            self._warn("malformed", f"no decision: malformed attention result: {error}")
            return
        pose = choice.pose
        if not cell.in_workspace(pose.x, pose.y):
            self._warn("workspace", f"no decision: action ({pose.x:.3f}, {pose.y:.3f}) is outside the "
                                    "workspace")
            return
        out = Primitive()
        out.header.stamp = msg.header.stamp
        out.header.frame_id = cell.BASE_FRAME
        out.kind = Primitive.GRASP if choice.decision.primitive == GRASP else Primitive.PUSH
        out.position.x, out.position.y, out.position.z = float(pose.x), float(pose.y), float(pose.z)
        out.yaw = float(pose.yaw)
        out.q_value = float(choice.decision.q_value)
        out.rotation_index = int(pose.rotation)
        out.pixel_row, out.pixel_col = (int(v) for v in pose.heightmap_pixel)
        self._primitive_pub.publish(out)
        self._last_answered_ns = time_to_ns(msg.header.stamp)
        self._decided_on[self._last_answered_ns] = obs.height
        while len(self._decided_on) > DECISIONS_KEPT:
            del self._decided_on[next(iter(self._decided_on))]  # oldest first (insertion order)
        kind = "grasp" if out.kind == Primitive.GRASP else "push"
        self.get_logger().info(
            f"{kind} at ({pose.x:.3f}, {pose.y:.3f}, {pose.z:.3f}) yaw {np.degrees(pose.yaw):.1f} deg, "
            f"Q {out.q_value:.3f} ({(time.perf_counter() - started) * 1000:.0f} ms)")
        if self._param("publish_q_maps"):
            picture = q_maps_picture(choice.q_maps, choice.masks, choice.decision)
            self._q_maps_pub.publish(numpy_to_image(picture, "rgb8", out.header))


assert PUSH == Primitive.PUSH and GRASP == Primitive.GRASP  # network indices double as message kinds


def main(args=None):
    spin_node(PolicyNode, args=args)


if __name__ == "__main__":
    main()
