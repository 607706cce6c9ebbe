"""Policy node: /attention/result -> /policy/primitive (+ /policy/q_maps_image).

Thin shell around impurity_policy.core.policy.Policy: it decodes the attention crops, runs the 32 Q
maps, and publishes the best primitive in base_link with the attention result's stamp. Stale input
(older than `max_age` or older than what was already answered), a wrong frame, malformed images and
NONE results get one log line and no decision, never a crash.
"""

import pathlib
import time
from dataclasses import dataclass

import numpy as np
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Image

from impurity_common import names
from impurity_common.conversions import (
    ImageFormatError,
    grid_from_heightmap,
    image_to_numpy,
    numpy_to_image,
    time_to_ns,
)
from impurity_common.enums import PrimitiveKind
from impurity_common.node_main import spin_node
from impurity_common.parameters import ParameterError, declare_parameters, increasing, param
from impurity_interfaces.msg import AttentionResult, EpisodeStep, Primitive
from impurity_policy.core.checkpoint import CheckpointError, load_network
from impurity_policy.core.network import GRASP, PUSH, QNetwork
from impurity_policy.core.policy import NoActionError, Observation, Policy, q_maps_picture
from impurity_policy.core.pose import PoseRules
from impurity_policy.core.rules import PRESETS, RULE_ORDER, RuleParams, RulePipeline

DECISIONS_KEPT = 16  # answered attention results whose height maps wait for their episode step
DECISION_LOG_PERIOD = 10.0  # s between info lines about the latest decision (debug logs every one)
PACKAGE_DIR = pathlib.Path(__file__).resolve().parents[1]  # src/impurity_policy with --symlink-install
_RULES, _POSE = RuleParams(), PoseRules()


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


def known_rules(names) -> str | None:
    unknown = [n for n in names if n and n not in RULE_ORDER]
    return f"names unknown rules {', '.join(unknown)} (known: {', '.join(RULE_ORDER)})" if unknown else None


@dataclass(frozen=True)
class PolicyParameters:
    """Everything bringup/config/cell.yaml may set for the policy node (rules: core/rules.py)."""

    checkpoint: str = param("", "Trained network (.pt); empty: the shipped one")
    allow_untrained: bool = param(False, "Without a checkpoint, decide with seeded random weights (wiring "
                                         "tests only) instead of exiting")
    seed: int = param(0, "Seed of the untrained network", low=0)
    device: str = param("cpu", "Where the network runs: cpu, cuda, cuda:N, or auto (CUDA when present)")
    max_age: float = param(5.0, "s: older attention results are stale and not answered", low=0.0)
    publish_q_maps: bool = param(True, "Publish the 32 Q maps as an image")
    threads: int = param(1, "torch CPU threads (1: robust when the cell's other processes share the cores)",
                         low=1, high=256)
    grasp_depth: float = param(_POSE.grasp_depth, "Grasp fingertips below the local top (m)",
                               low=0.0, high=0.2)
    grasp_min_tip: float = param(_POSE.grasp_min_tip, "Lowest grasp fingertip height above the table (m)",
                                 low=0.0, high=0.2)
    push_depth: float = param(_POSE.push_depth, "Push fingertips below the local top (m)", low=0.0, high=0.2)
    push_min_tip: float = param(_POSE.push_min_tip, "Lowest push fingertip height above the table (m)",
                                low=0.0, high=0.2)
    finger_overlap: float = param(_POSE.finger_overlap, "finger_clearance: the pads must reach this far "
                                                        "below the local top at the grasp pixel (m)",
                                  low=0.0, high=0.1)
    rules: str = param("cell", "Test-time rules preset: none (the paper's argmax) or cell (every rule)",
                       choices=tuple(PRESETS))
    rules_disabled: tuple[str, ...] = param(("",), "Rules of the preset left out (names in core/rules.py; "
                                            "empty strings are ignored)", check=known_rules)
    tried_action_radius_px: int = param(_RULES.tried_action_radius_px, "tried_actions: heightmap px around "
                                        "an executed action that are ruled out", low=0, high=224)
    failed_grasps_before_push: int = param(_RULES.failed_grasps_before_push, "tried_actions: failed grasps "
                                           "in a row after which only pushes are chosen", low=1)
    occluded_push_radius_px: int = param(_RULES.occluded_push_radius_px, "occluded_push_through_heap: "
                                         "pushes pass this close (px) to the crop's highest pile",
                                         low=1, high=224)
    push_end_margin: float = param(_RULES.push_end_margin, "push_end_inside: pushes end at least this far "
                                   "inside the workspace (m)", low=0.0, high=0.2)
    occluded_push_edge_margin: float = param(_RULES.occluded_push_edge_margin, "occluded_push_off_edge: "
                                             "pushes that head for a workspace edge end at least this "
                                             "far from it (m)",
                                             low=0.0, high=0.3)
    occluded_push_start_band: tuple[float, ...] = param(
        _RULES.occluded_push_start_band, "occluded_push_start_on_flank: [low, high] local top at the push "
        "start, as a fraction of the pile's top", length=2, low=0.0, high=1.0, check=increasing)
    target_push_radius_px: int = param(_RULES.target_push_radius_px, "target_push_start_near: pushes start "
                                       "this close (px) to the target's mask", low=0, high=224)
    target_on_top_tolerance: float = param(_RULES.target_on_top_tolerance, "grasp_where_target_on_top: "
                                           "the target is the local top give or take this (m)",
                                           low=0.0, high=0.1)
    grasp_core_depth_px: float = param(_RULES.grasp_core_depth_px, "grasp_at_target_core: grasps this "
                                       "close (px) to the target mask's deepest point", low=0.0, high=56.0)
    square_max_turn_deg: float = param(_RULES.square_max_turn_deg, "grasp_square_to_faces: a grasp on a flat "
                                       "rectangular target top turns its closing axis at most this far (deg) "
                                       "onto a face normal (0: never)", low=0.0, high=45.0)
    face_min_fill: float = param(_RULES.face_min_fill, "grasp_square_to_faces: the share of its least-area "
                                 "rectangle the target's mask fills for its top to count as a rectangle",
                                 low=0.0, high=1.0)
    corner_max_slope: float = param(_RULES.corner_max_slope, "grasp_square_to_faces: the most "
                                    "root-mean-square slope (m/m) of a top that counts as flat", low=0.0)

    def pose_rules(self) -> PoseRules:
        return PoseRules(grasp_depth=self.grasp_depth, grasp_min_tip=self.grasp_min_tip,
                         push_depth=self.push_depth, push_min_tip=self.push_min_tip,
                         finger_overlap=self.finger_overlap)

    def rule_pipeline(self) -> RulePipeline:
        params = RuleParams(tried_action_radius_px=self.tried_action_radius_px,
                            failed_grasps_before_push=self.failed_grasps_before_push,
                            occluded_push_radius_px=self.occluded_push_radius_px,
                            push_end_margin=self.push_end_margin,
                            occluded_push_edge_margin=self.occluded_push_edge_margin,
                            occluded_push_start_band=tuple(self.occluded_push_start_band),
                            target_push_radius_px=self.target_push_radius_px,
                            target_on_top_tolerance=self.target_on_top_tolerance,
                            grasp_core_depth_px=self.grasp_core_depth_px,
                            square_max_turn_deg=self.square_max_turn_deg, face_min_fill=self.face_min_fill,
                            corner_max_slope=self.corner_max_slope)
        return RulePipeline.preset(self.rules, params, without=[n for n in self.rules_disabled if n])


class PolicyNode(Node):
    def __init__(self):
        super().__init__("policy")
        self.params = declare_parameters(self, PolicyParameters)
        import torch

        torch.set_num_threads(self.params.threads)
        self.policy = Policy(self._network(), self.params.pose_rules(), rules=self.params.rule_pipeline())
        self._last_answered_ns = -1
        self._last_warning = {}
        self._memory_episode = ""
        self._decided_on = {}  # stamp (ns) of an answered attention result -> its full height map

        reliable = QoSProfile(depth=5, reliability=ReliabilityPolicy.RELIABLE)
        self._primitive_pub = self.create_publisher(Primitive, names.PRIMITIVE_TOPIC, reliable)
        self._q_maps_pub = self.create_publisher(Image, names.Q_MAPS_TOPIC,
                                                 QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE))
        self.create_subscription(AttentionResult, names.ATTENTION_TOPIC, self._on_attention, reliable)
        if "tried_actions" in self.policy.rules.names:
            self.create_subscription(EpisodeStep, names.EPISODE_STEPS_TOPIC, self._on_episode_step, 10)
        self.get_logger().info(f"ready: {names.ATTENTION_TOPIC} -> {names.PRIMITIVE_TOPIC}; rules "
                               f"'{self.params.rules}': {', '.join(self.policy.rules.names) or 'none'}")

    def _network(self) -> QNetwork:
        """The checkpoint's network; a missing or incompatible one ends the node with one line naming
        the parameter (or, with allow_untrained, seeded random weights)."""
        path = self.params.checkpoint or default_checkpoint()
        try:
            network = load_network(path, device=self.params.device)
            self.get_logger().info(f"loaded checkpoint {path} on {self.params.device}")
            return network
        except ValueError as error:  # the device
            raise ParameterError(self.get_name(), str(error), "device", self.params.device) from None
        except CheckpointError as error:
            if not self.params.allow_untrained:
                raise ParameterError(self.get_name(), f"cannot be used: {error}", "checkpoint", path,
                                     "a checkpoint written by `make train` for this network, or "
                                     "allow_untrained:=true for wiring tests") from None
            import torch

            torch.manual_seed(self.params.seed)
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
        if age > self.params.max_age:
            return f"stale attention result: {age:.2f} s old (max_age {self.params.max_age:.1f} s)"
        if stamp_ns <= self._last_answered_ns:
            return "attention result older than one already answered"
        if msg.header.frame_id not in ("", names.BASE_FRAME):
            return f"attention result in frame '{msg.header.frame_id}', expected '{names.BASE_FRAME}'"
        if msg.mode == AttentionResult.MODE_NONE:
            return "attention mode NONE: no target and no occluded region to act on"
        if msg.mode not in (AttentionResult.MODE_TARGET, AttentionResult.MODE_OCCLUDED_REGION):
            return f"unknown attention mode {msg.mode}"
        return None

    def _observation(self, msg: AttentionResult) -> Observation:
        """The policy's input, on the grid the Heightmap message carries. ImageFormatError or
        ValueError for images or a grid that cannot be used."""
        color = image_to_numpy(msg.color_crop, ("rgb8",))
        height_crop = image_to_numpy(msg.height_crop, ("32FC1",))
        mask = image_to_numpy(msg.mask, ("mono8",))
        height = image_to_numpy(msg.heightmap.height, ("32FC1",))
        grid = grid_from_heightmap(msg.heightmap)
        return Observation(int(msg.mode), color, height_crop, mask, (int(msg.crop_row0), int(msg.crop_col0)),
                           np.nan_to_num(height.astype(np.float32), nan=0.0), grid)

    # ---- outcomes ------------------------------------------------------------------------------
    def _on_episode_step(self, step: EpisodeStep) -> None:
        if step.episode_id != self._memory_episode:
            self.policy.rules.clear()
            self._memory_episode = step.episode_id
        height = self._decided_on.get(time_to_ns(step.primitive.header.stamp))
        if height is None:
            self._warn("unknown step", f"episode step {step.step} executed a primitive this node did not "
                                       "answer recently: not remembered as tried")
            return
        self.policy.rules.record(int(step.primitive.kind),
                                 (step.primitive.pixel_row, step.primitive.pixel_col),
                                 step.primitive.rotation_index, height, step.success)

    # ---- decision ------------------------------------------------------------------------------
    def _on_attention(self, msg: AttentionResult) -> None:
        reason = self._rejection(msg)
        if reason is not None:
            self._warn(reason.split(":")[0], f"no decision: {reason}")
            return
        started = time.perf_counter()
        try:
            obs = self._observation(msg)
            choice = self.policy.decide(obs)
        except (ImageFormatError, NoActionError, ValueError) as error:
            self._warn("malformed", f"no decision: malformed attention result: {error}")
            return
        pose = choice.pose
        if not obs.grid.contains(pose.x, pose.y):
            self._warn("workspace", f"no decision: action ({pose.x:.3f}, {pose.y:.3f}) is outside the "
                                    "workspace")
            return
        out = Primitive()
        out.header.stamp = msg.header.stamp
        out.header.frame_id = names.BASE_FRAME
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
        # it answers every view, episode or not: at most a line per DECISION_LOG_PERIOD (debug: every one)
        text = (f"{kind} at ({pose.x:.3f}, {pose.y:.3f}, {pose.z:.3f}) yaw {np.degrees(pose.yaw):.1f} deg, "
                f"Q {out.q_value:.3f} ({(time.perf_counter() - started) * 1000:.0f} ms)")
        self.get_logger().debug(text)
        self.get_logger().info(f"latest decision: {text}", throttle_duration_sec=DECISION_LOG_PERIOD)
        if self.params.publish_q_maps:
            picture = q_maps_picture(choice.q_maps, choice.masks, choice.decision)
            self._q_maps_pub.publish(numpy_to_image(picture, "rgb8", out.header))


assert PUSH == Primitive.PUSH == PrimitiveKind.PUSH and GRASP == Primitive.GRASP == PrimitiveKind.GRASP


def main(args=None):
    spin_node(PolicyNode, args=args)


if __name__ == "__main__":
    main()
