"""Attention node: /heightmap -> /attention/result (paper Algorithm 1) and /attention/debug_image.

Thin shell around impurity_attention.core.attention.attend: one AttentionResult per heightmap, with the
heightmap's stamp; NaN heights (colour without depth) are attended as unknown (attend's unknown) and the
result's heightmap holds the heights attention read instead; a malformed heightmap is dropped with one
rate-limited log line, and every heightmap while `use_sim_time` is true and no /clock has arrived (said once:
impurity_common.sim_time). A heightmap on /attention/known_product (transient local; the episode node sends
the episode's first view when it showed no target) becomes the known product (core/product_memory.py) for the
heightmaps that follow; an empty one (no cells, sent at each episode's reset) clears it.
/attention/look_closer (std_srvs/SetBool; the episode node's stall look, core/picking.py) set true makes the
heightmaps that follow attended with closer=True (the verifier's threshold lowered to its model's stall_look)
until it is set false.

The node's parameters are AttentionParams' fields (declared from the core dataclass, nested saliency.* and
density.*) and two of its own (AttentionNodeParameters).
"""

import copy
from dataclasses import dataclass

import numpy as np
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Image
from std_srvs.srv import SetBool

from impurity_attention.core.attention import AttentionParams, attend, debug_image, shipped_network
from impurity_attention.core.product_memory import known_product
from impurity_attention.core.verifier import default_verifier
from impurity_common import names
from impurity_common.conversions import ImageFormatError, grid_from_heightmap, image_to_numpy, numpy_to_image
from impurity_common.diagnostics import OK, WARN, Diagnostics, RateMeter, Status
from impurity_common.node_main import spin_node
from impurity_common.parameters import declare_parameters, param
from impurity_common.sim_time import StoppedClockGate
from impurity_interfaces.msg import AttentionResult, Heightmap


@dataclass(frozen=True)
class AttentionNodeParameters(AttentionParams):
    """Every parameter of the node (bringup/config/cell.yaml, section attention): attention's own
    (AttentionParams) and the node's."""

    publish_debug_image: bool = param(True, "Publish the saliency overlay on /attention/debug_image")
    log_throttle: float = param(5.0, "s between repeated warnings", low=0.0, high=3600.0)


class AttentionNode(Node):
    def __init__(self):
        super().__init__("attention")
        self.params = declare_parameters(self, AttentionNodeParameters)

        reliable = QoSProfile(depth=5, reliability=ReliabilityPolicy.RELIABLE)
        # the known product's subscription first: with a clear and a heightmap both waiting, the executor
        # takes ready subscriptions in the order they were made, so the clear is applied first
        self._known_product = None  # colour.ProductReference of the known product, or None
        self.create_subscription(Heightmap, names.KNOWN_PRODUCT_TOPIC, self._on_known_product,
                                 QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                                            durability=DurabilityPolicy.TRANSIENT_LOCAL))
        self._closer = False  # heightmaps are attended as a stall look (/attention/look_closer)
        self._stopped_clock = StoppedClockGate(self)
        self.create_service(SetBool, names.LOOK_CLOSER_SERVICE, self._on_look_closer)
        self.create_subscription(Heightmap, names.HEIGHTMAP_TOPIC, self._on_heightmap,
                                 QoSProfile(depth=2, reliability=ReliabilityPolicy.RELIABLE))
        self._result_pub = self.create_publisher(AttentionResult, names.ATTENTION_TOPIC, reliable)
        self._debug_pub = self.create_publisher(Image, names.ATTENTION_DEBUG_TOPIC,
                                                QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE))
        self._attended = RateMeter()
        self.diagnostics = Diagnostics(self, self._status)
        model = self.params.verifier or default_verifier()
        decided = (f"verifier threshold {model.threshold:.2f}, last look {model.last_look:.2f}, stall look "
                   f"{model.stall_look:.2f}")
        if model.reads_network:
            # read now, not at the first heightmap: a missing or wrong weights file stops the node, saying why
            network = shipped_network()
            decided += f", impurity network ({network.provenance or 'no provenance'})"
        self.get_logger().info(f"ready: {names.HEIGHTMAP_TOPIC} -> {names.ATTENTION_TOPIC}; {decided} (every "
                               f"setting: ros2 param dump /{self.get_name()})")

    def _status(self) -> Status:
        """Heightmaps attended per second; WARN until a heightmap has been attended."""
        values = {"attention rate (Hz)": self._attended.rate(), "heightmaps attended": self._attended.count,
                  "known product": self._known_product is not None, "stall look": self._closer}
        if self._attended.count == 0:
            return Status(WARN, f"no heightmap attended yet (waiting for {names.HEIGHTMAP_TOPIC})", values)
        return Status(OK, f"{values['attention rate (Hz)']:.1f} heightmaps attended/s", values)

    def _drop(self, reason: str) -> None:
        self.get_logger().warning(f"heightmap dropped: {reason}",
                                  throttle_duration_sec=self.params.log_throttle)

    def _on_known_product(self, msg: Heightmap) -> None:
        if msg.color.width * msg.color.height == 0:
            if self._known_product is not None:
                self.get_logger().info("known product cleared (a new episode)")
            self._known_product = None
            return
        try:
            product = known_product(image_to_numpy(msg.color, ("rgb8",)),
                                    image_to_numpy(msg.height, ("32FC1",)), self.params,
                                    grid_from_heightmap(msg))
        except (ImageFormatError, ValueError) as error:
            self._known_product = None
            self.get_logger().warning(f"known product dropped, none is used: {error}")
            return
        self._known_product = product
        self.get_logger().info(
            f"known product: {0 if product is None else len(product.colors)} object colours (the view's near "
            f"miss left out) from the view stamped {msg.header.stamp.sec}.{msg.header.stamp.nanosec:09d}; "
            f"regions coloured like more than {100 * self.params.known_product_max_share:.1f} % of them are "
            "passed over while a heap is left")

    def _on_look_closer(self, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        stall_look = (self.params.verifier or default_verifier()).stall_look
        if request.data != self._closer:
            threshold = f": verifier threshold {stall_look:.2f}" if request.data else ""
            self.get_logger().info(f"stall look {'on' if request.data else 'off'}{threshold}")
        self._closer = bool(request.data)
        response.success = True
        response.message = (f"stall look on: verifier threshold {stall_look:.2f}" if self._closer
                            else "stall look off")
        return response

    def _on_heightmap(self, msg: Heightmap) -> None:
        if self._stopped_clock.stopped():
            return
        try:
            color = image_to_numpy(msg.color, ("rgb8",))
            height = image_to_numpy(msg.height, ("32FC1",))
            grid = grid_from_heightmap(msg)
            unknown = np.isnan(height)
            output = attend(color, height, self.params, grid, known_product=self._known_product,
                            closer=self._closer, unknown=unknown if unknown.any() else None)
        except (ImageFormatError, ValueError) as error:
            self._drop(str(error))
            return
        if unknown.any():  # downstream reads heights, never NaN: the ones the decision read
            msg = copy.copy(msg)
            msg.height = numpy_to_image(output.height, "32FC1", msg.header)
        self._result_pub.publish(to_message(msg, output))
        self._attended.tick()
        if self.params.publish_debug_image and self._debug_pub.get_subscription_count() > 0:
            self._debug_pub.publish(numpy_to_image(debug_image(color, output), "rgb8", msg.header))


def to_message(heightmap: Heightmap, output) -> AttentionResult:
    result = AttentionResult()
    result.header = heightmap.header
    result.mode = int(output.mode)
    result.score = float(output.score)
    result.last_look = bool(output.last_look)
    result.center_row, result.center_col = (int(v) for v in output.center)
    result.center.x, result.center.y = (float(v) for v in output.center_xy)
    result.center.z = float(heightmap.origin.z)
    result.crop_row0, result.crop_col0 = (int(v) for v in output.crop_origin)
    result.color_crop = numpy_to_image(output.color_crop, "rgb8", heightmap.header)
    result.height_crop = numpy_to_image(output.height_crop, "32FC1", heightmap.header)
    result.mask = numpy_to_image(output.mask, "mono8", heightmap.header)
    result.heightmap = heightmap
    return result


def main(args=None):
    spin_node(AttentionNode, args=args)


if __name__ == "__main__":
    main()
