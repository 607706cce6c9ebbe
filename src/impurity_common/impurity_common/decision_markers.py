"""Decision markers: the chosen primitive and the attended region as a visualization_msgs/MarkerArray
for RViz and Foxglove.

  /policy/primitive (impurity_interfaces/Primitive)        ->  /cell/markers (MarkerArray, transient local)
  /attention/result (impurity_interfaces/AttentionResult)

Every update publishes the whole current picture (the last primitive's markers and the last attention
result's, visualisation.primitive_markers / attention_markers, frame base_link), so a late viewer gets
it at once. A message the markers cannot be drawn from is dropped with a rate-limited warning.
"""

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from visualization_msgs.msg import MarkerArray

from impurity_common import names
from impurity_common.node_main import spin_node
from impurity_interfaces.msg import AttentionResult, Primitive

from .visualisation import attention_markers, primitive_markers

LOG_THROTTLE = 5.0  # s between repeated warnings about undrawable messages


class DecisionMarkers(Node):
    def __init__(self):
        super().__init__("decision_markers")
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
        self.get_logger().info(
            f"ready: {names.PRIMITIVE_TOPIC} + {names.ATTENTION_TOPIC} -> {names.MARKERS_TOPIC}")

    def _on_primitive(self, msg: Primitive) -> None:
        try:
            self._primitive = primitive_markers(msg)
        except ValueError as error:
            self.get_logger().warning(f"primitive not drawn: {error}", throttle_duration_sec=LOG_THROTTLE)
            return
        self._publish()

    def _on_attention(self, msg: AttentionResult) -> None:
        try:
            self._attention = attention_markers(msg)
        except ValueError as error:
            self.get_logger().warning(f"attention result not drawn: {error}",
                                      throttle_duration_sec=LOG_THROTTLE)
            return
        self._publish()

    def _publish(self) -> None:
        self._pub.publish(MarkerArray(markers=[*self._primitive, *self._attention]))


def main(args=None):
    spin_node(DecisionMarkers, args=args)


if __name__ == "__main__":
    main()
