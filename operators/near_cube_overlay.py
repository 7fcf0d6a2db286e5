# SPDX-License-Identifier: GPL-3.0-or-later
"""``hybrid_rt.show_near_cube``: toggle a 3D-viewport overlay of the near cube's bounds.

The near cube (paper §3: half-size ``scene.hybrid_rt.near_size`` around the eye) decides
which geometry is ray traced through the per-frame BVH and which is ray marched in the cube
map; seeing it helps choose ``near_size``. It is centred where the frame is rendered from:
the scene camera in camera view (and when no viewport is at hand), otherwise the viewport's
own eye. The 12 edges come from ``hybrid_engine.viewport_frame.near_cube_edges``; only the
line drawing uses Blender's ``gpu`` module, imported when a viewport actually draws, so the
operator registers and toggles in background Blender too.
"""
from __future__ import annotations

import bpy
import numpy as np

from ..hybrid_engine.viewport_frame import near_cube_edges

OVERLAY_COLOR = (1.0, 0.55, 0.1, 0.9)
OVERLAY_LINE_WIDTH = 1.5

_handle = None  # the SpaceView3D draw handler while the overlay is shown


def is_enabled() -> bool:
    return _handle is not None


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
    return near_cube_edges(center, float(scene.hybrid_rt.near_size))


def _draw() -> None:
    """POST_VIEW draw callback (world space): the cube's edges as lines."""
    context = bpy.context
    scene = context.scene
    if scene is None or scene.render.engine != "HYBRID_RT":
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
        print(f"Hybrid RT near cube overlay: {exc}")
        set_enabled(False)


def set_enabled(enabled: bool) -> None:
    global _handle
    if enabled and _handle is None:
        _handle = bpy.types.SpaceView3D.draw_handler_add(_draw, (), "WINDOW", "POST_VIEW")
    elif not enabled and _handle is not None:
        bpy.types.SpaceView3D.draw_handler_remove(_handle, "WINDOW")
        _handle = None


def _redraw_viewports(context) -> None:
    screen = getattr(context, "screen", None)
    for area in (screen.areas if screen is not None else ()):
        if area.type == "VIEW_3D":
            area.tag_redraw()


class HYBRID_RT_OT_show_near_cube(bpy.types.Operator):
    """Show or hide the near cube (ray traced region around the eye) in the 3D viewport"""

    bl_idname = "hybrid_rt.show_near_cube"
    bl_label = "Show Near Cube"
    bl_options = {"REGISTER"}

    def execute(self, context):
        set_enabled(not is_enabled())
        _redraw_viewports(context)
        self.report({"INFO"}, f"Near cube overlay {'shown' if is_enabled() else 'hidden'}")
        return {"FINISHED"}


def register() -> None:
    bpy.utils.register_class(HYBRID_RT_OT_show_near_cube)


def unregister() -> None:
    set_enabled(False)
    bpy.utils.unregister_class(HYBRID_RT_OT_show_near_cube)
