"""A printed ChArUco board lying in the simulated cell, and colour renders to calibrate the camera on.

    world = CellWorld(mode="floating")
    spec = CharucoBoardSpec()                                   # impurity_calibration.calibration
    board = place_board(world.pb, spec, board_pose_on_table((0.32, -0.14, 0.001)))
    camera = CameraModel(position=..., orientation=look_at((0.9, 0.2, 0.7), (0.5, 0.0, 0.0)))
    color = render_color(world.pb, camera)                     # (480, 640, 3) uint8 RGB

The board is a thin textured quad (no collision shape: blocks and the gripper pass through it), its
texture the core's `board_image`, mapped so the board frame of impurity_calibration.calibration (origin at
the squares' lower-left outer corner, x right, y up the page, z out of the face) is the quad's body
frame. `CellWorld.reset_scene` rebuilds the physics world and removes it: place the board after.

Rendering: TinyRenderer samples a texture at one point per pixel (no anti-aliasing), which puts
aliasing steps along the squares' edges that a real sensor, integrating light over each pixel, does not
have. `render_color` renders `supersample` times finer (intrinsics scaled to match) and averages each
block of pixels (cv2.INTER_AREA): what the camera at the given intrinsics would see.
"""

from __future__ import annotations

import math
import pathlib
import tempfile
from dataclasses import dataclass, replace

import cv2
import numpy as np
from scipy.spatial.transform import Rotation

from impurity_calibration.calibration import CharucoBoardSpec, board_image

from .camera import CameraModel

TEXTURE_PIXELS_PER_SQUARE = 128  # texels per square: ~4 per camera pixel for 40 mm squares at 0.75 m
MARGIN = 0.01  # m of white paper around the squares (a print's margin)
LIFT = 0.0  # the quad lies exactly at the pose given; give z = table + paper thickness


@dataclass
class PlacedBoard:
    """A board in a PyBullet world: its body id, texture id, spec and 4x4 T_base_board."""

    body: int
    texture: int
    spec: CharucoBoardSpec
    base_from_board: np.ndarray


def _quad_obj(width: float, height: float, margin: float) -> str:
    """OBJ text of one quad in the board frame (m), texture coordinates over the whole image (v up)."""
    x0, y0, x1, y1 = -margin, -margin, width + margin, height + margin
    return ("# ChArUco board quad, board frame (m)\n"
            f"v {x0:.6f} {y0:.6f} 0\nv {x1:.6f} {y0:.6f} 0\nv {x1:.6f} {y1:.6f} 0\nv {x0:.6f} {y1:.6f} 0\n"
            "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\n"
            "f 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 4/4/1\n")


def place_board(pb, spec: CharucoBoardSpec, base_from_board: np.ndarray,
                pixels_per_square: int = TEXTURE_PIXELS_PER_SQUARE, margin: float = MARGIN) -> PlacedBoard:
    """Add the board (a visual-only textured quad with a white `margin` in m) to the world of the
    bullet client `pb` with its board frame at `base_from_board` (4x4 T_base_board, m). Raises
    ValueError for a non-finite or non-rigid pose or a negative margin."""
    base_from_board = np.asarray(base_from_board, dtype=np.float64)
    if base_from_board.shape != (4, 4) or not np.all(np.isfinite(base_from_board)):
        raise ValueError("base_from_board must be a finite 4x4 transform")
    rotation = base_from_board[:3, :3]
    if not np.allclose(rotation.T @ rotation, np.eye(3), atol=1e-6) or np.linalg.det(rotation) < 0:
        raise ValueError("base_from_board must be a rigid transform (orthonormal rotation, det +1)")
    if not (math.isfinite(margin) and margin >= 0.0):
        raise ValueError(f"margin must be >= 0 m, got {margin}")
    margin_px = int(round(margin / spec.square_length * pixels_per_square))
    margin = margin_px * spec.square_length / pixels_per_square  # what the texture holds exactly
    texture_image = cv2.cvtColor(board_image(spec, pixels_per_square, margin_px), cv2.COLOR_GRAY2BGR)
    with tempfile.TemporaryDirectory(prefix="charuco_board_") as folder:
        mesh = pathlib.Path(folder) / "board.obj"
        mesh.write_text(_quad_obj(spec.width, spec.height, margin))
        picture = pathlib.Path(folder) / "board.png"
        if not cv2.imwrite(str(picture), texture_image):
            raise OSError(f"cannot write the board texture {picture}")
        visual = pb.createVisualShape(pb.GEOM_MESH, fileName=str(mesh), rgbaColor=[1, 1, 1, 1])
        texture = pb.loadTexture(str(picture))
    quaternion = _quaternion(rotation)
    body = pb.createMultiBody(baseMass=0, baseCollisionShapeIndex=-1, baseVisualShapeIndex=visual,
                              basePosition=list(base_from_board[:3, 3] + (0.0, 0.0, LIFT)),
                              baseOrientation=list(quaternion))
    pb.changeVisualShape(body, -1, textureUniqueId=texture, rgbaColor=[1, 1, 1, 1])
    return PlacedBoard(body=body, texture=texture, spec=spec, base_from_board=base_from_board.copy())


def _quaternion(rotation: np.ndarray) -> tuple:
    """(x, y, z, w) of a rotation matrix."""
    return tuple(float(v) for v in Rotation.from_matrix(rotation).as_quat())


def look_at(eye, target, up=(0.0, 1.0, 0.0)) -> tuple:
    """Quaternion (x, y, z, w) of an optical frame (z out of the lens, x right, y down in the image) at
    `eye` looking at `target` (base_link, m), its image "up" (-y) towards `up` as far as possible.
    Raises ValueError when eye and target coincide or the view runs along `up`."""
    eye, target, up = (np.asarray(v, dtype=np.float64) for v in (eye, target, up))
    z = target - eye
    if np.linalg.norm(z) < 1e-9:
        raise ValueError("eye and target coincide")
    z /= np.linalg.norm(z)
    x = np.cross(-up, z)  # image right = down x forward
    if np.linalg.norm(x) < 1e-9:
        raise ValueError("the view runs along `up`: choose another up vector")
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return _quaternion(np.column_stack([x, y, z]))


def render_color(pb, camera: CameraModel, supersample: int = 1) -> np.ndarray:
    """Colour image (camera.height, camera.width, 3) uint8 RGB of the world seen by `camera`, rendered
    `supersample` times finer and averaged over each block (pixel centres preserved:
    c' = (c + 0.5) * s - 0.5). 1 = TinyRenderer's image as is."""
    factor = int(supersample)
    if factor < 1:
        raise ValueError(f"supersample must be >= 1, got {supersample}")
    if factor == 1:
        return camera.render(pb).color
    fine = replace(camera, width=camera.width * factor, height=camera.height * factor,
                   fx=camera.fx * factor, fy=camera.fy * factor,
                   cx=(camera.cx + 0.5) * factor - 0.5, cy=(camera.cy + 0.5) * factor - 0.5)
    return cv2.resize(fine.render(pb).color, (camera.width, camera.height), interpolation=cv2.INTER_AREA)
