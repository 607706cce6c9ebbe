"""Attention node: /heightmap -> /attention/result (paper Algorithm 1) and /attention/debug_image.

Thin shell around impurity_attention.core.attention.attend: one AttentionResult per heightmap, with the
heightmap's stamp; a malformed heightmap is dropped with one rate-limited log line.
"""

from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Image

from impurity_attention.core.attention import AttentionParams, attend, debug_image
from impurity_attention.core.density import DensityParams
from impurity_attention.core.heightmap import HeightmapGrid
from impurity_attention.core.saliency import SaliencyParams
from impurity_common.conversions import ImageFormatError, image_to_numpy, numpy_to_image
from impurity_common.node_main import spin_node
from impurity_common.parameters import describe
from impurity_interfaces.msg import AttentionResult, Heightmap

HEIGHTMAP_TOPIC = "/heightmap"
RESULT_TOPIC = "/attention/result"
DEBUG_TOPIC = "/attention/debug_image"
DEFAULTS = AttentionParams()

# parameter name -> (default, description); names group into saliency.* / density.* in cell.yaml
SALIENCY_PARAMETERS = {
    "center_sigma": (DEFAULTS.saliency.center_sigma, "VOCUS2 centre blur of the finest layer (px)"),
    "surround_sigma": (DEFAULTS.saliency.surround_sigma, "VOCUS2 surround blur (px, > centre)"),
    "n_scales": (DEFAULTS.saliency.n_scales, "VOCUS2 scales per octave"),
    "start_layer": (DEFAULTS.saliency.start_layer, "VOCUS2 first pyramid octave"),
    "stop_layer": (DEFAULTS.saliency.stop_layer, "VOCUS2 last pyramid octave"),
}
DENSITY_PARAMETERS = {
    "occupied_height": (DEFAULTS.density.occupied_height,
                        "Cells higher than this are objects, for DBSCAN and saliency (m)"),
    "stride": (DEFAULTS.density.stride, "Sub-grid step of the DBSCAN points (cells)"),
    "eps": (DEFAULTS.density.eps, "DBSCAN neighbourhood radius (m)"),
    "min_samples": (DEFAULTS.density.min_samples, "DBSCAN points within eps that make a core point"),
    "height_weight": (DEFAULTS.density.height_weight, "Height as a DBSCAN coordinate: m per m (0 = off)"),
    "min_cluster_height": (DEFAULTS.density.min_cluster_height, "Lower clusters cannot hide a target (m)"),
    "min_cluster_area": (DEFAULTS.density.min_cluster_area, "Smaller clusters cannot hide a target (m^2)"),
    "height_percentile": (DEFAULTS.density.height_percentile, "Cluster height = this percentile (%)"),
    "score": (DEFAULTS.density.score, "What makes a cluster the largest: area or volume"),
}
ATTENTION_PARAMETERS = {
    "background": (DEFAULTS.background, "objects: paint table cells with the objects' median colour "
                                        "before saliency; table: the plain heightmap (paper)"),
    "region_fraction": (DEFAULTS.region_fraction, "Salient region: object cells >= this x peak saliency"),
    "min_region_area": (DEFAULTS.min_region_area, "Smallest salient region (cells)"),
    "min_target_contrast": (DEFAULTS.min_target_contrast,
                            "Mean saliency of the best region below this: no visible target"),
    "mask_chroma_tolerance": (DEFAULTS.mask_chroma_tolerance,
                              "Target mask: object cells within this chroma distance of m_t (0 = m_t only)"),
    "crop_size": (DEFAULTS.crop_size, "Side of the target/cluster-centric crops (cells)"),
}


class AttentionNode(Node):
    def __init__(self):
        super().__init__("attention")
        for prefix, table in (("saliency.", SALIENCY_PARAMETERS), ("density.", DENSITY_PARAMETERS),
                              ("", ATTENTION_PARAMETERS)):
            for name, (default, text) in table.items():
                self.declare_parameter(prefix + name, default, describe(text))
        self.declare_parameter("publish_debug_image", True, describe("Publish the saliency overlay"))
        self.declare_parameter("log_throttle", 5.0, describe("s between repeated warnings"))
        self._params = self._read_params()

        reliable = QoSProfile(depth=5, reliability=ReliabilityPolicy.RELIABLE)
        self.create_subscription(Heightmap, HEIGHTMAP_TOPIC, self._on_heightmap,
                                 QoSProfile(depth=2, reliability=ReliabilityPolicy.RELIABLE))
        self._result_pub = self.create_publisher(AttentionResult, RESULT_TOPIC, reliable)
        self._debug_pub = self.create_publisher(Image, DEBUG_TOPIC,
                                                QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE))
        self.get_logger().info(f"ready: {self._params}")

    def _param(self, name):
        return self.get_parameter(name).value

    def _read_params(self) -> AttentionParams:
        saliency = SaliencyParams(**{name: self._param("saliency." + name) for name in SALIENCY_PARAMETERS})
        density = DensityParams(**{name: self._param("density." + name) for name in DENSITY_PARAMETERS})
        return AttentionParams(saliency=saliency, density=density,
                               **{name: self._param(name) for name in ATTENTION_PARAMETERS})

    def _drop(self, reason: str) -> None:
        self.get_logger().warning(f"heightmap dropped: {reason}",
                                  throttle_duration_sec=self._param("log_throttle"))

    def _on_heightmap(self, msg: Heightmap) -> None:
        try:
            color = image_to_numpy(msg.color, ("rgb8",))
            height = image_to_numpy(msg.height, ("32FC1",))
            if msg.resolution <= 0:
                raise ValueError(f"resolution {msg.resolution} is not positive")
            grid = HeightmapGrid(x_min=msg.origin.x, x_max=msg.origin.x + msg.resolution * height.shape[1],
                                 y_min=msg.origin.y, y_max=msg.origin.y + msg.resolution * height.shape[0],
                                 resolution=msg.resolution, table_z=msg.origin.z)
            output = attend(color, height, self._params, grid)
        except (ImageFormatError, ValueError) as error:
            self._drop(str(error))
            return
        self._result_pub.publish(to_message(msg, output))
        if self._param("publish_debug_image") and self._debug_pub.get_subscription_count() > 0:
            self._debug_pub.publish(numpy_to_image(debug_image(color, output), "rgb8", msg.header))


def to_message(heightmap: Heightmap, output) -> AttentionResult:
    result = AttentionResult()
    result.header = heightmap.header
    result.mode = int(output.mode)
    result.score = float(output.score)
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
