# SPDX-License-Identifier: GPL-3.0-or-later
"""The ``HYBRID_RT`` RenderEngine: a thin layer over ``hybrid_engine.Renderer``.

Each callback forwards to plain functions; no exception escapes a Blender callback (it is
reported to the user with ``error_set`` and the console gets the traceback). The renderer
and its GPU state live at module level because Blender creates a new engine instance for
every render; they are released on unregister.
"""
from __future__ import annotations

import time
import traceback
from dataclasses import replace

import bpy
import numpy as np

from ..hybrid_engine.renderer import FrameResult, RenderCancelled, Renderer, RenderModeUnavailable
from . import extract, properties, viewport
from .gl_host import gl_block

_renderer: Renderer | None = None
last_frame: FrameResult | None = None  # the most recent final render's result (image, passes, counts)


def shared_renderer() -> Renderer:
    """The process's final-render Renderer (created on first use, GL state kept)."""
    global _renderer
    if _renderer is None:
        _renderer = Renderer()
    return _renderer


def release_renderer() -> None:
    global _renderer
    if _renderer is not None:
        try:
            with gl_block():
                _renderer.release()
        finally:
            _renderer = None


def render_depsgraph(depsgraph, *, cancel=None, progress=None, report=None) -> FrameResult:
    """Extract the evaluated scene and render one frame with the scene's settings.

    Modes this build cannot render yet fall back to RASTER with a warning through
    ``report(level, message)``, so a user always gets an image.
    """
    scene = depsgraph.scene
    settings = properties.settings_from_scene(scene)
    start = time.perf_counter()
    scene_data = extract.extract_scene(depsgraph)
    camera = extract.camera_from_scene(scene, depsgraph)
    extract_ms = (time.perf_counter() - start) * 1e3
    with gl_block():
        renderer = shared_renderer()
        try:
            result = renderer.render(scene_data, camera, settings, cancel=cancel, progress=progress)
        except RenderModeUnavailable as exc:
            if report is not None:
                report({"WARNING"}, f"{exc}; rendering RASTER instead")
            result = renderer.render(scene_data, camera, replace(settings, mode="RASTER"),
                                     cancel=cancel, progress=progress)
    result.passes = {"extract": extract_ms, **result.passes}
    result.total_ms += extract_ms
    return result


class HybridRTRenderEngine(bpy.types.RenderEngine):
    """Hybrid rasterization + ray tracing (Ganestam & Doggett 2014)."""

    bl_idname = "HYBRID_RT"
    bl_label = "Hybrid RT"
    bl_use_preview = False
    bl_use_shading_nodes_custom = False  # materials are edited with Blender's own nodes
    bl_use_eevee_viewport = True  # Material Preview uses EEVEE
    # The viewport renders in its own EGL context and uploads the image through ``gpu``;
    # it needs no Blender GPU context during view_update.
    bl_use_gpu_context = False

    def render(self, depsgraph) -> None:
        try:
            self._render(depsgraph)
        except RenderCancelled:
            pass
        except Exception as exc:  # noqa: BLE001 - nothing may escape a Blender callback
            traceback.print_exc()
            message = f"Hybrid RT: {exc}"
            self.report({"ERROR"}, message)
            self.error_set(message)

    def _render(self, depsgraph) -> None:
        def progress(step: str, fraction: float) -> None:
            self.update_progress(fraction)
            self.update_stats("", f"Hybrid RT | {step}")

        global last_frame
        result = render_depsgraph(depsgraph, cancel=self.test_break, progress=progress, report=self.report)
        last_frame = result
        height, width = result.image.shape[:2]
        render_result = self.begin_result(0, 0, width, height)
        try:
            combined = render_result.layers[0].passes["Combined"]
            combined.rect.foreach_set(np.ascontiguousarray(result.image, np.float32).ravel())
        finally:
            self.end_result(render_result)
        triangles = result.counts.get("triangles_total", 0)
        self.update_stats(
            "", f"Hybrid RT | {result.mode} | {result.total_ms:.1f} ms | {triangles:,} triangles"
        )


    # -- viewport (blender_adapter/viewport.py does the work) --------------------------------
    def view_update(self, context, depsgraph) -> None:
        try:
            viewport.view_update(self, context, depsgraph)
        except Exception as exc:  # noqa: BLE001 - nothing may escape a Blender callback
            viewport.callback_failed(self, "view_update", exc)

    def view_draw(self, context, depsgraph) -> None:
        try:
            viewport.view_draw(self, context, depsgraph)
        except Exception as exc:  # noqa: BLE001 - nothing may escape a Blender callback
            viewport.callback_failed(self, "view_draw", exc)


def register() -> None:
    bpy.utils.register_class(HybridRTRenderEngine)
    viewport.register()


def unregister() -> None:
    viewport.unregister()
    release_renderer()
    bpy.utils.unregister_class(HybridRTRenderEngine)
