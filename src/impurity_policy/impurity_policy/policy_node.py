"""Policy node: /attention/result -> /policy/primitive (+ /policy/q_maps_image).

Thin shell around impurity_policy.core.policy.Policy: it decodes the attention crops, runs the 32 Q
maps, and publishes the best primitive in base_link with the attention result's stamp. Stale input
(older than `max_age` or older than what was already answered), a wrong frame, malformed images and
NONE results get one log line and no decision, never a crash. With `use_sim_time:=true` and no /clock yet
(a clock at 0 would pass every max_age check) no result is answered, said once (impurity_common.sim_time).
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
from impurity_common.diagnostics import OK, WARN, Diagnostics, LatencyMeter, Status
from impurity_common.enums import PrimitiveKind
from impurity_common.node_main import spin_node
from impurity_common.parameters import ParameterError, declare_parameters, param
from impurity_common.sim_time import StoppedClockGate
from impurity_interfaces.msg import AttentionResult, EpisodeStep, Primitive
from impurity_policy.core.checkpoint import CheckpointError, load_network
from impurity_policy.core.network import GRASP, PUSH, QNetwork
from impurity_policy.core.policy import NoActionError, Observation, Policy, q_maps_picture
from impurity_policy.core.pose import PoseRules
from impurity_policy.core.rules import PRESETS, RULE_ORDER, RuleParams, RulePipeline

DECISIONS_KEPT = 16  # answered attention results whose height maps wait for their episode step
DECISION_LOG_PERIOD = 10.0  # s between info lines about the latest decision (debug logs every one)
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


def known_rules(names) -> str | None:
    unknown = [n for n in names if n and n not in RULE_ORDER]
    return f"names unknown rules {', '.join(unknown)} (known: {', '.join(RULE_ORDER)})" if unknown else None


@dataclass(frozen=True)
class PolicyParameters(RuleParams, PoseRules):
    """Everything bringup/config/cell.yaml may set for the policy node: the pose rules' and the test-time
    rules' thresholds (pose.PoseRules, rules.RuleParams: their fields are parameters of the same names;
    an instance serves as either) and the node's own settings below."""

    checkpoint: str = param("", "Trained network (.pt); empty: the shipped one")
    allow_untrained: bool = param(False, "Without a checkpoint, decide with seeded random weights (wiring "
                                         "tests only) instead of exiting")
    seed: int = param(0, "Seed of the untrained network", low=0)
    device: str = param("cpu", "Where the network runs: cpu, cuda, cuda:N, or auto (CUDA when present)")
    max_age: float = param(5.0, "s: older attention results are stale and not answered", low=0.0)
    publish_q_maps: bool = param(True, "Publish the 32 Q maps as an image")
    threads: int = param(1, "torch CPU threads (1: robust when the cell's other processes share the cores)",
                         low=1, high=256)
    rules: str = param("cell", "Test-time rules preset: none (the paper's argmax) or cell (every rule)",
                       choices=tuple(PRESETS))
    rules_disabled: tuple[str, ...] = param(("",), "Rules of the preset left out (names in core/rules.py; "
                                            "empty strings are ignored)", check=known_rules)

    def rule_pipeline(self) -> RulePipeline:
        return RulePipeline.preset(self.rules, self, without=[n for n in self.rules_disabled if n])


class PolicyNode(Node):
    def __init__(self):
        super().__init__("policy")
        self.params = declare_parameters(self, PolicyParameters)
        import torch

        torch.set_num_threads(self.params.threads)
        self.policy = Policy(self._network(), self.params, rules=self.params.rule_pipeline())
        self._last_answered_ns = -1
        self._last_warning = {}
        self._memory_episode = ""
        self._decided_on = {}  # stamp (ns) of an answered attention result -> its full height map
        self._stopped_clock = StoppedClockGate(self)
        self._latency = LatencyMeter()  # s from an attention result's arrival to the primitive's publication
        self.diagnostics = Diagnostics(self, self._status)

        reliable = QoSProfile(depth=5, reliability=ReliabilityPolicy.RELIABLE)
        self._primitive_pub = self.create_publisher(Primitive, names.PRIMITIVE_TOPIC, reliable)
        self._q_maps_pub = self.create_publisher(Image, names.Q_MAPS_TOPIC,
                                                 QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE))
        self.create_subscription(AttentionResult, names.ATTENTION_TOPIC, self._on_attention, reliable)
        if "tried_actions" in self.policy.rules.names:
            self.create_subscription(EpisodeStep, names.EPISODE_STEPS_TOPIC, self._on_episode_step, 10)
        self.get_logger().info(f"ready: {names.ATTENTION_TOPIC} -> {names.PRIMITIVE_TOPIC}; rules "
                               f"'{self.params.rules}': {', '.join(self.policy.rules.names) or 'none'}")

    def _status(self) -> Status:
        """Decision latency (the last, the mean and the largest of the last 10 s, in s) and the decisions
        made; WARN until the first decision."""
        latency = self._latency
        values = {"decisions": latency.count, "decision latency (s)": "none yet" if latency.last is None
                  else latency.last, "mean decision latency (s)": latency.mean() or 0.0,
                  "largest decision latency (s)": latency.largest() or 0.0, "rules": self.params.rules}
        if latency.last is None:
            return Status(WARN, f"no decision yet (waiting for {names.ATTENTION_TOPIC})", values)
        return Status(OK, f"last decision in {latency.last * 1000:.0f} ms", values)

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
        if self._stopped_clock.stopped():
            return
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
        self._latency.add(time.perf_counter() - started)
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
