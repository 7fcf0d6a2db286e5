# SPDX-License-Identifier: GPL-3.0-or-later
"""The frame: plain scene arrays in, image plus per-pass timings and counts out.

``Renderer`` owns the GPU state of one consumer (a final render, a viewport) on the shared
process-wide context and keeps it across frames; ``render()`` runs the passes of paper §3
for the selected mode:

==========  ===================================================================================
RASTER      upload, shadow_maps, primary_raster, shade (specular lobes see the sky), readback
HYBRID      upload, shadow_maps, primary_raster, cube_map_raster (§3.2), cull + lbvh_build
            (§3.3), shade (emission + diffuse), trace (§3.4), readback
FULL_BVH    as HYBRID without the cube map and the culling: the LBVH holds the whole scene
            (the paper's ground truth)
PROVENANCE  upload, shadow_maps, primary_raster, shade, trace (which only decides where each
            specular pixel's first secondary ray starts: BVH blue, cube map red; Figure 4)
BOUNCES,    as HYBRID; the trace also counts, per pixel, bounces, cube-map steps, BVH nodes
CUBE_STEPS, or where one bounce's rays ended, and the image shows that count in false colour
BVH_NODES,  with a legend (trace/diagnostic_views.py; FrameResult.diagnostic holds the counts)
BOUNCE_PATHS
==========  ===================================================================================

``shade`` is the screen-space ambient occlusion (screen_ao.py) and the deferred shading of
the primary G-buffer, lit by one FrameResources (lights, shadow atlas, World light) that the
trace pass receives too.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..gpu import gl_context
from ..gpu.timing import PassTimer
from ..passes.gbuffer.gbuffer import GBufferPass
from ..passes.lighting.resources import FrameResources
from ..passes.scene_upload.scene_buffers import GPUScene
from ..passes.shading.deferred_shade import DeferredShadePass
from ..passes.shading.screen_ao import ScreenSpaceOcclusion
from ..passes.shadow_maps.shadow_depth import ShadowDepthPass
from ..passes.trace.diagnostic_views import LegendEntry, is_diagnostic, legend
from ..passes.trace.tracer import HybridTracer
from ..passes.view_cull.draw import SceneDrawer
from ..scene.camera import Camera
from ..scene.changes import GeometryTracker
from ..scene.data import SceneData
from ..scene.raster_view import RasterView
from ..scene.settings import DIAGNOSTIC_VIEWS, RenderSettings
from .film import FrameOutputs, depth_pass, normal_pass

CancelCallback = Callable[[], bool]
ProgressCallback = Callable[[str, float], None]


class RenderCancelled(Exception):
    """The caller's cancel callback asked to stop (Blender's test_break())."""


MODE_STEPS = {
    "RASTER": ("upload", "shadow_maps", "primary_raster", "shade", "readback"),
    "HYBRID": ("upload", "shadow_maps", "primary_raster", "cube_map_raster", "cull", "lbvh_build",
               "shade", "trace", "readback"),
    "FULL_BVH": ("upload", "shadow_maps", "primary_raster", "lbvh_build", "shade", "trace", "readback"),
    "PROVENANCE": ("upload", "shadow_maps", "primary_raster", "shade", "trace", "readback"),
}
MODE_STEPS.update({view: MODE_STEPS["HYBRID"] for view in DIAGNOSTIC_VIEWS})


@dataclass
class FrameResult:
    """One rendered frame.

    ``image`` is (H, W, 4) float32 linear RGBA, row 0 at the bottom (Blender's and OpenGL's
    order), alpha 0 on the background with transparent film. ``passes`` maps pass names to
    milliseconds (empty when timing is off); ``counts`` holds triangle and ray counts;
    ``timing_source`` says how time was measured. ``data_passes`` holds the data passes the
    frame was asked for (film.FrameOutputs: "depth" (H, W), "normal" (H, W, 3)), same rows.
    """

    image: np.ndarray
    passes: dict[str, float] = field(default_factory=dict)
    counts: dict[str, int] = field(default_factory=dict)
    timing_source: str = "off"
    total_ms: float = 0.0
    mode: str = "RASTER"
    data_passes: dict[str, np.ndarray] = field(default_factory=dict)
    near_size: float | None = None  # the near cube's half-size the frame used (HYBRID)
    # A diagnostic view's per-pixel counts (H, W), same rows as ``image``, and the legend of
    # its colours, which whoever shows the image paints (passes/trace/diagnostic_views.py).
    diagnostic: np.ndarray | None = None
    legend: list[LegendEntry] = field(default_factory=list)


class Renderer:
    """GPU state for rendering frames; create once, call ``render`` every frame."""

    def __init__(self, ctx=None) -> None:
        self.ctx = ctx if ctx is not None else gl_context.get_context()
        self.gpu_scene = GPUScene(self.ctx)
        # The G-buffer and shadow passes draw the scene through one drawer (view_cull/draw.py).
        self.drawer = SceneDrawer(self.ctx)
        self.shadow_depth = ShadowDepthPass(self.ctx, self.drawer)
        self.gbuffer = GBufferPass(self.ctx, self.drawer)
        self.resources = FrameResources(self.ctx)  # lights, shadow atlas, World light
        self.occlusion = ScreenSpaceOcclusion(self.ctx)
        self.deferred_shade = DeferredShadePass(self.ctx)
        self.tracer: HybridTracer | None = None  # created on the first non-RASTER frame
        # Frame-to-frame reuse: only changed triangles are re-uploaded, and of the shadow
        # maps only the layer whose objects changed is re-rendered (shadow_cache.py).
        self.geometry_tracker = GeometryTracker()
        # What the tracer's cube map and BVH were built for (render(reuse_world=True)).
        self._world_key: tuple | None = None

    def render(
        self,
        scene: SceneData,
        camera: Camera,
        settings: RenderSettings | None = None,
        *,
        timing: bool = True,
        cancel: CancelCallback | None = None,
        progress: ProgressCallback | None = None,
        outputs: FrameOutputs | None = None,
        reuse_world: bool = False,
        sample: int = 0,
    ) -> FrameResult:
        """Render one frame. Raises RenderCancelled when ``cancel()`` returns True between
        passes; the GPU state stays valid for the next frame. ``outputs`` asks for
        transparent film and data passes (film.py); by default the frame is opaque and has
        none.

        ``reuse_world``: this frame sees the last frame's scene from the same point (another
        sample of one pixel grid, antialias.py), so the cube map and the BVH, which depend
        only on the geometry, the settings and the camera's position, are kept instead of
        rebuilt. Honoured only when that holds: the same ``scene`` object and settings, the
        same position, no triangle changed and the last frame completed.

        ``sample`` numbers this frame among the samples of one view (antialias.py, the
        viewport's accumulation): the stochastic parts of the shading (glossy lobes,
        ambient occlusion) draw different directions for each, so that their average
        converges."""
        settings = settings or RenderSettings()
        outputs = outputs or FrameOutputs()
        steps = MODE_STEPS[settings.mode]  # RenderSettings admits no other mode
        traced = settings.mode != "RASTER"
        if traced and self.tracer is None:
            self.tracer = HybridTracer(self.ctx, self.gbuffer)
        tracer = self.tracer
        timer = PassTimer(self.ctx, enabled=timing)
        start = time.perf_counter()

        def step(name: str) -> None:
            if cancel is not None and cancel():
                raise RenderCancelled(f"cancelled before {name}")
            if progress is not None:
                progress(name, steps.index(name) / len(steps))

        counts: dict[str, int] = {}
        center = np.asarray(camera.position, np.float64)
        world_key = (id(scene), settings, center)
        kept_world = reuse_world and traced and self._same_world(world_key)
        self._world_key = None  # set again once this frame's world is complete
        step("upload")
        with timer.measure("upload"):
            delta = self.geometry_tracker.update(scene.geometry)
            self.gpu_scene.upload(scene, delta)
            if traced:
                tracer.upload(self.gpu_scene, scene, delta)
        counts["triangles_uploaded"] = int(delta.changed_triangles)
        if self.gpu_scene.uv_rows_resident:  # instanced geometry: made on the GPU
            moved = self.gpu_scene.instance_transform.stats
            counts["instances_written"] = moved.instances_written
            counts["meshes_uploaded"] = moved.meshes_uploaded
            counts["triangles_transformed"] = moved.triangles_transformed
        kept_world = kept_world and delta.unchanged
        step("shadow_maps")
        with timer.measure("shadow_maps"):
            shadows = self.shadow_depth.render(self.gpu_scene, scene, camera, settings, self.resources.shadows,
                                             delta)
            counts.update(shadows.counts())
            self.resources.update_lights(scene.lights, shadows.per_light, settings)
            self.resources.update_sky(scene.sky)
        step("primary_raster")
        view = RasterView.from_camera(camera)
        with timer.measure("primary_raster"):
            targets, submitted = self.gbuffer.render_primary(self.gpu_scene, scene, view)
        if "cube_map_raster" in steps and not kept_world:
            step("cube_map_raster")
            with timer.measure("cube_map_raster"):
                counts["triangles_cube_map_submitted"] = int(
                    tracer.render_cube_map(self.gpu_scene, scene, center, settings))
        culled = None
        if "cull" in steps and not kept_world:
            step("cull")
            with timer.measure("cull"):
                culled = tracer.cull(scene, center, settings)
            counts.update(objects_near_inside=culled.objects_inside,
                          objects_near_straddling=culled.objects_straddling,
                          objects_near_outside=culled.objects_outside)
        if "lbvh_build" in steps and not kept_world:
            step("lbvh_build")
            with timer.measure("lbvh_build"):
                tracer.build(culled)
        step("shade")
        with timer.measure("shade"):
            if settings.traces_sky:
                tracer.gather_world_light(self.gpu_scene, scene, view, targets, self.resources, settings,
                                          center, sample=sample)
            else:
                self.occlusion.run(targets, view, self.resources, sample)
            self.deferred_shade.run(self.gpu_scene, view, targets, self.resources,
                                    traced_specular=traced, transparent=outputs.transparent, sample=sample)
        if "trace" in steps:
            step("trace")
            with timer.measure("trace"):
                tracer.trace(self.gpu_scene, scene, view, targets, self.resources, settings, center,
                             sample=sample)
        step("readback")
        with timer.measure("readback"):
            image = targets.read_color()
            data = self._data_passes(targets, camera, outputs)
            if traced and settings.mode != "PROVENANCE":
                counts.update(tracer.read_stats(settings.max_depth).as_counts())
            diagnostic = None
            if is_diagnostic(settings):
                diagnostic = tracer.read_diagnostic(view)
        self._world_key = world_key if traced else None
        if gl_context.debug_checks_enabled():
            gl_context.check_error(f"{settings.mode} frame")
        if progress is not None:
            progress("done", 1.0)
        total = (time.perf_counter() - start) * 1e3
        counts = {
            "triangles_total": scene.geometry.triangle_count,
            "triangles_primary_submitted": int(submitted),
            "lights": len(scene.lights),
            **counts,
        }
        return FrameResult(image=image, passes=dict(timer.passes), counts=counts,
                           timing_source=timer.source, total_ms=total, mode=settings.mode,
                           data_passes=data, diagnostic=diagnostic,
                           legend=legend(settings) if diagnostic is not None else [],
                           near_size=float(settings.near_size) if "cube_map_raster" in steps else None)

    def _same_world(self, key: tuple) -> bool:
        """Whether ``key`` (scene object, settings, eye) is what the kept cube map and BVH
        were built for. The eye is compared to a relative 1e-9: a jittered camera's position
        comes back through a matrix inverse (antialias.jittered_camera)."""
        if self._world_key is None:
            return False
        scene_id, settings, center = key
        old_id, old_settings, old_center = self._world_key
        scale = 1.0 + float(np.max(np.abs(center)))
        return (scene_id == old_id and settings == old_settings
                and float(np.max(np.abs(center - old_center))) <= 1e-9 * scale)

    @staticmethod
    def _data_passes(targets, camera: Camera, outputs: FrameOutputs) -> dict[str, np.ndarray]:
        """The data passes ``outputs`` asks for, from the primary G-buffer (read back only
        then: a frame without passes reads nothing more)."""
        data = {}
        if outputs.depth:
            data["depth"] = depth_pass(targets.read("depth")[..., 0], camera)
        if outputs.normal:
            data["normal"] = normal_pass(targets.read("normal_material"))
        return data

    def release(self) -> None:
        """Free this renderer's GL objects (the shared context stays)."""
        if self.tracer is not None:
            self.tracer.release()
            self.tracer = None
        self.gbuffer.release()
        self.drawer.release()
        self.resources.release()
        self.gpu_scene.release()
