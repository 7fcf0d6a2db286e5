# SPDX-License-Identifier: GPL-3.0-or-later
"""The view a frame renders, given by its matrices, and the crops of it.

Blender's 3D viewport describes what it shows with two matrices per region
(``RegionView3D.view_matrix``, world → view, and ``window_matrix``, the OpenGL projection)
and the region's size in pixels. Perspective, orthographic and camera views (the latter with
the viewport's camera zoom and pan, which Blender folds into ``window_matrix``) all reduce to
these three values, so the renderer needs no knowledge of ``View3D``/``RegionView3D``:
``ViewportView.from_matrices`` turns them into a ``Camera`` whose view and projection
matrices *are* the region's. Because ``ViewportView`` is a ``Camera`` (same attributes,
overridden ``view_matrix``/``projection_matrix``), ``Renderer.render`` takes it unchanged.

A final render's *Render Region*, the viewport's render border in camera view and a
sub-pixel sample (antialias.py) are all crops of such a view: the same eye and axes, the
projection scaled and offset in clip space (``crop_projection``). The render region's pixels
follow Blender's render pipeline (``border_pixels``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..scene import matrix4
from ..scene.camera import Camera, checked_pixel_origin
from .film import FilmError

# window_matrix[3, 3] is 1 for an orthographic projection and 0 for a perspective one; Blender
# stores float32, so compare with a tolerance far above its rounding and far below 1.
_ORTHO_W_TOLERANCE = 1e-4
# The smallest |det| of the 2x2 NDC mapping that still counts as a usable projection.
_MIN_PROJECTION_DET = 1e-12


class ViewportError(ValueError):
    """Region data cannot produce a frame (zero-sized region, singular matrices)."""


def _matrix4(value, name: str) -> np.ndarray:
    """A finite 4x4 float64 array from numpy or mathutils input."""
    m = np.array(value, np.float64)
    if m.shape != (4, 4) or not np.isfinite(m).all():
        raise ViewportError(f"{name} must be a finite 4x4 matrix, got shape {m.shape}")
    return m


def clip_range(window_matrix: np.ndarray) -> tuple[float, float]:
    """(near, far) distances encoded in an OpenGL projection (see ``Camera.projection_matrix``).

    Perspective: p22 = -(f+n)/(f-n), p23 = -2fn/(f-n). Orthographic: p22 = -2/(f-n),
    p23 = -(f+n)/(f-n). Blender's orthographic viewport uses a negative near distance
    (``BKE_camera_params_from_view3d``: clip_start = -clip_end / 2), which is kept as is.
    """
    p = np.asarray(window_matrix, np.float64)
    p22, p23 = p[2, 2], p[2, 3]
    if is_orthographic(p):
        return (p23 + 1.0) / p22, (p23 - 1.0) / p22
    return p23 / (p22 - 1.0), p23 / (p22 + 1.0)


def is_orthographic(window_matrix: np.ndarray) -> bool:
    p = np.asarray(window_matrix, np.float64)
    return abs(p[3, 3] - 1.0) < _ORTHO_W_TOLERANCE and abs(p[3, 2]) < _ORTHO_W_TOLERANCE


@dataclass(frozen=True)
class ViewportView(Camera):
    """A viewport region as a ``Camera``: its matrices are the region's, not derived from a lens.

    ``world_to_view`` is ``RegionView3D.view_matrix`` and ``window`` its ``window_matrix``
    (row-major, mathutils order). ``matrix_world``, ``projection``, ``clip_start`` and
    ``clip_end`` are derived from them; the lens/sensor fields of ``Camera`` are unused.
    """

    world_to_view: np.ndarray = field(default_factory=lambda: np.eye(4))
    window: np.ndarray = field(default_factory=lambda: np.eye(4))

    def __post_init__(self) -> None:
        # Camera.__post_init__ is not called: it validates lens parameters this view does not
        # have and rejects the negative near plane of Blender's orthographic viewport.
        view = _matrix4(self.world_to_view, "view_matrix")
        window = _matrix4(self.window, "window_matrix")
        if int(self.width) < 1 or int(self.height) < 1:
            raise ViewportError(f"viewport size must be at least 1x1, got {self.width}x{self.height}")
        window_xy_det = window[0, 0] * window[1, 1] - window[0, 1] * window[1, 0]
        if abs(window_xy_det) < _MIN_PROJECTION_DET or abs(matrix4.determinant(view)) < _MIN_PROJECTION_DET:
            raise ViewportError("view or window matrix is singular (zero zoom or scale)")
        near, far = clip_range(window)
        if not (np.isfinite(near) and np.isfinite(far) and near < far):
            raise ViewportError(f"window matrix has no usable depth range ({near}..{far})")
        object.__setattr__(self, "world_to_view", view)
        object.__setattr__(self, "window", window)
        object.__setattr__(self, "matrix_world", matrix4.inverse(view))
        object.__setattr__(self, "projection", "ORTHO" if is_orthographic(window) else "PERSP")
        object.__setattr__(self, "clip_start", float(near))
        object.__setattr__(self, "clip_end", float(far))
        object.__setattr__(self, "width", int(self.width))
        object.__setattr__(self, "height", int(self.height))
        object.__setattr__(self, "pixel_origin", checked_pixel_origin(self.pixel_origin))

    @classmethod
    def from_matrices(cls, view_matrix, window_matrix, width: int, height: int,
                      pixel_origin: tuple[int, int] = (0, 0)) -> "ViewportView":
        """The region's view: ``view_matrix``/``window_matrix`` as numpy or mathutils matrices,
        ``width`` x ``height`` the pixels to render; ``pixel_origin``: where its pixel (0, 0)
        lies in the whole view's pixels (``Camera.pixel_origin``)."""
        return cls(world_to_view=view_matrix, window=window_matrix, width=int(width), height=int(height),
                   pixel_origin=pixel_origin)

    # -- Camera interface ------------------------------------------------------------------
    def view_matrix(self) -> np.ndarray:
        return self.world_to_view.copy()

    def projection_matrix(self) -> np.ndarray:
        return self.window.copy()

    def viewplane(self) -> tuple[float, float, float, float]:
        """(xmin, xmax, ymin, ymax) of the view plane at the near distance (perspective) or in
        view units (orthographic), recovered from the window matrix."""
        p = self.window
        if self.projection == "ORTHO":
            return ((-1 - p[0, 3]) / p[0, 0], (1 - p[0, 3]) / p[0, 0],
                    (-1 - p[1, 3]) / p[1, 1], (1 - p[1, 3]) / p[1, 1])
        n = self.clip_start
        return (n * (p[0, 2] - 1) / p[0, 0], n * (p[0, 2] + 1) / p[0, 0],
                n * (p[1, 2] - 1) / p[1, 1], n * (p[1, 2] + 1) / p[1, 1])

    # -- derived views ---------------------------------------------------------------------
    def resized(self, width: int, height: int) -> "ViewportView":
        """The same projection rendered at another pixel size (NDC does not depend on it); its
        pixel origin scales with the width and height."""
        x0, y0 = self.pixel_origin
        origin = (round(x0 * int(width) / self.width), round(y0 * int(height) / self.height))
        return ViewportView.from_matrices(self.world_to_view, self.window, width, height, origin)

    def scaled(self, scale: float) -> "ViewportView":
        """The view at ``viewport_scale`` of its resolution (see ``render_size``)."""
        return self.resized(*render_size(self.width, self.height, scale))

    def cropped(self, rect: tuple[int, int, int, int]) -> "ViewportView":
        """The part of this view inside the pixel rectangle ``rect = (x0, y0, x1, y1)``
        (row 0 at the bottom), as a view of (x1-x0) x (y1-y0) pixels whose image equals that
        part of this view's image."""
        x0, y0, x1, y1 = (int(v) for v in rect)
        if not (0 <= x0 < x1 <= self.width and 0 <= y0 < y1 <= self.height):
            raise ViewportError(f"crop {rect} lies outside the {self.width}x{self.height} view")
        return ViewportView.from_matrices(
            self.world_to_view, crop_projection(self.window, rect, self.width, self.height), x1 - x0, y1 - y0,
            (self.pixel_origin[0] + x0, self.pixel_origin[1] + y0))


def render_size(width: int, height: int, scale: float) -> tuple[int, int]:
    """Pixels rendered for a ``width`` x ``height`` region at ``viewport_scale`` ``scale``
    (at least 1x1; the image is stretched back over the region when drawn)."""
    if not (math.isfinite(scale) and scale > 0):
        raise ViewportError(f"viewport scale must be positive, got {scale}")
    return max(1, int(round(width * scale))), max(1, int(round(height * scale)))


def crop_projection(window_matrix: np.ndarray, rect, width: int, height: int) -> np.ndarray:
    """The projection whose NDC square is the pixel rectangle ``rect = (x0, y0, x1, y1)`` of a
    ``width`` x ``height`` image rendered with ``window_matrix``: a 2D scale and offset in
    clip space, applied after the projection (works for perspective and orthographic)."""
    x0, y0, x1, y1 = (float(v) for v in rect)
    # Pixel rect → NDC rect of the full image.
    nx0, nx1 = 2 * x0 / width - 1, 2 * x1 / width - 1
    ny0, ny1 = 2 * y0 / height - 1, 2 * y1 / height - 1
    remap = np.eye(4)
    remap[0, 0], remap[0, 3] = 2 / (nx1 - nx0), -(nx1 + nx0) / (nx1 - nx0)
    remap[1, 1], remap[1, 3] = 2 / (ny1 - ny0), -(ny1 + ny0) / (ny1 - ny0)
    # Clip-space x' = a x + b w keeps the perspective divide consistent: x'/w = a (x/w) + b.
    return remap @ np.asarray(window_matrix, np.float64)


def camera_frame_rect(view: Camera, camera: Camera) -> tuple[float, float, float, float]:
    """Where ``camera``'s image lies inside ``view``'s image, as (x0, y0, x1, y1) pixels of
    ``view`` (row 0 at the bottom), i.e. Blender's camera frame (passepartout) in camera view.

    Both views look from the same eye along the same axes in camera view, so NDC of one maps
    to NDC of the other by a 2D affine map; the camera's NDC corners (±1, ±1) are mapped through
    ``view.view_projection() @ inverse(camera.view_projection())`` at the camera's near plane.
    """
    to_view = view.view_projection() @ matrix4.inverse(camera.view_projection())
    corners = np.array([[-1, -1, -1, 1], [1, 1, -1, 1]], np.float64)
    mapped = corners @ to_view.T
    ndc = mapped[:, :2] / mapped[:, 3:4]
    x = (ndc[:, 0] + 1) * 0.5 * view.width
    y = (ndc[:, 1] + 1) * 0.5 * view.height
    return float(min(x)), float(min(y)), float(max(x)), float(max(y))


def border_rect(frame: tuple[float, float, float, float], border_min: tuple[float, float],
                border_max: tuple[float, float], width: int, height: int) -> tuple[int, int, int, int] | None:
    """The render border (``render.border_min_x`` ... as fractions of the camera frame) as
    whole pixels of a ``width`` x ``height`` region, clipped to it; None when nothing of the
    border is visible."""
    fx0, fy0, fx1, fy1 = frame
    x0 = fx0 + border_min[0] * (fx1 - fx0)
    x1 = fx0 + border_max[0] * (fx1 - fx0)
    y0 = fy0 + border_min[1] * (fy1 - fy0)
    y1 = fy0 + border_max[1] * (fy1 - fy0)
    def nearest(v: float) -> int:
        # Rounded to a millionth of a pixel first: an edge that lies on a half pixel stays
        # there whatever rounding the matrices around it carried.
        return int(math.floor(round(v, 6) + 0.5))

    ix0, iy0 = max(0, nearest(x0)), max(0, nearest(y0))
    ix1, iy1 = min(int(width), nearest(x1)), min(int(height), nearest(y1))
    if ix1 <= ix0 or iy1 <= iy0:
        return None
    return ix0, iy0, ix1, iy1


def border_pixels(width: int, height: int, border_min: tuple[float, float],
                  border_max: tuple[float, float]) -> tuple[int, int, int, int]:
    """The render region as (x0, y0, x1, y1) pixels of a ``width`` x ``height`` frame (row 0
    at the bottom), as Blender's render pipeline computes it: the stored float32 fractions
    times the resolution, truncated. Raises FilmError for a region without pixels, which
    Blender itself refuses to render."""
    def edge(fraction: float, size: int) -> int:
        return int(np.float32(fraction) * np.float32(size))

    x0, x1 = edge(border_min[0], width), edge(border_max[0], width)
    y0, y1 = edge(border_min[1], height), edge(border_max[1], height)
    x0, y0 = max(x0, 0), max(y0, 0)
    x1, y1 = min(x1, int(width)), min(y1, int(height))
    if x1 <= x0 or y1 <= y0:
        raise FilmError(f"the render region {border_min}..{border_max} of a {width}x{height} frame "
                        "covers no pixel: widen it (Ctrl+B in camera view) or turn Render Region off")
    return x0, y0, x1, y1


def cropped_camera(camera: Camera, rect: tuple[float, float, float, float], width: int, height: int) -> Camera:
    """A ``width`` x ``height`` camera whose image spans the rectangle ``rect = (x0, y0, x1,
    y1)`` of ``camera``'s image, in its pixels (fractions allowed): the same view with the
    projection cropped (``crop_projection``). A render region and a sub-pixel
    sample (antialias.py) are both such crops."""
    window = crop_projection(camera.projection_matrix(), rect, camera.width, camera.height)
    # The whole frame's pixel nearest the crop's first: a sub-pixel sample keeps its pixel.
    x0, y0 = (math.floor(float(v) + 0.5) for v in rect[:2])
    origin = (camera.pixel_origin[0] + x0, camera.pixel_origin[1] + y0)
    return ViewportView.from_matrices(camera.view_matrix(), window, width, height, origin)


def region_camera(camera: Camera, rect: tuple[int, int, int, int]) -> Camera:
    """A camera whose image is exactly the pixels ``rect`` of ``camera``'s image (the
    viewport's render border does the same)."""
    x0, y0, x1, y1 = rect
    if (x0, y0, x1, y1) == (0, 0, camera.width, camera.height):
        return camera
    return cropped_camera(camera, rect, x1 - x0, y1 - y0)
