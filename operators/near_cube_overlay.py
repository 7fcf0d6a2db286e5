# SPDX-License-Identifier: GPL-3.0-or-later
"""The near-cube overlay: the near cube's bounds drawn in the 3D viewport.

The near cube (paper §3: half-size ``scene.hybrid_rt.near_size`` around the eye, or the size
Frame Budget chose) decides which geometry is ray traced through the per-frame BVH and which
is ray marched in the cube map; seeing it helps choose its size. Whether it is drawn is
``scene.hybrid_rt.show_near_cube``, saved with the .blend and shown in the viewport's
Overlays popover and the Diagnostics panel. It is centred where the frame is rendered from:
the scene camera in camera view (and when no viewport is at hand), otherwise the viewport's
own eye. The 12 edges come from ``hybrid_engine.frame.overlay.near_cube_edges``; only the
line drawing uses Blender's ``gpu`` module, imported when a viewport actually draws.
"""
from __future__ import annotations

import bpy
import numpy as np

from ..blender_adapter import effective_values, properties, viewport
from ..hybrid_engine.frame.overlay import near_cube_edges

OVERLAY_COLOR = (1.0, 0.55, 0.1, 0.9)
OVERLAY_LINE_WIDTH = 1.5

_handle = None  # the SpaceView3D draw handler while the add-on is registered
_failures: set[str] = set()


def is_shown(scene) -> bool:
    """Whether the scene asks for the overlay (``scene.hybrid_rt.show_near_cube``)."""
    settings = getattr(scene, "hybrid_rt", None)
    return bool(getattr(settings, "show_near_cube", False))


def overlay_center(scene, region_data=None) -> np.ndarray | None:
    """The eye the near cube surrounds: the viewport's, or the scene camera's in camera view
    or without a viewport; None when there is neither."""
    if region_data is not None and region_data.view_perspective != "CAMERA":
        return np.array(region_data.view_matrix.inverted().translation, np.float64)
    if scene.camera is not None:
        return np.array(scene.camera.matrix_world.translation, np.float64)
    return None


def overlay_edges(scene, region_data=None) -> np.ndarray | None:
    """(12, 2, 3) world-space edges of the near cube for this scene and viewport, or None."""
    center = overlay_center(scene, region_data)
    if center is None:
        return None
    settings = viewport.budgeted_settings(scene, properties.settings_from_scene(scene))
    size = float(settings.near_size)
    if size <= 0.0:  # Automatic: the size the last frame took (the overlay reads no geometry)
        last = effective_values.last()
        if last is None:
            return None
        size = last.near_size
    return near_cube_edges(center, size)


def _draw() -> None:
    """POST_VIEW draw callback (world space): the cube's edges as lines."""
    context = bpy.context
    scene = context.scene
    if scene is None or scene.render.engine != "HYBRID_RT" or not is_shown(scene):
        return
    try:
        edges = overlay_edges(scene, context.region_data)
        if edges is None:
            return
        import gpu
        from gpu_extras.batch import batch_for_shader

        shader = gpu.shader.from_builtin("UNIFORM_COLOR")
        batch = batch_for_shader(shader, "LINES", {"pos": edges.reshape(-1, 3).tolist()})
        gpu.state.line_width_set(OVERLAY_LINE_WIDTH)
        gpu.state.blend_set("ALPHA")
        shader.uniform_float("color", OVERLAY_COLOR)
        batch.draw(shader)
        gpu.state.blend_set("NONE")
        gpu.state.line_width_set(1.0)
    except Exception as exc:  # noqa: BLE001 - a draw callback must not raise into Blender
        message = f"Hybrid RT near cube overlay: {exc}"
        if message not in _failures:  # once, not on every redraw
            _failures.add(message)
            print(message)


def _overlay_popover(self, context) -> None:
    """The toggle in the 3D viewport's Overlays popover, under Guides."""
    if context.scene is not None and context.engine == "HYBRID_RT":
        self.layout.prop(context.scene.hybrid_rt, "show_near_cube", text="Hybrid RT Near Cube")


def register() -> None:
    global _handle
    _handle = bpy.types.SpaceView3D.draw_handler_add(_draw, (), "WINDOW", "POST_VIEW")
    popover = getattr(bpy.types, "VIEW3D_PT_overlay_guides", None)
    if popover is not None:
        popover.append(_overlay_popover)


def unregister() -> None:
    global _handle
    popover = getattr(bpy.types, "VIEW3D_PT_overlay_guides", None)
    if popover is not None:
        popover.remove(_overlay_popover)
    if _handle is not None:
        bpy.types.SpaceView3D.draw_handler_remove(_handle, "WINDOW")
        _handle = None
