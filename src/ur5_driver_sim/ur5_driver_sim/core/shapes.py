"""Basic-block shapes (paper 6.1: "basic blocks", 25-100 mm) and how they become PyBullet bodies.

A block is described by a BlockSpec (pure data, JSON-friendly) so scene files, scenario generators
and tests share one description; `spawn_block` turns it into a body.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from . import config

SHAPES = ("cube", "slab", "bar", "cylinder", "prism", "half_cylinder")

# Size ranges (m) per shape: dims are (x, y, z) extents of the block in its own frame.
_SIZE_RANGES = {
    "cube": ((0.030, 0.045),),
    "slab": ((0.060, 0.090), (0.040, 0.060), (0.018, 0.025)),
    "bar": ((0.080, 0.100), (0.025, 0.032), (0.025, 0.032)),
    "cylinder": ((0.030, 0.045), (0.030, 0.050)),  # diameter, height
    "prism": ((0.040, 0.050), (0.040, 0.060), (0.030, 0.040)),  # base width, length, height
    "half_cylinder": ((0.045, 0.060), (0.040, 0.060)),  # diameter, length (height = radius)
}


@dataclass
class BlockSpec:
    shape: str
    dims: tuple  # (x, y, z) extents in the block frame, m
    color: tuple  # RGB 0..1
    is_target: bool = False
    position: tuple = (0.5, 0.0, 0.05)  # base_link, m (block frame origin = bounding-box centre)
    orientation: tuple = (0.0, 0.0, 0.0, 1.0)  # quaternion x, y, z, w
    extra: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        d = asdict(self)
        d.pop("extra")
        return d

    @staticmethod
    def from_json(d: dict) -> BlockSpec:
        shape = d.get("shape")
        if shape not in SHAPES:
            raise ValueError(f"unknown shape {shape!r} (expected one of {SHAPES})")
        dims = tuple(float(v) for v in d["dims"]) if "dims" in d else default_dims(shape)
        if len(dims) != 3 or min(dims) <= 0:
            raise ValueError(f"dims must be three positive extents, got {dims}")
        is_target = bool(d.get("is_target", False))
        color = d.get("color") or (config.TARGET_COLOR if is_target else config.PRODUCT_COLOR)
        position = tuple(float(v) for v in d.get("position", (0.5, 0.0, dims[2] / 2)))
        if "orientation" in d:
            orientation = tuple(float(v) for v in d["orientation"])
        else:
            orientation = yaw_quaternion(float(d.get("yaw", 0.0)))
        return BlockSpec(shape, dims, tuple(float(c) for c in color), is_target, position, orientation)


def yaw_quaternion(yaw: float) -> tuple:
    return (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


def default_dims(shape: str) -> tuple:
    """Mid-range extents of a shape."""
    return random_dims(shape, None)


def random_dims(shape: str, rng: np.random.Generator | None) -> tuple:
    """Extents (x, y, z) of a block of this shape; the range midpoints when rng is None."""
    ranges = _SIZE_RANGES[shape]
    values = [(lo + hi) / 2 if rng is None else float(rng.uniform(lo, hi)) for lo, hi in ranges]
    if shape == "cube":
        return (values[0],) * 3
    if shape == "cylinder":
        return (values[0], values[0], values[1])
    if shape == "half_cylinder":
        return (values[1], values[0], values[0] / 2)
    return tuple(values)


def _prism_mesh(dims):
    """Triangular prism: triangle in the x-z plane (base width dims[0], apex height dims[2]), length
    along y. Vertices centred on the bounding box."""
    w, length, h = dims
    tri = [(-w / 2, -h / 2), (w / 2, -h / 2), (0.0, h / 2)]
    vertices = [(x, y, z) for y in (-length / 2, length / 2) for (x, z) in tri]
    # Counter-clockwise seen from outside (outward normals): the renderer culls back faces, and
    # inward-facing triangles made prisms render as their darkened, flattened inside.
    indices = [0, 1, 2, 3, 5, 4, 0, 4, 1, 0, 3, 4, 1, 5, 2, 1, 4, 5, 2, 3, 0, 2, 5, 3]
    return vertices, indices


def _half_cylinder_mesh(dims, segments: int = 12):
    """Half cylinder lying on its flat face: axis along x, flat side down, bounding box centred."""
    length, diameter, _ = dims
    r = diameter / 2
    arc = [(r * math.cos(math.pi * i / segments), r * math.sin(math.pi * i / segments) - r / 2)
           for i in range(segments + 1)]  # (y, z) in the cross-section
    vertices = [(x, y, z) for x in (-length / 2, length / 2) for (y, z) in arc]
    n = len(arc)
    indices = []
    for i in range(n - 1):  # curved side
        indices += [i, i + 1, n + i + 1, i, n + i + 1, n + i]
    indices += [0, n, n + n - 1, 0, n + n - 1, n - 1]  # flat bottom
    for i in range(1, n - 1):  # end caps (fans)
        indices += [0, i + 1, i, n, n + i, n + i + 1]
    return vertices, indices


def spawn_block(pb, spec: BlockSpec) -> int:
    """Create the body for a block; returns its PyBullet id."""
    dims = spec.dims
    mass = config.BLOCK_DENSITY * dims[0] * dims[1] * dims[2]
    rgba = list(spec.color) + [1.0]
    if spec.shape in ("cube", "slab", "bar"):
        half = [d / 2 for d in dims]
        collision = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=half)
        visual = pb.createVisualShape(pb.GEOM_BOX, halfExtents=half, rgbaColor=rgba)
    elif spec.shape == "cylinder":
        collision = pb.createCollisionShape(pb.GEOM_CYLINDER, radius=dims[0] / 2, height=dims[2])
        visual = pb.createVisualShape(pb.GEOM_CYLINDER, radius=dims[0] / 2, length=dims[2], rgbaColor=rgba)
        mass *= math.pi / 4
    else:
        vertices, indices = (_prism_mesh if spec.shape == "prism" else _half_cylinder_mesh)(dims)
        collision = pb.createCollisionShape(pb.GEOM_MESH, vertices=vertices)
        visual = pb.createVisualShape(pb.GEOM_MESH, vertices=vertices, indices=indices, rgbaColor=rgba)
        mass *= 0.5 if spec.shape == "prism" else math.pi / 4
    body = pb.createMultiBody(baseMass=mass, baseCollisionShapeIndex=collision,
                              baseVisualShapeIndex=visual, basePosition=spec.position,
                              baseOrientation=spec.orientation)
    pb.changeDynamics(body, -1, lateralFriction=config.BLOCK_LATERAL_FRICTION,
                      rollingFriction=config.BLOCK_ROLLING_FRICTION,
                      spinningFriction=config.BLOCK_SPINNING_FRICTION)
    return body


def footprint_radius(dims) -> float:
    """Radius of the circle around a block's footprint (any yaw)."""
    return 0.5 * math.hypot(dims[0], dims[1])
