# SPDX-License-Identifier: GPL-3.0-or-later
"""What a final render delivers besides the shaded colour: Blender's film and passes.

An artist composites a render: over a plate (*Film > Transparent*), with depth of field or
fog from the *Depth* pass, relit or masked from the *Normal* pass, and re-renders a small
part of a frame (*Render Region*, Ctrl+B in camera view). Blender's own engines give all
four, so a renderer that ignores them breaks a compositing setup the moment it is chosen.
The conventions below are Cycles', so a compositing node tree made for Cycles reads ours
the same way (tests/test_engine.py compares both engines in one process):

* transparent film: the background (no primary hit) is (0, 0, 0, 0), premultiplied; rays
  reflected or refracted into the sky still see it, as in Cycles;
* Depth: the distance from the camera *along its view axis* (planar, not along the ray),
  in scene units, and ``BACKGROUND_DEPTH`` where nothing was hit;
* Normal: the world-space shading normal turned towards the camera (a surface seen from its
  back side reports the back side's normal), 0 where nothing was hit;
* render region: Blender's render pipeline asks for the pixels ``views.border_pixels`` gives
  (its ``disprect``: fractions times the resolution, truncated), and places them in the
  full frame itself unless the render is cropped to the region.

Everything here is numpy on arrays the renderer already has; nothing costs anything when
it is not asked for.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scene.camera import Camera

# Cycles' Depth of a pixel that hit nothing (kernel film: "no hit" leaves the 1e10 it
# starts the pass with); compositing setups test for it.
BACKGROUND_DEPTH = 1.0e10


class FilmError(ValueError):
    """A render region that covers no pixel, or film data of the wrong shape."""


@dataclass(frozen=True)
class FrameOutputs:
    """What a frame is asked to deliver besides its colour.

    ``transparent``: background pixels get alpha 0 (Blender's ``render.film_transparent``).
    ``depth`` / ``normal``: fill ``FrameResult.data_passes["depth"]`` ((H, W) float32) and
    ``["normal"]`` ((H, W, 3) float32), as the view layer's Z and Normal passes.
    """

    transparent: bool = False
    depth: bool = False
    normal: bool = False


def depth_pass(window_depth: np.ndarray, camera: Camera) -> np.ndarray:
    """The Depth pass from the primary depth buffer.

    ``window_depth`` is the (H, W) depth buffer ([0, 1], the camera's projection), cleared
    to 1 and written only where a fragment passed the LESS test, so the pixels with a
    primary hit are those below 1. Each pixel centre is taken back through the inverse
    projection, which serves perspective, orthographic and shifted or cropped frustums
    alike, and its view-space z negated (the camera looks down -z).
    """
    h, w = window_depth.shape
    hit = window_depth < 1.0
    ndc_x = (np.arange(w, dtype=np.float64) + 0.5) / w * 2.0 - 1.0
    ndc_y = (np.arange(h, dtype=np.float64) + 0.5) / h * 2.0 - 1.0
    ndc_z = np.asarray(window_depth, np.float64) * 2.0 - 1.0
    inv = np.linalg.inv(camera.projection_matrix())
    # View-space z and w of (x, y, z, 1) through the inverse projection, row by row of the
    # matrix so no (H, W, 4) array is built: z/w is the point's view-space z.
    z = inv[2, 0] * ndc_x[None, :] + inv[2, 1] * ndc_y[:, None] + inv[2, 2] * ndc_z + inv[2, 3]
    w_ = inv[3, 0] * ndc_x[None, :] + inv[3, 1] * ndc_y[:, None] + inv[3, 2] * ndc_z + inv[3, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        depth = -z / w_
    depth = np.where(hit & np.isfinite(depth), depth, BACKGROUND_DEPTH)
    return depth.astype(np.float32)


def normal_pass(normal_material: np.ndarray) -> np.ndarray:
    """The Normal pass from the primary G-buffer's normal target.

    ``normal_material`` is (H, W, 4): xyz the world shading normal as modelled, w the
    material index + 1, negated where the triangle is seen from its back side, 0 for the
    background (gbuffer.frag.glsl). Back sides report their own normal, as Cycles flips
    the shading normal of a back-facing hit.
    """
    if normal_material.ndim != 3 or normal_material.shape[2] != 4:
        raise FilmError(f"the normal target must be (H, W, 4), got {normal_material.shape}")
    n = np.asarray(normal_material[..., :3], np.float64)
    code = normal_material[..., 3]
    length = np.linalg.norm(n, axis=-1, keepdims=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        unit = np.where(length > 0, n / length, 0.0)
    side = np.where(code < 0, -1.0, np.where(code > 0, 1.0, 0.0))[..., None]
    return (unit * side).astype(np.float32)
