# SPDX-License-Identifier: GPL-3.0-or-later
"""Camera matrices exactly as Blender defines them.

Follows Blender's ``BKE_camera_params_compute_viewplane``: the sensor size is the width
unless the fit is VERTICAL; AUTO fits the larger image dimension; shift is in units of the
fitted dimension; orthographic cameras use ``ortho_scale`` in place of sensor/lens. The view
matrix is the inverse of the (scale-free) camera world matrix; the camera looks down -Z.
Matrices are row-major numpy (mathutils order); transpose before uploading to GLSL.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


class CameraError(ValueError):
    """Camera parameters cannot produce an image (zero size, bad clip range, NaN matrix)."""


def _identity() -> np.ndarray:
    return np.eye(4, dtype=np.float64)


def checked_pixel_origin(value) -> tuple[int, int]:
    """A ``Camera.pixel_origin`` as two ints; CameraError for anything else."""
    try:
        x, y = value
        origin = (int(x), int(y))
    except (TypeError, ValueError) as error:
        raise CameraError(f"pixel origin must be two whole numbers, got {value!r}") from error
    if origin != (x, y):
        raise CameraError(f"pixel origin must be two whole numbers, got {value!r}")
    return origin


@dataclass(frozen=True)
class Camera:
    """A Blender camera reduced to plain numbers (see module docstring)."""

    matrix_world: np.ndarray = field(default_factory=_identity)
    width: int = 640
    height: int = 360
    projection: str = "PERSP"  # 'PERSP' or 'ORTHO'
    lens: float = 50.0  # mm
    sensor_width: float = 36.0  # mm
    sensor_height: float = 24.0  # mm
    sensor_fit: str = "AUTO"  # 'AUTO', 'HORIZONTAL', 'VERTICAL'
    shift_x: float = 0.0
    shift_y: float = 0.0
    clip_start: float = 0.1
    clip_end: float = 100.0
    ortho_scale: float = 6.0
    pixel_aspect_x: float = 1.0
    pixel_aspect_y: float = 1.0
    # Where this image's pixel (0, 0) lies among the whole frame's pixels: (0, 0) for a whole
    # frame; a render region's or a sub-pixel sample's corner (frame/views.py
    # cropped_camera). What is keyed by the screen (the traced diffuse light's interleaved
    # first directions, diffuse_gather.comp.glsl) is then the same in a region as in the frame.
    pixel_origin: tuple[int, int] = (0, 0)

    def __post_init__(self) -> None:
        m = np.asarray(self.matrix_world, np.float64)
        if m.shape != (4, 4) or not np.isfinite(m).all():
            raise CameraError("camera matrix_world must be a finite 4x4 matrix")
        object.__setattr__(self, "matrix_world", m)
        if int(self.width) < 1 or int(self.height) < 1:
            raise CameraError(f"image size must be at least 1x1, got {self.width}x{self.height}")
        if self.projection not in ("PERSP", "ORTHO"):
            raise CameraError(f"unsupported camera projection {self.projection!r} (PERSP or ORTHO)")
        if not (0 < self.clip_start < self.clip_end) or not np.isfinite(self.clip_end):
            raise CameraError(
                f"clip range must satisfy 0 < clip_start < clip_end, got {self.clip_start}..{self.clip_end}"
            )
        if self.projection == "PERSP" and not self.lens > 0:
            raise CameraError(f"focal length must be positive, got {self.lens}")
        if self.sensor_fit not in ("AUTO", "HORIZONTAL", "VERTICAL"):
            raise CameraError(f"unknown sensor fit {self.sensor_fit!r}")
        object.__setattr__(self, "pixel_origin", checked_pixel_origin(self.pixel_origin))

    # -- world placement -------------------------------------------------------------------
    @property
    def rotation(self) -> np.ndarray:
        """Orthonormal camera axes (columns x, y, z) with the object scale removed."""
        axes = self.matrix_world[:3, :3]
        norms = np.linalg.norm(axes, axis=0)
        norms[norms == 0] = 1.0
        return axes / norms

    @property
    def position(self) -> np.ndarray:
        return self.matrix_world[:3, 3].copy()

    @property
    def forward(self) -> np.ndarray:
        return -self.rotation[:, 2]

    @property
    def center(self) -> np.ndarray:
        """The centre of the lens: where the near cube and the cube map are centred (paper
        §3.2). The eye itself, except for a sample of a thin lens (frame/camera_effects.py),
        whose eye lies on the aperture around it."""
        return self.position

    def view_matrix(self) -> np.ndarray:
        """World → camera space (inverse of the scale-free world matrix)."""
        r = self.rotation
        view = np.eye(4)
        view[:3, :3] = r.T
        view[:3, 3] = -r.T @ self.position
        return view

    # -- projection ------------------------------------------------------------------------
    def viewplane(self) -> tuple[float, float, float, float]:
        """(xmin, xmax, ymin, ymax) of the view plane at distance clip_start (perspective)
        or in world units (orthographic), as Blender computes it."""
        winx, winy = float(self.width), float(self.height)
        aspx, aspy = float(self.pixel_aspect_x), float(self.pixel_aspect_y)
        ycor = aspy / aspx
        if self.projection == "ORTHO":
            pixsize = float(self.ortho_scale)
        else:
            sensor = self.sensor_height if self.sensor_fit == "VERTICAL" else self.sensor_width
            pixsize = sensor * self.clip_start / self.lens
        fit = self.sensor_fit
        if fit == "AUTO":
            fit = "HORIZONTAL" if aspx * winx >= aspy * winy else "VERTICAL"
        viewfac = winx if fit == "HORIZONTAL" else ycor * winy
        pixsize /= viewfac
        xmin, xmax = -0.5 * winx, 0.5 * winx
        ymin, ymax = -0.5 * ycor * winy, 0.5 * ycor * winy
        dx, dy = self.shift_x * viewfac, self.shift_y * viewfac
        return ((xmin + dx) * pixsize, (xmax + dx) * pixsize, (ymin + dy) * pixsize, (ymax + dy) * pixsize)

    def projection_matrix(self) -> np.ndarray:
        """OpenGL clip matrix (NDC z in [-1, 1]) for the Blender view plane."""
        left, right, bottom, top = self.viewplane()
        near, far = float(self.clip_start), float(self.clip_end)
        p = np.zeros((4, 4))
        if self.projection == "ORTHO":
            p[0, 0] = 2 / (right - left)
            p[1, 1] = 2 / (top - bottom)
            p[2, 2] = -2 / (far - near)
            p[0, 3] = -(right + left) / (right - left)
            p[1, 3] = -(top + bottom) / (top - bottom)
            p[2, 3] = -(far + near) / (far - near)
            p[3, 3] = 1
        else:
            p[0, 0] = 2 * near / (right - left)
            p[1, 1] = 2 * near / (top - bottom)
            p[0, 2] = (right + left) / (right - left)
            p[1, 2] = (top + bottom) / (top - bottom)
            p[2, 2] = -(far + near) / (far - near)
            p[2, 3] = -2 * far * near / (far - near)
            p[3, 2] = -1
        return p

    def view_projection(self) -> np.ndarray:
        return self.projection_matrix() @ self.view_matrix()

    # -- rays (for references and tests) ---------------------------------------------------
    def pixel_rays(self) -> tuple[np.ndarray, np.ndarray]:
        """World-space rays through pixel centres, row 0 at the *bottom* of the image
        (Blender's and OpenGL's convention). Returns (origins, directions) of shape (H, W, 3)."""
        h, w = int(self.height), int(self.width)
        xs = (np.arange(w) + 0.5) / w * 2 - 1
        ys = (np.arange(h) + 0.5) / h * 2 - 1
        nx, ny = np.meshgrid(xs, ys)
        inv = np.linalg.inv(self.view_projection())
        def unproject(z: float) -> np.ndarray:
            clip = np.stack([nx, ny, np.full_like(nx, z), np.ones_like(nx)], axis=-1)
            world = clip @ inv.T
            return world[..., :3] / world[..., 3:4]
        near_pts, far_pts = unproject(-1.0), unproject(1.0)
        d = far_pts - near_pts
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        if self.projection == "ORTHO":
            return near_pts, d
        origin = np.broadcast_to(self.position, near_pts.shape).copy()
        return origin, d


def look_at(eye, target, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """A camera world matrix at ``eye`` looking at ``target`` (Blender: camera looks down -Z)."""
    eye, target, up = (np.asarray(v, np.float64) for v in (eye, target, up))
    back = eye - target
    back /= np.linalg.norm(back)
    right = np.cross(up, back)
    if np.linalg.norm(right) < 1e-9:  # looking along up: pick any perpendicular
        right = np.cross((0.0, 1.0, 0.0), back)
    right /= np.linalg.norm(right)
    true_up = np.cross(back, right)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = right, true_up, back, eye
    return m


def perspective_matrix(fov_y: float, aspect: float, near: float, far: float) -> np.ndarray:
    """Symmetric OpenGL perspective (NDC z in [-1, 1]); fov_y in radians."""
    f = 1.0 / np.tan(fov_y / 2.0)
    p = np.zeros((4, 4))
    p[0, 0], p[1, 1] = f / aspect, f
    p[2, 2] = -(far + near) / (far - near)
    p[2, 3] = -2.0 * far * near / (far - near)
    p[3, 2] = -1.0
    return p


def orthographic_matrix(half_width: float, half_height: float, near: float, far: float) -> np.ndarray:
    """Symmetric OpenGL orthographic projection."""
    p = np.eye(4)
    p[0, 0], p[1, 1] = 1.0 / half_width, 1.0 / half_height
    p[2, 2] = -2.0 / (far - near)
    p[2, 3] = -(far + near) / (far - near)
    return p


def view_from_world(matrix_world: np.ndarray) -> np.ndarray:
    """Inverse of a rigid camera/light world matrix (rotation columns assumed orthonormal)."""
    r = np.asarray(matrix_world, np.float64)[:3, :3]
    t = np.asarray(matrix_world, np.float64)[:3, 3]
    view = np.eye(4)
    view[:3, :3] = r.T
    view[:3, 3] = -r.T @ t
    return view


# Cube faces in the order +X, -X, +Y, -Y, +Z, -Z with their up vectors (GL cube-map order).
CUBE_FACE_DIRECTIONS = np.array(
    [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], np.float64
)
CUBE_FACE_UPS = np.array(
    [[0, -1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1], [0, -1, 0], [0, -1, 0]], np.float64
)


# The faces' world → view rotations, the same at any centre (made once: the cube map and
# every point lamp's shadow faces take six views each frame).
CUBE_FACE_ROTATIONS = np.stack([view_from_world(look_at((0.0, 0.0, 0.0), d, up))[:3, :3]
                                for d, up in zip(CUBE_FACE_DIRECTIONS, CUBE_FACE_UPS)])


def cube_face_views(center) -> list[np.ndarray]:
    """World → view matrices of the six cube faces centred on ``center``."""
    c = np.asarray(center, np.float64).reshape(3)
    views = np.zeros((6, 4, 4))
    views[:, :3, :3] = CUBE_FACE_ROTATIONS
    views[:, :3, 3] = -(CUBE_FACE_ROTATIONS @ c)
    views[:, 3, 3] = 1.0
    return list(views)
