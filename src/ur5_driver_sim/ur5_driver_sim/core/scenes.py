"""Scenario layouts (paper 6.1): where blocks start before physics settles them.

Each generator is pure: (rng, counts, colours) -> list of BlockSpec, where `colours` is the scene's
appearance.BlockColours (product blocks draw their jitter from `rng`).
The world spawns them, lets them settle and checks the scenario's invariants (all in the workspace;
invisible: no target pixel).

Scene sets (SCENE_SETS) are families of scenes beyond the paper's blocks, for fitting and measuring what
must hold across piece sizes: pieces taller or flatter than ours, a handful of pieces, dense scenes, scenes
with no impurity. A set draws each scene's counts from its seed and, with `heights`, gives every piece
(impurity and product alike) a height in that range, standing upright (random and challenging layouts):

    draw = SCENE_SETS["tall"].draw(seed=70_003)   # SceneDraw(num_targets, num_objects, heights)
    world.reset_scene("random", seed=70_003, num_targets=draw.num_targets, num_objects=draw.num_objects,
                      piece_heights=draw.heights)
"""

from __future__ import annotations

import json
import math
import pathlib
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np

from impurity_common import cell

from .shapes import SHAPES, BlockSpec, random_dims, yaw_quaternion

SCENARIOS = ("random", "challenging", "invisible", "file", "empty")
DEFAULT_COUNTS = {  # (targets, non-target blocks)
    "random": (2, 20), "challenging": (2, 20), "invisible": (2, 20), "empty": (0, 0), "file": (-1, -1)}
MAX_BLOCKS = 60
CENTER = ((cell.WORKSPACE_X[0] + cell.WORKSPACE_X[1]) / 2, (cell.WORKSPACE_Y[0] + cell.WORKSPACE_Y[1]) / 2)

# random: blocks dropped in a square around the workspace centre (dense clutter, as in VPG).
DROP_HALF_SIZE = 0.13
# challenging: a packed grid of footprint-sized blocks.
PACK_FOOTPRINT = (0.036, 0.043)  # m, block footprint edge / diameter
PACK_GAP = (0.002, 0.006)  # m between neighbours
PACK_SHAPES = ("cube", "cylinder", "prism", "half_cylinder")  # the last not with piece heights given
# invisible: heaps of a row of small targets boxed in by two bars and two pillars under a cover slab.
HEAP_TARGET_EDGE = 0.026
HEAP_WALL_GAP = 0.004
HEAP_MIN_SEPARATION = 0.14
HEAP_CENTER_HALF_RANGE = (0.10, 0.11)  # x, y around the workspace centre
HEAP_BLOCKS_PER_HEAP = 5  # 2 bars, 2 pillars, 1 cover slab
HEAP_LOOSE_RADIUS = (0.065, 0.09)  # m from a heap centre where half of the other blocks lean
HEAP_TOP_Z = 0.058  # m: top of a heap's cover slab, where the other half is piled
# Pieces of a scene set with heights: these shapes, footprints from shapes' ranges, the height drawn apart
# (a half cylinder's height is its radius: not drawn apart, not used).
UPRIGHT_SHAPES = ("cube", "slab", "bar", "cylinder", "prism")
UPRIGHT_LAYOUTS = ("random", "challenging")  # the layouts that take piece heights
PIECE_HEIGHT_LIMITS = (0.005, 0.1)  # m: piece heights a scene set may ask (the gripper's finger length)


def random_quaternion(rng: np.random.Generator) -> tuple:
    u1, u2, u3 = rng.uniform(0, 1, 3)
    return (math.sqrt(1 - u1) * math.sin(2 * math.pi * u2), math.sqrt(1 - u1) * math.cos(2 * math.pi * u2),
            math.sqrt(u1) * math.sin(2 * math.pi * u3), math.sqrt(u1) * math.cos(2 * math.pi * u3))


def resolve_counts(scenario: str, num_targets: int, num_objects: int) -> tuple:
    default_targets, default_objects = DEFAULT_COUNTS[scenario]
    targets = default_targets if num_targets is None or num_targets < 0 else int(num_targets)
    objects = default_objects if num_objects is None or num_objects < 0 else int(num_objects)
    if targets + objects > MAX_BLOCKS:
        raise ValueError(f"{targets + objects} blocks requested; at most {MAX_BLOCKS}")
    if scenario == "invisible":
        check_invisible_counts(targets, objects)
    return targets, objects


def check_invisible_counts(num_targets: int, num_objects: int) -> int:
    """Number of heaps for these counts; ValueError (before anything is built) when they cannot work."""
    heaps = 2 if num_targets <= 2 else 3
    if num_objects < heaps * HEAP_BLOCKS_PER_HEAP:
        raise ValueError(f"invisible needs at least {heaps * HEAP_BLOCKS_PER_HEAP} non-target blocks "
                         f"for {heaps} heaps, got {num_objects}")
    if num_targets > 2 * heaps:
        raise ValueError(f"invisible hides at most 2 targets per heap (6 in all), got {num_targets}")
    return heaps


def _block(rng, shape, is_target, colours, dims=None) -> BlockSpec:
    dims = dims or random_dims(shape, rng)
    color = colours.impurity() if is_target else colours.product(rng)
    return BlockSpec(shape=shape, dims=dims, color=color, is_target=is_target)


def stack_without_overlap(specs, xy_points, rng, base_z=cell.TABLE_Z, random_orientation=True):
    """Give each spec a start pose at its xy point, as low as possible without its bounding sphere
    overlapping earlier ones: blocks then fall only a few cm and settle fast."""
    placed = []  # (center, radius)
    for spec, (x, y) in zip(specs, xy_points, strict=True):
        radius = 0.5 * math.sqrt(sum(d * d for d in spec.dims))
        z = base_z + radius + 0.002
        while any(math.dist((x, y, z), c) < radius + r for c, r in placed):
            z += 0.01
        placed.append(((x, y, z), radius))
        spec.position = (x, y, z)
        spec.orientation = (random_quaternion(rng) if random_orientation
                            else yaw_quaternion(rng.uniform(0, math.pi)))
    return specs


def upright_dims(shape: str, heights: tuple, rng) -> tuple:
    """Extents of a piece of `shape` standing upright: the footprint from the shape's size ranges, the height
    (z extent) drawn from `heights` (m, lowest and highest)."""
    dims = random_dims(shape, rng)
    return (dims[0], dims[1], float(rng.uniform(*heights)))


def _upright_block(rng, is_target, colours, heights) -> BlockSpec:
    shape = UPRIGHT_SHAPES[rng.integers(len(UPRIGHT_SHAPES))]
    return _block(rng, shape, is_target, colours, upright_dims(shape, heights, rng))


def random_layout(rng, num_targets, num_objects, colours, heights=None):
    """Blocks dropped in a square around the workspace centre. heights (m, lowest and highest): every
    piece is an upright one (UPRIGHT_SHAPES) of a height in that range, dropped with a random yaw only."""
    flags = [True] * num_targets + [False] * num_objects
    rng.shuffle(flags)
    if heights is None:
        specs = [_block(rng, SHAPES[rng.integers(len(SHAPES))], is_target, colours) for is_target in flags]
    else:
        specs = [_upright_block(rng, is_target, colours, heights) for is_target in flags]
    points = [(CENTER[0] + rng.uniform(-DROP_HALF_SIZE, DROP_HALF_SIZE),
               CENTER[1] + rng.uniform(-DROP_HALF_SIZE, DROP_HALF_SIZE)) for _ in specs]
    return stack_without_overlap(specs, points, rng, random_orientation=heights is None)


def _rotate(dx, dy, yaw):
    c, s = math.cos(yaw), math.sin(yaw)
    return c * dx - s * dy, s * dx + c * dy


def challenging_layout(rng, num_targets, num_objects, colours, heights=None):
    """Blocks standing side by side on a grid with gaps of a few mm; targets in interior cells. heights (m,
    lowest and highest): block heights drawn from that range, and no half cylinders."""
    total = num_targets + num_objects
    if total == 0:
        return []
    cols = max(1, math.ceil(math.sqrt(total)))
    rows = math.ceil(total / cols)
    pitch = PACK_FOOTPRINT[1] + rng.uniform(*PACK_GAP)
    cells = [(r, c) for r in range(rows) for c in range(cols)]
    interior = [rc for rc in cells if 0 < rc[0] < rows - 1 and 0 < rc[1] < cols - 1]
    border = [rc for rc in cells if rc not in interior]
    rng.shuffle(interior)
    rng.shuffle(border)
    target_cells = (interior + border)[:num_targets]
    rest = [rc for rc in interior + border if rc not in target_cells]
    rest.sort(key=lambda rc: rc in border)  # leave empty cells on the border, never inside the packing
    object_cells = rest[:num_objects]
    yaw = rng.uniform(0, math.pi / 2)
    margin = math.hypot(cols, rows) * pitch / 2
    half_free = [max(0.0, (cell.WORKSPACE_X[1] - cell.WORKSPACE_X[0]) / 2 - margin - 0.01),
                 max(0.0, (cell.WORKSPACE_Y[1] - cell.WORKSPACE_Y[0]) / 2 - margin - 0.01)]
    cx = CENTER[0] + rng.uniform(-min(half_free[0], 0.04), min(half_free[0], 0.04))
    cy = CENTER[1] + rng.uniform(-min(half_free[1], 0.04), min(half_free[1], 0.04))
    specs = []
    for cell_rc, is_target in [(rc, True) for rc in target_cells] + [(rc, False) for rc in object_cells]:
        shapes = PACK_SHAPES if heights is None else PACK_SHAPES[:3]
        shape = shapes[rng.integers(len(shapes))]
        edge = rng.uniform(*PACK_FOOTPRINT)
        height = rng.uniform(0.03, 0.045) if heights is None else rng.uniform(*heights)
        dims = {"cube": (edge, edge, height), "cylinder": (edge, edge, height), "prism": (edge, edge, height),
                "half_cylinder": (edge, edge, edge / 2)}[shape]
        spec = _block(rng, shape, is_target, colours, dims)
        dx = (cell_rc[1] - (cols - 1) / 2) * pitch
        dy = (cell_rc[0] - (rows - 1) / 2) * pitch
        ox, oy = _rotate(dx, dy, yaw)
        spec.position = (cx + ox, cy + oy, cell.TABLE_Z + dims[2] / 2 + 0.001)
        spec.orientation = yaw_quaternion(yaw + (math.pi / 2) * rng.integers(4) * (shape != "prism"))
        specs.append(spec)
    return specs


def _heap_centers(rng, count):
    for _ in range(1000):
        centers = [(CENTER[0] + rng.uniform(-HEAP_CENTER_HALF_RANGE[0], HEAP_CENTER_HALF_RANGE[0]),
                    CENTER[1] + rng.uniform(-HEAP_CENTER_HALF_RANGE[1], HEAP_CENTER_HALF_RANGE[1]))
                   for _ in range(count)]
        pairs = [(a, b) for i, a in enumerate(centers) for b in centers[i + 1:]]
        if all(math.dist(a, b) >= HEAP_MIN_SEPARATION for a, b in pairs):
            return centers
    raise RuntimeError("could not place the heaps apart")


def invisible_layout(rng, num_targets, num_objects, colours):
    """Two or three heaps; each hides its targets in a box of two bars and two pillars under a slab,
    and the remaining blocks are dropped onto the heaps."""
    heaps = check_invisible_counts(num_targets, num_objects)
    per_heap = [num_targets // heaps + (1 if i < num_targets % heaps else 0) for i in range(heaps)]
    centers = _heap_centers(rng, heaps)
    specs = []
    for (hx, hy), k in zip(centers, per_heap, strict=True):
        yaw = rng.uniform(0, math.pi)
        t = HEAP_TARGET_EDGE
        row_half = max(k, 1) * t / 2 + (max(k, 1) - 1) * 0.001

        def place(spec, dx, dy, z, extra_yaw=0.0, hx=hx, hy=hy, yaw=yaw):
            ox, oy = _rotate(dx, dy, yaw)
            spec.position = (hx + ox, hy + oy, z)
            spec.orientation = yaw_quaternion(yaw + extra_yaw)
            specs.append(spec)

        for i in range(k):
            target = _block(rng, "cube", True, colours, (t, t, t))
            place(target, -row_half + t / 2 + i * (t + 0.002), 0.0, cell.TABLE_Z + t / 2 + 0.001)
        wall_h = rng.uniform(0.032, 0.036)
        bar_len = 2 * row_half + 2 * HEAP_WALL_GAP + 0.07
        for side in (-1, 1):
            bar = _block(rng, "bar", False, colours, (min(bar_len, 0.1), 0.028, wall_h))
            place(bar, 0.0, side * (t / 2 + HEAP_WALL_GAP + 0.014), cell.TABLE_Z + wall_h / 2 + 0.001)
        for side in (-1, 1):
            pillar = _block(rng, "cube", False, colours, (0.03, 0.03, wall_h))
            place(pillar, side * (row_half + HEAP_WALL_GAP + 0.015), 0.0, cell.TABLE_Z + wall_h / 2 + 0.001)
        slab_h = 0.02
        cover = _block(rng, "slab", False, colours, (0.1, 0.085, slab_h))
        place(cover, 0.0, 0.0, cell.TABLE_Z + wall_h + slab_h / 2 + 0.003)
    extra = num_objects - heaps * HEAP_BLOCKS_PER_HEAP
    loose = [_block(rng, SHAPES[rng.integers(len(SHAPES))], False, colours) for _ in range(extra)]
    on_top = loose[: extra // 2]  # piled on the cover slabs: the heaps
    around = loose[extra // 2:]  # leaning on the heaps' sides
    top_points, side_points = [], []
    for i in range(len(on_top)):
        hx, hy = centers[i % heaps]
        top_points.append((hx + rng.uniform(-0.02, 0.02), hy + rng.uniform(-0.02, 0.02)))
    for i in range(len(around)):
        hx, hy = centers[i % heaps]
        angle = rng.uniform(0, 2 * math.pi)
        radius = rng.uniform(*HEAP_LOOSE_RADIUS)
        side_points.append((hx + radius * math.cos(angle), hy + radius * math.sin(angle)))
    stack_without_overlap(on_top, top_points, rng, base_z=cell.TABLE_Z + HEAP_TOP_Z, random_orientation=False)
    stack_without_overlap(around, side_points, rng, random_orientation=False)
    return specs + loose


def load_scene_file(path) -> list:
    """A JSON scene: a list of blocks, or {"blocks": [...]}; each block has shape, is_target and a pose
    (position, and orientation quaternion or yaw), optionally dims and color."""
    path = pathlib.Path(path)
    try:
        data = json.loads(path.read_text())
    except OSError as exc:
        raise ValueError(f"cannot read scene file {path}: {exc}") from exc
    except json.JSONDecodeError as exc:
        raise ValueError(f"scene file {path} is not valid JSON: {exc}") from exc
    blocks = data.get("blocks") if isinstance(data, dict) else data
    if not isinstance(blocks, list):
        raise ValueError(f"scene file {path}: expected a list of blocks or {{'blocks': [...]}}")
    return [BlockSpec.from_json(b) for b in blocks]


def save_scene_file(path, specs) -> None:
    pathlib.Path(path).write_text(json.dumps({"blocks": [s.to_json() for s in specs]}, indent=1))


# ------------------------------------------------------------------------------------------------ scene sets
SCENE_SET_STREAM = 7_919  # a scene set draws its counts from default_rng([SCENE_SET_STREAM, seed])


class SceneDraw(NamedTuple):
    """One scene of a set: its counts and piece heights (m, lowest and highest; None: the shapes' own
    sizes). Counts of -1 are the scenario's defaults."""
    num_targets: int
    num_objects: int
    heights: tuple | None


@dataclass(frozen=True)
class SceneSet:
    """A family of scenes: piece heights (m, lowest and highest; None: the shapes' own sizes, the paper's
    blocks), impurities and pieces in all (inclusive ranges, drawn per seed; None: the scenario's
    defaults)."""
    name: str
    meaning: str
    heights: tuple | None = None
    targets: tuple | None = None
    pieces: tuple | None = None

    def draw(self, seed: int) -> SceneDraw:
        """The counts and heights of the scene of `seed`: the same seed draws the same counts."""
        if self.targets is None:
            return SceneDraw(-1, -1, self.heights)
        rng = np.random.default_rng([SCENE_SET_STREAM, int(seed)])
        targets = int(rng.integers(self.targets[0], self.targets[1] + 1))
        pieces = int(rng.integers(self.pieces[0], self.pieces[1] + 1))
        return SceneDraw(targets, pieces - targets, self.heights)

    def with_heights(self, heights: tuple) -> SceneSet:
        """This set with piece heights `heights` (m); its name says them in mm ("sparse@50-50")."""
        check_piece_heights(heights)
        low, high = (round(1000 * h) for h in heights)
        return replace(self, name=f"{self.name.split('@')[0]}@{low}-{high}", heights=tuple(heights),
                       meaning=f"{self.meaning.split('; ')[0]}; pieces {low}-{high} mm tall here")


WIDE_HEIGHTS = (0.015, 0.060)  # m: pieces flatter and taller than ours
SCENE_SETS = {s.name: s for s in (
    SceneSet("paper", "the paper's scenes: our blocks (25-100 mm), the scenario's counts"),
    SceneSet("tall", "pieces 40-60 mm tall (taller than ours), 2 impurities among 20", (0.040, 0.060), (2, 2),
             (22, 22)),
    SceneSet("flat", "pieces 15-25 mm tall (flatter than ours), 2 impurities among 20", (0.015, 0.025),
             (2, 2), (22, 22)),
    SceneSet("mixed", "pieces 15-60 mm tall, 2 impurities among 20", WIDE_HEIGHTS, (2, 2), (22, 22)),
    SceneSet("sparse", "a handful of pieces (5-10, 1-2 impurities), 15-60 mm tall", WIDE_HEIGHTS, (1, 2),
             (5, 10)),
    SceneSet("dense", "40-50 pieces (2-4 impurities), 15-60 mm tall", WIDE_HEIGHTS, (2, 4), (40, 50)),
    SceneSet("clean", "no impurity: 5-40 pieces of product, 15-60 mm tall", WIDE_HEIGHTS, (0, 0), (5, 40)),
)}


def check_piece_heights(heights) -> None:
    """ValueError naming the limits unless heights is (lowest, highest) m within PIECE_HEIGHT_LIMITS."""
    low, high = heights
    if not PIECE_HEIGHT_LIMITS[0] <= low <= high <= PIECE_HEIGHT_LIMITS[1]:
        raise ValueError(f"piece heights {low * 1000:g}-{high * 1000:g} mm: need "
                         f"{PIECE_HEIGHT_LIMITS[0] * 1000:g} <= lowest <= highest <= "
                         f"{PIECE_HEIGHT_LIMITS[1] * 1000:g} mm")


def scene_set_named(name: str) -> SceneSet:
    """A set of SCENE_SETS by name, or "<set>@<lowest>-<highest>" (mm) for that set with those piece
    heights. ValueError naming the sets for anything else."""
    base, _, heights = name.partition("@")
    if base not in SCENE_SETS:
        raise ValueError(f"unknown scene set {name!r} (expected one of {', '.join(SCENE_SETS)}, optionally "
                         "with @<lowest>-<highest> piece heights in mm)")
    if not heights:
        return SCENE_SETS[base]
    try:
        low, high = (float(v) / 1000 for v in heights.split("-"))
    except ValueError as error:
        raise ValueError(f"scene set {name!r}: piece heights are <lowest>-<highest> in mm") from error
    return SCENE_SETS[base].with_heights((low, high))
