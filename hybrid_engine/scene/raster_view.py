# SPDX-License-Identifier: GPL-3.0-or-later
"""What a raster pass needs of a camera, in the form GLSL takes it.

The primary camera and each cube-map face (paper §3.1, §3.2) are drawn by the same
G-buffer pass; the passes that reconstruct positions from a G-buffer (deferred shading,
the tracer) share the same camera uniforms. Both read them from one ``RasterView``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import matrix4
from .camera import Camera


def gl_matrix(m: np.ndarray) -> bytes:
    """Row-major numpy matrix → column-major float32 bytes for a GLSL mat4."""
    return np.ascontiguousarray(np.asarray(m, np.float32).T).tobytes()


def axis_pixel(view_proj: np.ndarray, height: int, orthographic: bool) -> tuple[float, float]:
    """A pixel's footprint on the view's optical axis: (width at the eye, growth per unit of
    distance), ``width + spread * distance``. Read from the projection's vertical scale, which
    a crop (a render region, a sub-pixel sample: views.crop_projection) multiplies by as much
    as it divides the height: every crop of one view has the whole view's pixel, so what is
    keyed by it (random.glsl's position keys) is the same in the region as in the frame."""
    m = np.asarray(view_proj, np.float64)
    row_y = m[1, :3]
    if not orthographic:
        back = m[3, :3]  # clip w is the distance in front of the eye: the view's axis
        back = back / max(float(np.linalg.norm(back)), 1e-300)
        row_y = row_y - float(np.dot(row_y, back)) * back  # the shear of an off-centre crop removed
    scale = float(np.linalg.norm(row_y)) * max(int(height), 1) / 2.0
    if not scale > 0.0:
        return 0.0, 0.0
    return (1.0 / scale, 0.0) if orthographic else (0.0, 1.0 / scale)


@dataclass(frozen=True)
class RasterView:
    """A view drawn into a G-buffer: the primary camera or a cube-map face."""

    view_proj: np.ndarray
    position: np.ndarray
    forward: np.ndarray
    orthographic: bool
    width: int
    height: int
    # World to camera space as Cycles' Texture Coordinate Camera output gives it (+Z in front
    # of the camera); None for views that are no camera (the cube-map faces).
    world_to_camera: np.ndarray | None = None
    # Where pixel (0, 0) lies in the whole frame's pixels (Camera.pixel_origin).
    pixel_origin: tuple[int, int] = (0, 0)

    @classmethod
    def from_camera(cls, camera: Camera) -> "RasterView":
        to_camera = np.diag([1.0, 1.0, -1.0, 1.0]) @ camera.view_matrix()
        return cls(camera.view_projection(), camera.position, camera.forward,
                   camera.projection == "ORTHO", int(camera.width), int(camera.height), to_camera,
                   tuple(camera.pixel_origin))

    def view_proj_bytes(self) -> bytes:
        """The view-projection as a GLSL mat4 (passes that project points into the view)."""
        return gl_matrix(self.view_proj)

    def uniforms(self) -> dict:
        """The camera uniforms that the passes reconstructing positions from a G-buffer
        share (deferred_shade.comp.glsl, hybrid_trace.comp.glsl)."""
        return {
            "u_inv_view_proj": gl_matrix(matrix4.inverse(self.view_proj)),
            "u_camera_position": tuple(np.asarray(self.position, float)),
            "u_camera_forward": tuple(np.asarray(self.forward, float)),
            "u_orthographic": int(self.orthographic),
            "u_size": (self.width, self.height),
            "u_pixel_origin": tuple(int(v) for v in self.pixel_origin),
            # random.glsl's position keys: cells a fraction of this view's pixel.
            "u_key_eye": tuple(np.asarray(self.position, float)),
            "u_key_pixel": axis_pixel(self.view_proj, self.height, self.orthographic),
            **self.node_camera_uniforms(),
        }

    def node_camera_uniforms(self) -> dict:
        """The node programs' camera (node_program.glsl: Texture Coordinate Camera and
        Window), only for a view that is a camera."""
        if self.world_to_camera is None:
            return {}
        return {"u_node_world_to_camera": gl_matrix(self.world_to_camera),
                "u_node_world_to_clip": gl_matrix(self.view_proj)}
