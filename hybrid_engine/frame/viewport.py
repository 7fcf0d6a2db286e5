# SPDX-License-Identifier: GPL-3.0-or-later
"""One viewport frame without Blender: what ``view_draw`` reads, as plain data, and the plan
it makes of it.

``view_draw`` copies the region's matrices, size and camera-view border into a
``RegionInput``; ``plan_frame`` turns that into the view to render (views.py) and where its
image goes in the region, and ``accumulation_key`` says when the viewport's accumulated
samples must start over. Tests drive all of it with plain numbers.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scene.camera import Camera
from ..scene.thin_lens import ThinLens
from .views import ViewportView, border_rect, camera_frame_rect

def accumulation_key(view: Camera, settings, scene_version: int, transparent: bool) -> tuple:
    """What the viewport's accumulated samples show (accumulation.py): the view's matrices
    and size, the settings, the scene's version (bumped by every depsgraph update) and the
    film's transparency. Any change of these starts the samples over."""
    return (np.asarray(view.view_matrix(), np.float64).tobytes(),
            np.asarray(view.projection_matrix(), np.float64).tobytes(),
            int(view.width), int(view.height), settings, int(scene_version), bool(transparent))


# ---------------------------------------------------------------------------------------
# One viewport frame's inputs, as plain data
# ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class RegionInput:
    """What ``view_draw`` reads from Blender for one frame (``context.region`` and
    ``context.region_data``), copied into plain values so the frame logic runs in tests.

    ``perspective`` is ``RegionView3D.view_perspective`` ('PERSP', 'ORTHO' or 'CAMERA');
    in camera view, ``camera`` is the scene camera at the render resolution (for its frame
    inside the region) and ``border`` the render border ((min_x, min_y), (max_x, max_y)) as
    fractions of that frame, or None when the render border is off. ``lens``: in camera view,
    the camera's Depth of Field when it is on (EEVEE's viewport shows it there too), sampled
    over the accumulated redraws; None elsewhere.
    """

    view_matrix: np.ndarray
    window_matrix: np.ndarray
    width: int
    height: int
    perspective: str = "PERSP"
    camera: Camera | None = None
    border: tuple[tuple[float, float], tuple[float, float]] | None = None
    lens: ThinLens | None = None


@dataclass(frozen=True)
class FramePlan:
    """The view to render and where its image goes in the region: ``rect`` = (x0, y0, x1, y1)
    region pixels (the whole region, or the render border in camera view). ``view`` is None
    when nothing is to be rendered (a border entirely outside the region)."""

    view: ViewportView | None
    rect: tuple[int, int, int, int]


def plan_frame(region: RegionInput, viewport_scale: float) -> FramePlan:
    """Region data → the view to render at ``viewport_scale`` and its place in the region."""
    view = ViewportView.from_matrices(region.view_matrix, region.window_matrix, region.width, region.height)
    rect = (0, 0, view.width, view.height)
    if region.perspective == "CAMERA" and region.border is not None and region.camera is not None:
        cropped = border_rect(camera_frame_rect(view, region.camera), region.border[0], region.border[1],
                              view.width, view.height)
        if cropped is None:
            return FramePlan(None, rect)
        view, rect = view.cropped(cropped), cropped
    return FramePlan(view.scaled(viewport_scale), rect)
