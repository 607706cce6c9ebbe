"""Decision markers: the chosen primitive and the attended region as a visualization_msgs/MarkerArray
for RViz and Foxglove.

  /policy/primitive (impurity_interfaces/Primitive)        ->  /cell/markers (MarkerArray, transient local)
  /attention/result (impurity_interfaces/AttentionResult)

Every update publishes the whole current picture (the last primitive's markers and the last attention
result's, visualisation.primitive_markers / attention_markers, frame base_link, and the heightmap the
attention result carries as coloured points, visualisation.heightmap_marker), so a late viewer gets it
at once. A message the markers cannot be drawn from is dropped with a rate-limited warning.
"""

from dataclasses import dataclass

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from visualization_msgs.msg import MarkerArray

from impurity_common import names
from impurity_common.diagnostics import OK, Diagnostics, Status
from impurity_common.node_main import spin_node
from impurity_common.parameters import declare_parameters, param
from impurity_interfaces.msg import AttentionResult, Primitive
from impurity_viz.visualisation import attention_markers, heightmap_marker, primitive_markers


@dataclass(frozen=True)
class DecisionMarkersParameters:
    """Every parameter of the node."""

    heightmap_stride: int = param(4, "Draw every n-th heightmap cell (rows and columns) as a point; 0 = no "
                                  "heightmap points", low=0, high=32)
    log_throttle: float = param(5.0, "s between repeated warnings about undrawable messages", low=0.0,
                                high=3600.0)


class DecisionMarkers(Node):
    def __init__(self):
        super().__init__("decision_markers")
        self.params = declare_parameters(self, DecisionMarkersParameters)
        self._primitive: list = []
        self._attention: list = []
        reliable = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        self._pub = self.create_publisher(
            MarkerArray, names.MARKERS_TOPIC,
            QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.TRANSIENT_LOCAL))
        self.create_subscription(Primitive, names.PRIMITIVE_TOPIC, self._on_primitive, reliable)
        self.create_subscription(AttentionResult, names.ATTENTION_TOPIC, self._on_attention,
                                 QoSProfile(depth=2, reliability=ReliabilityPolicy.RELIABLE))
        self._drawn = 0
        self.diagnostics = Diagnostics(self, lambda: Status(
            OK, f"{self._drawn} marker array(s) drawn",
            {"marker arrays": self._drawn, "primitive markers": len(self._primitive),
             "attention markers": len(self._attention)}))
        self.get_logger().info(
            f"ready: {names.PRIMITIVE_TOPIC} + {names.ATTENTION_TOPIC} -> {names.MARKERS_TOPIC}")

    def _on_primitive(self, msg: Primitive) -> None:
        try:
            self._primitive = primitive_markers(msg)
        except ValueError as error:
            self.get_logger().warning(f"primitive not drawn: {error}",
                                      throttle_duration_sec=self.params.log_throttle)
            return
        self._publish()

    def _on_attention(self, msg: AttentionResult) -> None:
        try:
            markers = attention_markers(msg)
            if self.params.heightmap_stride > 0 and msg.heightmap.height.width > 0:
                markers.append(heightmap_marker(msg.heightmap, self.params.heightmap_stride))
        except ValueError as error:
            self.get_logger().warning(f"attention result not drawn: {error}",
                                      throttle_duration_sec=self.params.log_throttle)
            return
        self._attention = markers
        self._publish()

    def _publish(self) -> None:
        self._pub.publish(MarkerArray(markers=[*self._primitive, *self._attention]))
        self._drawn += 1


def main(args=None):
    spin_node(DecisionMarkers, args=args)


if __name__ == "__main__":
    main()
