"""Attention node: /heightmap -> /attention/result (paper Algorithm 1) and /attention/debug_image.

Thin shell around impurity_attention.core.attention.attend: one AttentionResult per heightmap, with the
heightmap's stamp; a malformed heightmap is dropped with one rate-limited log line. A heightmap on
/attention/known_product (transient local; the episode node sends the episode's first view when it showed no
target) becomes the known product (core/product_memory.py) for the heightmaps that follow; an empty one (no
cells, sent at each episode's reset) clears it. /attention/look_closer (std_srvs/SetBool; the episode
node's stall look, core/picking.py) set true makes the heightmaps that follow attended with closer=True (the
verifier's threshold lowered to stall_look_threshold) until it is set false; with stall_look_threshold 0 or
another decision than the verifier it answers success false and nothing changes.
"""

from dataclasses import asdict, dataclass

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Image
from std_srvs.srv import SetBool

from impurity_attention.core.attention import (
    AttentionParams,
    attend,
    debug_image,
    shipped_network,
)
from impurity_attention.core.density import DensityParams
from impurity_attention.core.product_memory import known_product
from impurity_attention.core.saliency import SaliencyParams
from impurity_attention.core.verifier import default_verifier
from impurity_common import cell, names
from impurity_common.conversions import ImageFormatError, grid_from_heightmap, image_to_numpy, numpy_to_image
from impurity_common.node_main import spin_node
from impurity_common.parameters import InvalidParameter, declare_parameters, param
from impurity_interfaces.msg import AttentionResult, Heightmap

DEFAULTS = AttentionParams()


@dataclass(frozen=True)
class SaliencyParameters:
    """VOCUS2 saliency (parameters saliency.*)."""

    center_sigma: float = param(DEFAULTS.saliency.center_sigma, "VOCUS2 centre blur of the finest layer (px)",
                                low=0.1, high=50.0)
    surround_sigma: float = param(DEFAULTS.saliency.surround_sigma, "VOCUS2 surround blur (px, > centre)",
                                  low=0.1, high=100.0)
    n_scales: int = param(DEFAULTS.saliency.n_scales, "VOCUS2 scales per octave", low=1, high=8)
    start_layer: int = param(DEFAULTS.saliency.start_layer, "VOCUS2 first pyramid octave", low=0, high=6)
    stop_layer: int = param(DEFAULTS.saliency.stop_layer, "VOCUS2 last pyramid octave", low=0, high=6)

    def __post_init__(self):
        if self.surround_sigma <= self.center_sigma:
            raise InvalidParameter("surround_sigma", f"is not above center_sigma ({self.center_sigma})")
        if self.stop_layer < self.start_layer:
            raise InvalidParameter("stop_layer", f"is below start_layer ({self.start_layer})")


@dataclass(frozen=True)
class DensityParameters:
    """DBSCAN clusters of the occluded-region search (parameters density.*)."""

    occupied_height: float = param(DEFAULTS.density.occupied_height,
                                   "Cells higher than this are objects, for DBSCAN and saliency (m)",
                                   low=0.0, high=0.5)
    stride: int = param(DEFAULTS.density.stride, "Sub-grid step of the DBSCAN points (cells)", low=1, high=32)
    eps: float = param(DEFAULTS.density.eps, "DBSCAN neighbourhood radius (m)", low=0.001, high=0.5)
    min_samples: int = param(DEFAULTS.density.min_samples, "DBSCAN points within eps that make a core point",
                             low=1, high=10000)
    min_cluster_height: float = param(DEFAULTS.density.min_cluster_height,
                                      "Lower clusters cannot hide a target (m): the tallest single "
                                      "product piece plus a margin", low=0.0, high=1.0)
    min_cluster_area: float = param(DEFAULTS.density.min_cluster_area,
                                    "Smaller clusters cannot hide a target (m^2)", low=0.0, high=1.0)
    height_percentile: float = param(DEFAULTS.density.height_percentile,
                                     "Cluster height = this percentile (%)", low=0.0, high=100.0)


@dataclass(frozen=True)
class AttentionNodeParameters:
    """Every parameter of the node (bringup/config/cell.yaml, section attention)."""

    saliency: SaliencyParameters = SaliencyParameters()
    density: DensityParameters = DensityParameters()
    region_fraction: float = param(DEFAULTS.region_fraction,
                                   "Salient region: object cells >= this x peak saliency",
                                   low=0.01, high=0.99)
    min_region_area: int = param(DEFAULTS.min_region_area, "Smallest salient region (cells)",
                                 low=1, high=cell.HEIGHTMAP_SIZE ** 2)
    lightness_weight: float = param(DEFAULTS.lightness_weight, "relative: weight of the lightness map "
                                    "against the chromatic ones (shading makes product heaps salient in "
                                    "lightness)", low=0.01, high=1.0)
    min_relative_contrast: float = param(DEFAULTS.min_relative_contrast, "relative: mean relative saliency "
                                         "of the best region below this: no visible target", low=0.0)
    verifier_last_look: float = param(DEFAULTS.verifier_last_look, "verifier: with no target and no heap "
                                      "left, the likeliest region is grasped from this impurity probability "
                                      "on before the scene is called clean; 0: no last look",
                                      low=0.0, high=0.999)
    stall_look_threshold: float = param(DEFAULTS.stall_look_threshold, "verifier: least impurity probability "
                                        "of a target on a stall look (/attention/look_closer, asked for by "
                                        "the episode node after pushes that found nothing); 0: off",
                                        low=0.0, high=0.999)
    known_product_delta_e: float = param(DEFAULTS.known_product_delta_e, "verifier, with a known product "
                                         "(/attention/known_product) and a heap left: CIE76 distance within "
                                         "which a product colour counts as the region's colour",
                                         low=0.1, high=100.0)
    known_product_max_share: float = param(DEFAULTS.known_product_max_share, "verifier, with a known product "
                                           "and a heap left: a region whose colour is that of more than this "
                                           "share of the known product is passed over", low=0.0, high=0.999)
    mask_chroma_tolerance: float = param(DEFAULTS.mask_chroma_tolerance, "Target mask: object cells within "
                                         "this chroma distance of m_t (0 = m_t only)", low=0.0)
    crop_size: int = param(DEFAULTS.crop_size, "Side of the target/cluster-centric crops (cells)",
                           low=2, high=2 * cell.HEIGHTMAP_SIZE, step=2)
    publish_debug_image: bool = param(True, "Publish the saliency overlay")
    log_throttle: float = param(5.0, "s between repeated warnings", low=0.0, high=3600.0)

    def attention(self) -> AttentionParams:
        """The core's parameters."""
        return AttentionParams(
            saliency=SaliencyParams(**asdict(self.saliency)), density=DensityParams(**asdict(self.density)),
            region_fraction=self.region_fraction, min_region_area=self.min_region_area,
            min_relative_contrast=self.min_relative_contrast, lightness_weight=self.lightness_weight,
            verifier_last_look=self.verifier_last_look, stall_look_threshold=self.stall_look_threshold,
            known_product_delta_e=self.known_product_delta_e,
            known_product_max_share=self.known_product_max_share,
            mask_chroma_tolerance=self.mask_chroma_tolerance, crop_size=self.crop_size)


class AttentionNode(Node):
    def __init__(self):
        super().__init__("attention")
        self.params = declare_parameters(self, AttentionNodeParameters)
        self._params = self.params.attention()

        reliable = QoSProfile(depth=5, reliability=ReliabilityPolicy.RELIABLE)
        # the known product's subscription first: with a clear and a heightmap both waiting, the executor
        # takes ready subscriptions in the order they were made, so the clear is applied first
        self._known_product = None  # colour.ProductReference of the known product, or None
        self.create_subscription(Heightmap, names.KNOWN_PRODUCT_TOPIC, self._on_known_product,
                                 QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                                            durability=DurabilityPolicy.TRANSIENT_LOCAL))
        self._closer = False  # heightmaps are attended as a stall look (/attention/look_closer)
        self.create_service(SetBool, names.LOOK_CLOSER_SERVICE, self._on_look_closer)
        self.create_subscription(Heightmap, names.HEIGHTMAP_TOPIC, self._on_heightmap,
                                 QoSProfile(depth=2, reliability=ReliabilityPolicy.RELIABLE))
        self._result_pub = self.create_publisher(AttentionResult, names.ATTENTION_TOPIC, reliable)
        self._debug_pub = self.create_publisher(Image, names.ATTENTION_DEBUG_TOPIC,
                                                QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE))
        p = self._params
        model = p.verifier or default_verifier()
        decided = (f"verifier threshold {model.threshold:.2f}, last look {p.verifier_last_look:.2f}, "
                   f"stall look {p.stall_look_threshold:.2f}")
        if model.reads_network:
            # read now, not at the first heightmap: a missing or wrong weights file stops the node, saying why
            network = shipped_network()
            decided += f", impurity network ({network.provenance or 'no provenance'})"
        self.get_logger().info(f"ready: {names.HEIGHTMAP_TOPIC} -> {names.ATTENTION_TOPIC}; {decided} (every "
                               f"setting: ros2 param dump /{self.get_name()})")

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
                                    image_to_numpy(msg.height, ("32FC1",)), self._params,
                                    grid_from_heightmap(msg))
        except (ImageFormatError, ValueError) as error:
            self._known_product = None
            self.get_logger().warning(f"known product dropped, none is used: {error}")
            return
        self._known_product = product
        self.get_logger().info(
            f"known product: {0 if product is None else len(product.colors)} object colours (the view's near "
            f"miss left out) from the view stamped {msg.header.stamp.sec}.{msg.header.stamp.nanosec:09d}; "
            f"regions coloured like more than {100 * self._params.known_product_max_share:.1f} % of them are "
            "passed over while a heap is left")

    def _on_look_closer(self, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        p = self._params
        if request.data != self._closer:
            threshold = f": verifier threshold {p.stall_look_threshold:.2f}" if request.data else ""
            self.get_logger().info(f"stall look {'on' if request.data else 'off'}{threshold}")
        self._closer = bool(request.data)
        response.success = True
        response.message = (f"stall look on: verifier threshold {p.stall_look_threshold:.2f}" if self._closer
                            else "stall look off")
        return response

    def _on_heightmap(self, msg: Heightmap) -> None:
        try:
            color = image_to_numpy(msg.color, ("rgb8",))
            height = image_to_numpy(msg.height, ("32FC1",))
            grid = grid_from_heightmap(msg)
            output = attend(color, height, self._params, grid, known_product=self._known_product,
                            closer=self._closer)
        except (ImageFormatError, ValueError) as error:
            self._drop(str(error))
            return
        self._result_pub.publish(to_message(msg, output))
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
