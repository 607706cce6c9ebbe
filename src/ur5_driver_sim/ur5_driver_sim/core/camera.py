"""The simulated RealSense colour stream: a pinhole camera rendered with PyBullet's TinyRenderer.

Intrinsics and pose are those of impurity_common.cell unless given. Depth is metric along the optical
axis (what an aligned RealSense depth image holds); segmentation carries PyBullet body ids.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impurity_common import cell


@dataclass
class CameraFrame:
    color: np.ndarray  # (H, W, 3) uint8 RGB
    depth: np.ndarray  # (H, W) float32, m along the optical axis
    segmentation: np.ndarray  # (H, W) int32 body id, -1 background
    intrinsics: np.ndarray  # 3x3 K
    camera_pose: np.ndarray  # 4x4 T_base_cameraoptical


def quaternion_to_matrix(q) -> np.ndarray:
    x, y, z, w = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def pose_matrix(position, orientation) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3] = quaternion_to_matrix(orientation)
    t[:3, 3] = position
    return t


@dataclass
class CameraModel:
    width: int = cell.CAMERA_WIDTH
    height: int = cell.CAMERA_HEIGHT
    fx: float = cell.CAMERA_FX
    fy: float = cell.CAMERA_FY
    cx: float = cell.CAMERA_CX
    cy: float = cell.CAMERA_CY
    position: tuple = cell.CAMERA_POSITION
    orientation: tuple = cell.CAMERA_ORIENTATION
    near: float = cell.CAMERA_NEAR
    far: float = cell.CAMERA_FAR

    @property
    def intrinsics(self) -> np.ndarray:
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def pose(self) -> np.ndarray:
        return pose_matrix(self.position, self.orientation)

    def view_matrix(self) -> list:
        """OpenGL view matrix (column-major): the GL eye frame is the optical frame with y, z flipped."""
        t_base_eye = self.pose @ np.diag([1.0, -1.0, -1.0, 1.0])
        return list(np.linalg.inv(t_base_eye).T.reshape(-1))

    def projection_matrix(self) -> list:
        """OpenGL projection (column-major) reproducing K, pixel centres at integer coordinates."""
        w, h, n, f = self.width, self.height, self.near, self.far
        p = np.zeros((4, 4))
        p[0, 0] = 2 * self.fx / w
        p[0, 2] = 1 - 2 * (self.cx + 0.5) / w
        p[1, 1] = 2 * self.fy / h
        p[1, 2] = -(1 - 2 * (self.cy + 0.5) / h)
        p[2, 2] = -(f + n) / (f - n)
        p[2, 3] = -2 * f * n / (f - n)
        p[3, 2] = -1.0
        return list(p.T.reshape(-1))

    def render(self, pb, depth_noise_std: float = 0.0, rng: np.random.Generator | None = None,
               palette=None) -> CameraFrame:
        """Render colour, depth and segmentation. `palette` (appearance.Palette) sets the light and the
        exposure; None: the default light, exposure 1."""
        light = (palette.light_direction, palette.ambient, palette.diffuse) if palette is not None else (
            [0.3, 0.2, 1.0], 0.6, 0.45)
        _, _, rgba, zbuffer, seg = pb.getCameraImage(
            self.width, self.height, viewMatrix=self.view_matrix(), projectionMatrix=self.projection_matrix(),
            shadow=0, lightDirection=list(light[0]), lightAmbientCoeff=light[1], lightDiffuseCoeff=light[2],
            lightSpecularCoeff=0.05, renderer=pb.ER_TINY_RENDERER)
        rgba = np.asarray(rgba, dtype=np.uint8).reshape(self.height, self.width, 4)
        zbuffer = np.asarray(zbuffer, dtype=np.float64).reshape(self.height, self.width)
        depth = self.far * self.near / (self.far - (self.far - self.near) * zbuffer)
        if depth_noise_std > 0.0:
            rng = rng or np.random.default_rng()
            depth = depth + rng.normal(0.0, depth_noise_std, depth.shape)
        seg = np.asarray(seg, dtype=np.int32).reshape(self.height, self.width)
        color = np.ascontiguousarray(rgba[:, :, :3])
        if palette is not None:
            color = palette.expose(color)
        return CameraFrame(color=color, depth=depth.astype(np.float32),
                           segmentation=seg, intrinsics=self.intrinsics, camera_pose=self.pose)
