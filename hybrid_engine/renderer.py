# SPDX-License-Identifier: GPL-3.0-or-later
"""The frame: plain scene arrays in, image plus per-pass timings and counts out.

``Renderer`` owns the GPU state of one consumer (a final render, a viewport) on the shared
process-wide context and keeps it across frames; ``render()`` runs the passes of paper §3
for the selected mode. RASTER runs steps 1 and 4 of §3 (primary G-buffer and deferred
shading with shadow maps); the other modes add the cube map, the near-cube LBVH and the
recursive tracer on top of the same passes.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from . import gl_context
from .camera import Camera
from .gpu_scene import GPUScene
from .raster import RasterPasses, RasterView
from .scene_data import SceneData
from .settings import RenderSettings
from .timing import PassTimer

CancelCallback = Callable[[], bool]
ProgressCallback = Callable[[str, float], None]


class RenderCancelled(Exception):
    """The caller's cancel callback asked to stop (Blender's test_break())."""


class RenderModeUnavailable(NotImplementedError):
    """The requested mode needs passes that this build does not provide."""


@dataclass
class FrameResult:
    """One rendered frame.

    ``image`` is (H, W, 4) float32 linear RGBA, row 0 at the bottom (Blender's and OpenGL's
    order). ``passes`` maps pass names to milliseconds (empty when timing is off);
    ``counts`` holds triangle and ray counts; ``timing_source`` says how time was measured.
    """

    image: np.ndarray
    passes: dict[str, float] = field(default_factory=dict)
    counts: dict[str, int] = field(default_factory=dict)
    timing_source: str = "off"
    total_ms: float = 0.0
    mode: str = "RASTER"


class Renderer:
    """GPU state for rendering frames; create once, call ``render`` every frame."""

    def __init__(self, ctx=None) -> None:
        self.ctx = ctx if ctx is not None else gl_context.get_context()
        self.gpu_scene = GPUScene(self.ctx)
        self.raster = RasterPasses(self.ctx)

    def render(
        self,
        scene: SceneData,
        camera: Camera,
        settings: RenderSettings | None = None,
        *,
        timing: bool = True,
        cancel: CancelCallback | None = None,
        progress: ProgressCallback | None = None,
    ) -> FrameResult:
        """Render one frame. Raises RenderCancelled when ``cancel()`` returns True between
        passes; the GPU state stays valid for the next frame."""
        settings = settings or RenderSettings()
        if settings.mode != "RASTER":
            raise RenderModeUnavailable(
                f"render mode {settings.mode} needs the hybrid tracer, which is not built yet; "
                "use RASTER"
            )
        timer = PassTimer(self.ctx, enabled=timing)
        start = time.perf_counter()
        steps = ("upload", "shadow_maps", "primary_raster", "shade", "readback")

        def step(name: str) -> None:
            if cancel is not None and cancel():
                raise RenderCancelled(f"cancelled before {name}")
            if progress is not None:
                progress(name, steps.index(name) / len(steps))

        step("upload")
        with timer.measure("upload"):
            self.gpu_scene.upload(scene)
        step("shadow_maps")
        with timer.measure("shadow_maps"):
            per_light = self.raster.shadows(self.gpu_scene, scene, settings)
            self.gpu_scene.upload_lights(scene.lights, per_light)
        step("primary_raster")
        view = RasterView.from_camera(camera)
        with timer.measure("primary_raster"):
            targets = self.raster.primary_targets(view.width, view.height)
            targets.clear()
            submitted = self.raster.gbuffer(self.gpu_scene, scene, view, targets)
        step("shade")
        with timer.measure("shade"):
            self.raster.shade(self.gpu_scene, scene, view, targets, settings)
        step("readback")
        with timer.measure("readback"):
            image = targets.read_color()
        if gl_context.debug_checks_enabled():
            gl_context.check_error(f"{settings.mode} frame")
        if progress is not None:
            progress("done", 1.0)
        total = (time.perf_counter() - start) * 1e3
        counts = {
            "triangles_total": scene.geometry.triangle_count,
            "triangles_primary_submitted": int(submitted),
            "lights": len(scene.lights),
        }
        return FrameResult(image=image, passes=dict(timer.passes), counts=counts,
                           timing_source=timer.source, total_ms=total, mode=settings.mode)

    def release(self) -> None:
        """Free this renderer's GL objects (the shared context stays)."""
        self.raster.release()
        self.gpu_scene.release()
