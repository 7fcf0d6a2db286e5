# SPDX-License-Identifier: GPL-3.0-or-later
"""Material, World and Light previews (``RenderEngine.render`` with ``is_preview``).

Blender renders a preview of the ID being edited on its own preview scene (a sphere or cube
on a floor, its lamps and World), small (128x128 for the Properties editor), on a job
thread, and often: every edit of a material re-renders it. So a preview takes a cheap path:

- one sample, no denoiser, a small cube map and small shadow maps, no per-pass timing;
- its own ``Renderer``: no GL target, cube map or denoiser history is shared with the
  viewport's sessions or with F12's renderer, so a preview never changes what they draw next;
- the preview scene is read afresh (``extract_scene``) and nothing is written to any ID, nor
  kept of the artist's scene (F12's Persistent Data cache is F12's alone).

The GL runs under ``gl_block()``, which takes the one context over from whichever thread held
it and hands it back (hybrid_engine/gpu/gl_context.py), so a preview on Blender's job thread
and a viewport frame on the main thread never run GL at the same time.
"""
from __future__ import annotations

import threading
from dataclasses import replace

import numpy as np

from ..hybrid_engine.frame.antialias import render_antialiased
from ..hybrid_engine.frame.film import FrameOutputs
from ..hybrid_engine.frame.renderer import FrameResult, Renderer
from ..hybrid_engine.scene.settings import RenderSettings
from . import messages
from .export.camera import camera_from_scene
from .gl_host import gl_block
from .scene_cache import extract_scene

# The preview's cheap path: a 128-pixel preview sees the cube map's faces at about its own
# size, so a larger map would only cost; the shadow maps likewise.
PREVIEW_SETTINGS = replace(RenderSettings(), cube_resolution=128, shadow_resolution=256, render_samples=1,
                           viewport_samples=1, near_cube_mode="FIXED", denoise_viewport=False,
                           denoise_render=False)

_renderer: Renderer | None = None
# Previews of several IDs may be rendered by more than one job thread; they take turns on the
# one preview renderer (gl_block serialises the GL, this the renderer's own state).
_renderer_lock = threading.Lock()


def render_preview(depsgraph, cancel=None) -> FrameResult:
    """Render Blender's preview scene (``depsgraph``) with the cheap settings: one sample of
    the whole frame, opaque, untimed."""
    global _renderer
    # Blender's preview scene is Blender's: what its own materials use (the hidden floor's
    # alpha, say) is nothing the artist can change, and what the previewed material uses
    # reaches the artist from the viewport and F12. A preview tells nothing.
    with messages.collecting():
        scene_data = extract_scene(depsgraph)
    camera = camera_from_scene(depsgraph.scene, depsgraph)
    with _renderer_lock, gl_block():
        if _renderer is None:
            _renderer = Renderer()
        return render_antialiased(_renderer, scene_data, camera, PREVIEW_SETTINGS, 1, outputs=FrameOutputs(),
                                  timing=False, cancel=cancel, denoise=False)


def write_result(engine, result: FrameResult) -> None:
    """Hand the preview's image to Blender (it lands in the ID's ``preview``)."""
    height, width = result.image.shape[:2]
    render_result = engine.begin_result(0, 0, width, height)
    try:
        combined = render_result.layers[0].passes["Combined"]
        combined.rect.foreach_set(np.ascontiguousarray(result.image, np.float32).ravel())
    finally:
        engine.end_result(render_result)


def release() -> None:
    """Free the preview renderer's GL objects (on unregister)."""
    global _renderer
    with _renderer_lock:
        renderer, _renderer = _renderer, None
        if renderer is not None:
            with gl_block():
                renderer.release()
