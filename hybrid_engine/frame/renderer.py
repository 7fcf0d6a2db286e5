# SPDX-License-Identifier: GPL-3.0-or-later
"""The frame: plain scene arrays in, image plus per-pass timings and counts out.

``Renderer`` owns the passes of one consumer (a final render, a viewport) on the shared
process-wide context and keeps them across frames; ``render()`` runs the passes of paper §3
for the selected mode, in this order, each a folder of ``hybrid_engine/passes/`` taking one
``FrameContext`` (passes/frame_context.py):

==========  ===================================================================================
RASTER      upload, instance_transform, shadow_maps, lighting, primary_raster, shade (specular
            lobes see the sky), readback
HYBRID      upload, instance_transform, shadow_maps, lighting, primary_raster, cube_map_raster
            (§3.2), cull + lbvh_build (§3.3), shade (emission + diffuse), trace (§3.4),
            readback
FULL_BVH    as HYBRID without the cube map and the culling: the LBVH holds the whole scene
            (the paper's ground truth)
PROVENANCE  as RASTER, then trace (which only decides where each specular pixel's first
            secondary ray starts: BVH blue, cube map red; Figure 4)
BOUNCES,    as HYBRID; the trace also counts, per pixel, bounces, cube-map steps, BVH nodes
CUBE_STEPS, or where one bounce's rays ended, and the image shows that count in false colour
BVH_NODES,  (trace/diagnostic_views.py; FrameResult.diagnostic holds the counts and
BOUNCE_PATHS FrameResult.legend what the colours mean)
==========  ===================================================================================

A frame that accumulates (``render(accumulate=True)``: the viewport's redraws, a final
render's samples) ends with ``accumulate``, the running mean of the view's samples on the
GPU, and reads that back instead of the one sample: once per frame, or not at all before a
final render's last sample.

``shade`` is the diffuse light (traced paths, passes/diffuse_light/, or with World Light
Screen Space the screen-space occlusion) and the deferred shading of the primary G-buffer, lit by the frame's
``lighting`` resource, which the trace pass reads too. A frame rendered with ``denoise``
filters the diffuse light between the two (passes/denoise/, step ``denoise``), and the
filter's history follows the camera from one such frame to the next. Each pass declares what it reads and
writes; the renderer checks the order once per configuration, before its first frame
(``check_order``), and the frame lets a pass touch only what it declared.

Nothing in a frame waits for the GPU before its end: the near-cube cull's kept count stays on
the GPU for the LBVH build (gpu/device_count.py), the passes' counters are copied into a
statistics ring on the GPU and read only when a caller asks for ``FrameResult.counts``
(gpu/statistics.py), and per-pass timing, which brackets every pass with ``ctx.finish()``, is
off unless asked for. The frame's one wait is reading its image back.
"""
from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..gpu import gl_context
from ..gpu.dispatch import pass_barrier
from ..gpu.statistics import LazyCounts, StatisticsRing
from ..gpu.timing import PassTimer
from ..passes.film.accumulate import AccumulatePass
from ..passes.film.cryptomatte import CryptomattePass
from ..passes.film.data_passes import DataPassesPass, read_data_passes
from ..passes.film.light_passes import LightPassesPass, read_light_passes
from ..passes.film.vector import VectorPass
from ..passes.surface_motion.surface_motion import SurfaceMotionPass
from ..passes.cube_light.cube_light import CubeLightPass
from ..passes.cube_map.cube_map import CubeMapPass
from ..passes.emitters.emitter_pass import EmitterTablePass
from ..passes.diffuse_light.diffuse_light import DiffuseLightPass
from ..passes.denoise.denoise import DenoisePass
from ..passes.frame_context import FrameContext, FramePass, check_order
from ..passes.gbuffer.gbuffer import GBufferPass
from ..passes.lbvh.build_pass import LBVHBuildPass
from ..passes.lbvh.lbvh import BuiltLBVH, LBVHBuilder
from ..passes.lighting.resources import FrameResources, LightingPass
from ..passes.near_cube_cull.near_cube import NearCubeCuller
from ..passes.scene_upload.scene_buffers import GPUScene
from ..passes.scene_upload.upload_passes import InstanceTransformPass, SceneUploadPass
from ..passes.shading.deferred_shade import DeferredShadePass
from ..passes.shading.screen_ao import ScreenSpaceOcclusion
from ..passes.shadow_maps.shadow_depth import ShadowDepthPass
from ..passes.trace.diagnostic_views import LegendEntry, is_diagnostic, legend
from ..passes.trace.tracer import HybridTracer
from ..passes.view_cull.draw import SceneDrawer
from ..scene.camera import Camera
from ..scene.data import SceneData
from ..scene.raster_view import RasterView
from ..scene.scale import EffectiveValues, resolve
from ..scene.settings import DIAGNOSTIC_VIEWS, RenderSettings
from .film import FrameOutputs
from .readback import ImageReadback

CancelCallback = Callable[[], bool]
ProgressCallback = Callable[[str, float], None]


class RenderCancelled(Exception):
    """The caller's cancel callback asked to stop (Blender's test_break())."""


# The steps of each mode as timing reports name them (several passes may share a step).
_RASTER = ("upload", "instance_transform", "shadow_maps", "lighting", "primary_raster")
MODE_STEPS = {
    "RASTER": (*_RASTER, "shade", "readback"),
    "HYBRID": (*_RASTER, "cube_map_raster", "cull", "lbvh_build", "shade", "trace", "readback"),
    "FULL_BVH": (*_RASTER, "lbvh_build", "shade", "trace", "readback"),
    "PROVENANCE": (*_RASTER, "shade", "trace", "readback"),
}
MODE_STEPS.update({view: MODE_STEPS["HYBRID"] for view in DIAGNOSTIC_VIEWS})


def frame_steps(mode: str, accumulate: bool = False, data: bool = False, lit_cube: bool = False,
                denoise: bool = False, cryptomatte: bool = False, light: bool = False,
                vector: bool = False) -> tuple[str, ...]:
    """The steps of a frame of ``mode`` (RenderSettings admits no other); one that
    accumulates adds ``accumulate``, one with data passes ``data_passes``, before the
    read-back; the lit cube map (``lit_cube``) adds ``cube_light`` after the cube map, and one
    that denoises ``denoise`` after the diffuse light (within ``shade``), one with Cryptomatte
    passes ``cryptomatte`` after the data passes; light passes ``light_passes`` after the
    accumulation; the Vector pass ``vector`` last."""
    steps = MODE_STEPS[mode]
    if lit_cube and "cube_map_raster" in steps:
        at = steps.index("cube_map_raster") + 1
        steps = (*steps[:at], "cube_light", *steps[at:])
    if denoise:
        at = steps.index("shade") + 1
        steps = (*steps[:at], "denoise", *steps[at:])
    extra = (("accumulate",) * accumulate + ("light_passes",) * light + ("data_passes",) * data
             + ("cryptomatte",) * cryptomatte + ("vector",) * vector)
    return (*steps[:-1], *extra, steps[-1])
# The passes that depend only on the geometry, the settings and the eye, and what they leave:
# another sample of one view keeps them (render(reuse_world=True)).
WORLD_PASSES = ("cube_map_raster", "cull", "lbvh_build")
WORLD_RESOURCES = ("cube_map", "near_triangles", "bvh")
# What the frame's end reads back: the image, and the G-buffer for the data passes.
READBACK_READS = ("color", "gbuffer")


@dataclass
class FrameResult:
    """One rendered frame.

    ``image`` is (H, W, 4) float32 linear RGBA, row 0 at the bottom (Blender's and OpenGL's
    order), alpha 0 on the background with transparent film. ``passes`` maps pass names to
    milliseconds (empty when timing is off); ``counts`` holds triangle and ray counts, the
    GPU's read back on first access (a ``LazyCounts``: a caller that never looks reads
    nothing); ``timing_source`` says how time was measured. ``data_passes`` holds the data passes the
    frame was asked for (film.FrameOutputs: "depth" (H, W), the others (H, W, 3)), same rows.
    """

    image: np.ndarray
    passes: dict[str, float] = field(default_factory=dict)
    counts: Mapping[str, int] = field(default_factory=dict)
    timing_source: str = "off"
    # With timing on: the main thread's CPU ms inside each pass, and on a hardware GPU the
    # GPU's own ms from timer queries (gpu/timing.py).
    host_passes: dict[str, float] = field(default_factory=dict)
    gpu_passes: dict[str, float] = field(default_factory=dict)
    total_ms: float = 0.0
    mode: str = "RASTER"
    data_passes: dict[str, np.ndarray] = field(default_factory=dict)
    metadata: dict[str, str] = field(default_factory=dict)  # the image's (Cryptomatte's manifest)
    near_size: float | None = None  # the near cube's half-size the frame used (HYBRID)
    # The near size, far clip and face resolution the frame used, Automatic ones derived
    # from the scene and the output (scene/scale.py), for the panels to show.
    effective: EffectiveValues | None = None
    # A diagnostic view's per-pixel counts (H, W), same rows as ``image``, and the legend of
    # its colours, which whoever shows the image paints (passes/trace/diagnostic_views.py).
    diagnostic: np.ndarray | None = None
    legend: list[LegendEntry] = field(default_factory=list)


class Renderer:
    """The passes of a frame on the shared context; create once, call ``render`` every frame."""

    def __init__(self, ctx=None, gather_seed: int = 0) -> None:
        # gather_seed: which set of numbers the diffuse light's paths draw, 0 the product's
        # (passes/diffuse_light/; a measurement averages its figures over several).
        self.ctx = ctx if ctx is not None else gl_context.get_context()
        self.gpu_scene = GPUScene(self.ctx)
        # The G-buffer and shadow passes draw the scene through one drawer (view_cull/draw.py).
        self.drawer = SceneDrawer(self.ctx)
        self.upload = SceneUploadPass(self.gpu_scene)
        self.instance_transform = InstanceTransformPass(self.gpu_scene)
        self.shadow_maps = ShadowDepthPass(self.ctx, self.drawer)
        self.resources = FrameResources(self.ctx)  # lights and World light
        self.lighting = LightingPass(self.resources)
        self.gbuffer = GBufferPass(self.ctx, self.drawer)
        self.occlusion = ScreenSpaceOcclusion(self.ctx)
        self.deferred_shade = DeferredShadePass(self.ctx)
        self.denoiser: DenoisePass | None = None  # made on the first frame that denoises
        self.surface_motion: SurfaceMotionPass | None = None  # the instances' moves, for it
        # The running mean of a view's samples (render(accumulate=True)), and the data
        # passes a final render asks for (FrameOutputs).
        self.accumulate = AccumulatePass(self.ctx)
        self.data_passes = DataPassesPass(self.ctx)
        self.cryptomatte: CryptomattePass | None = None  # made on the first frame that asks
        self.light_passes: LightPassesPass | None = None  # Cycles' light passes, likewise
        self.vector: VectorPass | None = None  # Cycles' Vector pass, likewise
        # The traced modes' passes, made on the first frame that needs them (their kernels
        # take a while to compile).
        self.cube_map: CubeMapPass | None = None
        self.cube_light: CubeLightPass | None = None
        self.culler: NearCubeCuller | None = None
        self.lbvh: LBVHBuildPass | None = None
        self.tracer: HybridTracer | None = None
        self.diffuse_light: DiffuseLightPass | None = None
        self.gather_seed = int(gather_seed)
        self.emitters: EmitterTablePass | None = None  # the emissive triangles as lights
        # What the last frame's cube map, cull and BVH were built for, and them
        # (render(reuse_world=True)).
        self._world_key: tuple | None = None
        self._world: dict[str, object] = {}
        self._checked: set[tuple] = set()  # configurations whose pass order was checked
        self.statistics = StatisticsRing(self.ctx)  # where frames' GPU counters are copied

    # -- the passes ----------------------------------------------------------------------------
    def passes(self, settings: RenderSettings, accumulate: bool = False, data: bool = False,
               denoise: bool = False, cryptomatte: bool = False, light: bool = False,
               vector: bool = False) -> list[FramePass]:
        """This renderer's passes for ``settings``, in the order a frame runs them;
        ``accumulate`` adds the running mean of the view's samples after the colour, ``data``
        the Depth and Normal passes, ``denoise`` the filter of the ambient estimate before
        the shading reads it, ``cryptomatte`` the Cryptomatte coverage, ``light`` Cycles' light
        passes (written by the shading and the tracer, summed after the accumulation),
        ``vector`` Cycles' Vector pass."""
        mode = settings.mode
        traced = mode != "RASTER"
        if traced:
            self._ensure_traced()
        ambient = self.diffuse_light if settings.traces_diffuse else self.occlusion
        plan: list[FramePass] = [self.upload, self.instance_transform, *([self.emitters] if traced else []),
                                 self.shadow_maps, self.lighting, self.gbuffer]
        if denoise:
            if self.denoiser is None:
                self.denoiser = DenoisePass(self.ctx)
                self.surface_motion = SurfaceMotionPass(self.ctx)
            # The instances' moves, for the denoiser and the diffuse gather's history lookups.
            plan.append(self.surface_motion)
        steps = MODE_STEPS[mode]
        if "cube_map_raster" in steps:
            plan.append(self.cube_map)
            if settings.lit_cube:
                plan.append(self.cube_light)
        if "cull" in steps:
            plan.append(self.culler)
        if "lbvh_build" in steps:
            plan.append(self.lbvh)
        plan.append(ambient)
        if denoise:
            plan.append(self.denoiser)
        self.deferred_shade.light_passes = light
        plan.append(self.deferred_shade)
        if traced:
            self.tracer.light_passes = light
            plan.append(self.tracer)
        if accumulate:
            plan.append(self.accumulate)
        if light:
            if self.light_passes is None:
                self.light_passes = LightPassesPass(self.ctx)
            plan.append(self.light_passes)
        if data:
            plan.append(self.data_passes)
        if cryptomatte:
            if self.cryptomatte is None:
                self.cryptomatte = CryptomattePass(self.ctx)
            plan.append(self.cryptomatte)
        if vector:
            if self.vector is None:
                self.vector = VectorPass(self.ctx)
            plan.append(self.vector)
        return plan

    def _ensure_traced(self) -> None:
        if self.tracer is None:
            self.cube_map = CubeMapPass(self.ctx, self.gbuffer)
            self.cube_light = CubeLightPass(self.ctx)
            self.culler = NearCubeCuller(self.ctx)
            self.lbvh = LBVHBuildPass(LBVHBuilder(self.ctx))
            self.tracer = HybridTracer(self.ctx)
            self.diffuse_light = DiffuseLightPass(self.tracer, feedback=self._diffuse_feedback,
                                                  gather_seed=self.gather_seed)
            self.emitters = EmitterTablePass(self.ctx)

    def _diffuse_feedback(self):
        """The denoiser's last frame, for the diffuse gather (None before one)."""
        return self.denoiser.feedback() if self.denoiser is not None else None

    def _checked_passes(self, settings: RenderSettings, accumulate: bool, data: bool,
                        denoise: bool, cryptomatte: bool = False, light: bool = False,
                        vector: bool = False) -> list[FramePass]:
        """``passes(settings, accumulate, data, denoise, cryptomatte, light, vector)``, their order
        checked once per configuration."""
        plan = self.passes(settings, accumulate, data, denoise, cryptomatte, light, vector)
        key = (settings.mode, settings.traces_diffuse, settings.lit_cube, accumulate, data, denoise, cryptomatte,
               light, vector)
        if key not in self._checked:
            check_order(plan, settings, final_reads=READBACK_READS + (("film",) if accumulate else ()))
            self._checked.add(key)
        return plan

    @property
    def bvh(self) -> BuiltLBVH | None:
        """The BVH the last traced frame read (tests, diagnostics)."""
        return self._world.get("bvh")

    # -- a frame -------------------------------------------------------------------------------
    def render(
        self,
        scene: SceneData,
        camera: Camera,
        settings: RenderSettings | None = None,
        *,
        timing: bool = False,
        statistics: bool = True,
        cancel: CancelCallback | None = None,
        progress: ProgressCallback | None = None,
        outputs: FrameOutputs | None = None,
        reuse_world: bool = False,
        sample: int = 0,
        accumulate: bool = False,
        read_image: bool = True,
        readback: ImageReadback | None = None,
        denoise: bool = False,
    ) -> FrameResult:
        """Render one frame. Raises RenderCancelled when ``cancel()`` returns True between
        passes; the GPU state stays valid for the next frame. ``outputs`` asks for
        transparent film and data passes (film.py); by default the frame is opaque and has
        none.

        ``reuse_world``: this frame sees the last frame's scene from the same point (another
        sample of one pixel grid, antialias.py), so the cube map, the cull and the BVH, which
        depend only on the geometry, the settings and the camera's position, are kept
        instead of rebuilt. Honoured only when that holds: the same ``scene`` object and
        settings, the same position, no triangle changed and the last frame completed.

        ``sample`` numbers this frame among the samples of one view (antialias.py, the
        viewport's accumulation): the stochastic parts of the shading (glossy lobes,
        ambient occlusion) draw different directions for each, so that their average
        converges.

        ``accumulate``: the frame's image is the mean of samples 0..``sample`` of the view,
        kept on the GPU (passes/film/; sample 0 starts it over, each later one must
        follow the last). ``read_image`` False reads no image back (``image`` is None: a
        final render's samples before its last). ``readback``: the image goes to the host
        through this reader instead (frame/readback.py: a persistent array, possibly
        asynchronous), and ``image`` is the newest one it holds.

        ``timing``: bracket every pass with ``ctx.finish()`` and report its milliseconds in
        ``FrameResult.passes`` (timing reports, benchmarks); each bracket drains the GPU, so
        a frame without it waits only for its image. ``statistics``: copy the passes' GPU
        counters for ``FrameResult.counts`` (read when first asked for); without, the counts
        hold only what the host knows.

        ``denoise``: filter the ambient estimate (passes/denoise/) before the shading reads
        it; the caller decides from the settings (``denoise_viewport``, ``denoise_render``).
        The filter keeps its history from one denoised frame to the next of this renderer."""
        settings, effective = resolve(settings or RenderSettings(), scene, camera.center, camera.width,
                                      camera.height)
        outputs = outputs or FrameOutputs()
        crypto = outputs.cryptomatte is not None
        light = outputs.light is not None
        vector = outputs.vector is not None
        steps = frame_steps(settings.mode, accumulate, outputs.wants_data, settings.lit_cube, denoise, crypto, light,
                            vector)
        traced = settings.mode != "RASTER"
        data = outputs.wants_data
        plan = self._checked_passes(settings, accumulate, data, denoise, crypto, light, vector)
        if not denoise and self.denoiser is not None:
            self.denoiser.forget()  # its history would miss this frame
            self.surface_motion.forget()
        timer = PassTimer(self.ctx, enabled=timing)
        start = time.perf_counter()
        frame = FrameContext(self.ctx, scene_data=scene, camera=camera, settings=settings,
                             view=RasterView.from_camera(camera), outputs=outputs, sample=sample, denoise=denoise,
                             accumulate=accumulate)
        world_key = (id(scene), settings, frame.center)
        may_keep = reuse_world and traced and self._same_world(world_key)
        self._world_key = None  # set again once this frame's world is complete

        def step(name: str) -> None:
            if cancel is not None and cancel():
                raise RenderCancelled(f"cancelled before {name}")
            if progress is not None:
                progress(name, steps.index(name) / len(steps))

        last_step = None
        for frame_pass in plan:
            if frame_pass.name in WORLD_PASSES and may_keep and frame.resource("delta").unchanged:
                frame.provide({name: self._world[name] for name in WORLD_RESOURCES if name in self._world})
                continue
            if frame_pass.name != last_step:  # passes of one step (shade) are one step
                step(frame_pass.name)
                last_step = frame_pass.name
            with timer.measure(frame_pass.name), frame.running(frame_pass):
                frame_pass.run(frame)
                pass_barrier(self.ctx)
        step("readback")
        with timer.measure("readback"):
            result = self._read_back(frame, read_image, readback, statistics)
        if traced:
            self._world = {name: frame.resource(name) for name in WORLD_RESOURCES if frame.has(name)}
            self._world_key = world_key
        if gl_context.debug_checks_enabled():
            gl_context.check_error(f"{settings.mode} frame")
        if progress is not None:
            progress("done", 1.0)
        result.effective = effective
        result.passes = dict(timer.passes)
        result.host_passes = dict(timer.host_passes)
        result.gpu_passes = dict(timer.gpu_passes)
        result.timing_source = timer.source
        result.total_ms = (time.perf_counter() - start) * 1e3
        return result

    def _read_back(self, frame: FrameContext, read_image: bool, readback: ImageReadback | None,
                   statistics: bool = True) -> FrameResult:
        """The frame's image, data passes and diagnostic counts, read from the GPU, and its
        counts: the host's, and the GPU's copied into the statistics ring (after the last
        pass, before the image is read) to be read when first asked for."""
        settings = frame.settings
        pending = self.statistics.collect(frame.statistics) if statistics else None
        targets = frame.resource("gbuffer")
        texture = frame.resource("film").mean if frame.has("film") else targets.color
        image = None
        if readback is not None:
            readback.submit(texture, tag=frame.sample)
            image = readback.image
        elif read_image:
            image = np.empty((texture.height, texture.width, 4), np.float32)
            texture.read_into(image)
        names = frame.outputs.data_names(reads_image=read_image or readback is not None)
        data = read_data_passes(frame.resource("data_passes"), names) if names else {}
        if frame.has("cryptomatte") and (read_image or readback is not None):
            data.update(frame.resource("cryptomatte").read())
        if frame.has("light_film") and (read_image or readback is not None):
            data.update(read_light_passes(frame.resource("light_film"), frame.outputs.light))
        if frame.has("vector") and (read_image or readback is not None):
            data.update(frame.resource("vector").read())
        counts = dict(frame.counts)
        diagnostic = self.tracer.read_diagnostic(frame.view) if is_diagnostic(settings) else None
        scene = frame.resource("scene")
        counts = LazyCounts({
            "triangles_total": scene.geometry.triangle_count,
            "triangles_primary_submitted": counts.pop("triangles_primary_submitted", 0),
            "lights": len(scene.lights),
            **counts,
        }, pending)
        return FrameResult(image=image, counts=counts, mode=settings.mode, data_passes=data,
                           diagnostic=diagnostic, legend=legend(settings) if diagnostic is not None else [],
                           near_size=float(settings.near_size) if "cube_map_raster" in MODE_STEPS[settings.mode]
                           else None)

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

    def release(self) -> None:
        """Free this renderer's GL objects (the shared context stays)."""
        self.accumulate.release()
        self.data_passes.release()
        if self.cryptomatte is not None:
            self.cryptomatte.release()
            self.cryptomatte = None
        if self.light_passes is not None:
            self.light_passes.release()
            self.light_passes = None
        if self.vector is not None:
            self.vector.release()
            self.vector = None
        self.deferred_shade.light_targets.release()
        if self.denoiser is not None:
            self.denoiser.release()
            self.surface_motion.release()
            self.denoiser = self.surface_motion = None
        for owner in (self.cube_map, self.cube_light, self.culler, self.tracer, self.diffuse_light, self.emitters):
            if owner is not None:
                owner.release()
        if self.lbvh is not None:
            self.lbvh.builder.release()
        self.cube_map = self.cube_light = self.culler = self.lbvh = self.tracer = None
        self.diffuse_light = self.emitters = None
        self._world = {}
        self._world_key = None
        self.statistics.release()
        self.shadow_maps.release()
        self.gbuffer.release()
        self.drawer.release()
        self.resources.release()
        self.gpu_scene.release()
