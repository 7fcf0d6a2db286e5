# SPDX-License-Identifier: GPL-3.0-or-later
"""The hybrid tracer: secondary rays through the near-cube BVH and the G-buffer cube map.

Paper §3.4 (steps 3 to 5 of the frame, §3). One compute megakernel
(``gpu_shaders/trace/hybrid_trace.comp.glsl``) walks, per pixel, a depth-first stack of the
reflected and refracted rays spawned by the primary G-buffer and traces each through the
frame's BVH (the ``lbvh_build`` pass over what the ``cull`` pass kept, §3.3) and by marching
the cube map (the ``cube_map_raster`` pass, ``gpu_shaders/include/cube_march.glsl``),
adding their radiance to the deferred-shaded image. FULL_BVH, the paper's ground truth,
traces a BVH of the whole scene and never touches the cube map. The tracer builds none of
these: it reads them from the frame (passes/frame_context.py).

The kernel reads the scene's geometry where the upload put it (scene_upload/): at a BVH hit
it interpolates the shading normals and reads the material and UV row of the ORIGINAL
triangle index the BVH reports (the face normal comes from the hit leaf's own corners). Its
buffers are fixed-size and the kernel is compiled once per define set: a frame of the same
size as the last allocates nothing and compiles nothing.

With World Light Rays (``RenderSettings.traces_diffuse``) the kernel is compiled with
``DIFFUSE_GATHER``: the first bounce's hits gather their diffuse light with one cosine ray
of unlimited reach instead of an occlusion ray within AO Distance (trace_ray.glsl
shade_hit). The diffuse light of primary pixels is the ``diffuse_light`` pass's
(passes/diffuse_light/), which binds what this kernel binds (``inputs``).
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from functools import partial

import numpy as np

from ...gpu import gl_context, shader_loader
from ...gpu.bindings import Image, bind, split_storage
from ...gpu.dispatch import split_blocks, storage_barrier
from ...gpu.render_targets import sampled_depth_texture
from ...scene.bounds import SceneBounds
from ...scene.raster_view import RasterView
from ...scene.settings import FIELD_LIMITS, RenderSettings
from ..film.light_passes import light_bindings
from ..frame_context import FrameContext, PassIO
from ..lbvh.lbvh import BVH_BLOCKS
from ..near_cube_cull.near_cube import overlap_margin
from ..scene_upload.textures import pixel_footprint
from .diagnostic_views import is_diagnostic
from .diagnostic_views import kernel_uniforms as diagnostic_uniforms
from .wave_trace import TraceInputs, WaveTracer, uses_waves, waves_fit

log = logging.getLogger(__name__)

# Kernel modes (u_mode in hybrid_trace.comp.glsl).
TRACE_MODES = {"HYBRID": 0, "FULL_BVH": 1, "PROVENANCE": 2}

# Counter layout: uint[len(COUNTER_KINDS)][COUNTER_DEPTHS], index kind * COUNTER_DEPTHS + depth.
# The first six count rays (each at most once per kind); the last two sum the BVH nodes the
# rays visited and the march steps they took.
RAY_KINDS = ("traced", "cube_map", "sky", "bvh_reentry", "bvh_hit", "cube_hit")

WORK_KINDS = ("bvh_nodes", "cube_steps")

COUNTER_KINDS = RAY_KINDS + WORK_KINDS

COUNTER_DEPTHS = 17
COUNTER_WORDS = len(COUNTER_KINDS) * COUNTER_DEPTHS
assert FIELD_LIMITS["max_depth"][1] < COUNTER_DEPTHS, "the kernel's counters cover every depth"

WORKGROUP = 8  # the kernel's local size in x and y
NORMAL_BYTES = 36  # three float32 vec3 per triangle: Geometry.normals as uploaded


# Whether the tracer's mirror and glass rays march the cube map by its surface footprints
# where it has them (cube_march.glsl "Surface footprints"); False keeps the paper's rule for
# them (a switch for benchmarks/chess_flip_split.py and the cost measurements).
MIRROR_FOOTPRINTS = True

# Padding of the scene bounds the tracer clips rays to (relative to their extent, so at any
# scale): float rounding of the box slabs must not cut a surface on the boundary.
SCENE_BOUNDS_PADDING = 1e-3


def scene_bound_uniforms(bounds: SceneBounds) -> dict:
    """hybrid_trace.comp.glsl's u_scene_* uniforms: the padded bounds of all geometry, past
    which a ray can hit nothing (the sky), or unbounded for a scene with no finite geometry."""
    if bounds.empty:
        return {"u_scene_bounded": 0, "u_scene_lo": (0.0, 0.0, 0.0), "u_scene_hi": (0.0, 0.0, 0.0)}
    pad = SCENE_BOUNDS_PADDING * (float(np.max(bounds.hi - bounds.lo)) or 1.0)  # relative: any scale
    return {"u_scene_bounded": 1,
            "u_scene_lo": tuple(float(v) for v in bounds.lo - pad),
            "u_scene_hi": tuple(float(v) for v in bounds.hi + pad)}


@dataclass
class TraceStats:
    """What one frame's tracing did (goes into FrameResult.counts)."""

    per_depth: dict[str, list[int]]  # kind -> [count at depth 1, 2, ...]
    bvh_triangles: int | None = None  # None: counted elsewhere (the BVH's own count)

    @classmethod
    def of(cls, words: np.ndarray, max_depth: int, bvh_triangles: int | None = None) -> "TraceStats":
        """The statistics of the kernel's counters (uint32[COUNTER_WORDS])."""
        raw = np.asarray(words, np.uint32).reshape(len(COUNTER_KINDS), COUNTER_DEPTHS)
        # Rays of depth 1 .. max_depth, and the one more the depth limit traces.
        depths = range(1, max(int(max_depth), 0) + min(max(int(max_depth), 0), 1) + 1)
        per_depth = {kind: [int(raw[k, d]) for d in depths] for k, kind in enumerate(COUNTER_KINDS)}
        return cls(per_depth=per_depth, bvh_triangles=bvh_triangles)

    def as_counts(self) -> dict[str, int]:
        counts = {} if self.bvh_triangles is None else {"triangles_bvh": int(self.bvh_triangles)}
        for kind, values in self.per_depth.items():
            name = kind if kind in WORK_KINDS else f"rays_{kind}"
            counts[name] = int(sum(values))
            for depth, value in enumerate(values, start=1):
                counts[f"{name}_bounce_{depth}"] = int(value)
        return counts


def traced_resources(settings: RenderSettings) -> tuple[str, ...]:
    """What the kernel traces through in ``settings.mode``: the BVH (not in PROVENANCE, which
    only decides where each first secondary ray starts) and the cube map (the hybrid modes)."""
    mode = settings.trace_mode
    return ((("bvh",) if mode != "PROVENANCE" else ()) + (("cube_map",) if mode == "HYBRID" else ())
            + (("cube_light",) if mode == "HYBRID" and settings.lit_cube else ()))


class HybridTracer:
    """The megakernel, its counters and the diagnostic views' image (the frame's ``trace``
    pass)."""

    name = "trace"

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.program = shader_loader.compute(ctx, "trace/hybrid_trace.comp.glsl")
        self._counters = ctx.buffer(reserve=len(COUNTER_KINDS) * COUNTER_DEPTHS * 4)
        self._zero_counters = bytes(self._counters.size)
        self._dummy_ssbo = ctx.buffer(reserve=256)
        self._dummy_depth = sampled_depth_texture(ctx, (1, 1))
        self._dummy_rgba = ctx.texture((1, 1), 4, dtype="f4")
        self._dummy_rg = ctx.texture((1, 1), 2, dtype="f4")
        self.diagnostic = None  # the diagnostic views' per-pixel counts (diagnostic_views.py)
        self._waves: WaveTracer | None = None  # the wave pipeline, made when first chosen
        self._traced_in_waves = False  # whether this frame's trace ran in waves
        # Frames traced by the per-pixel kernel although the wave kernels were chosen, because
        # their storage blocks would pass the driver's limit (wave_trace.waves_fit).
        self.wave_fallbacks = 0
        # Whether the frame's plan asks for Cycles' light passes (the renderer sets it): the
        # megakernel then also adds the reflections' and refractions' light to their layers
        # (passes/film/light_passes.py); the waves keep no lobe per ray, so it runs instead.
        self.light_passes = False

    def io(self, settings: RenderSettings) -> PassIO:
        light = ("light_samples",) if self.light_passes else ()
        return PassIO(reads=("scene", "scene_buffers", "world_triangles", "gbuffer", "lighting", "color",
                             *traced_resources(settings), *light),
                      writes=("color", *light))

    def run(self, frame: FrameContext) -> None:
        """Trace the reflections and refractions of the primary G-buffer, lit by the frame's
        lighting (the same the deferred shading used), adding their radiance to the frame's
        colour (or writing the provenance colours): by the megakernel, or in waves where the
        ``trace`` kernel runs GPU-shaped (wave_trace.py)."""
        self._traced_in_waves = False
        if uses_waves(frame.settings) and not self.light_passes:
            inputs = self.inputs(frame)
            if waves_fit(self.ctx, inputs.defines):
                if self._waves is None:
                    self._waves = WaveTracer(self.ctx)
                self._waves.run(inputs, frame.settings)
                self._traced_in_waves = True
            else:
                self.wave_fallbacks += 1
                if self.wave_fallbacks == 1:
                    log.info("Hybrid RT: the scene's arrays are split over more storage blocks than the "
                             "wave trace kernels can bind on this driver; the per-pixel trace kernel runs")
        if not self._traced_in_waves:
            self.dispatch(frame)
        self.deposit_statistics(frame)
        frame.write("color", frame.read("gbuffer").color)
        if self.light_passes:
            frame.write("light_samples", frame.read("light_samples"))

    def deposit_statistics(self, frame: FrameContext) -> None:
        """The BVH's leaf count and the kernel's counters, into the frame's statistics: copied
        on the GPU, read after the frame if a caller asks (gpu/statistics.py). PROVENANCE
        traces nothing and counts nothing."""
        if "bvh" not in traced_resources(frame.settings):
            return
        count = frame.read("bvh").count
        frame.statistics.deposit(count.buffer, 1, _bvh_counts, offset=count.offset)
        frame.statistics.deposit(self._counters, COUNTER_WORDS, partial(_ray_counts, int(frame.settings.max_depth)))
        if self._traced_in_waves:
            self._waves.deposit_statistics(frame.statistics)

    def dispatch(self, frame: FrameContext) -> None:
        """Run the megakernel: the reflections and refractions."""
        inputs = self.inputs(frame)
        defines, images, uniforms = inputs.defines, inputs.images, inputs.uniforms
        if self.light_passes and frame.settings.trace_mode != "PROVENANCE" and not is_diagnostic(frame.settings):
            defines = {**defines, "LIGHT_PASSES": 1}
            light_images, light_uniforms = light_bindings(frame.read("light_samples"))
            images = {**images, **light_images}
            uniforms = {**uniforms, **light_uniforms}
        prog = (shader_loader.compute(self.ctx, "trace/hybrid_trace.comp.glsl", defines)
                if defines else self.program)
        bind(prog, *inputs.parts, storage=inputs.storage, textures=inputs.textures,
             images=images, uniforms=uniforms)
        width, height = inputs.size
        prog.run(math.ceil(width / WORKGROUP), math.ceil(height / WORKGROUP), 1)
        storage_barrier(self.ctx)
        if gl_context.debug_checks_enabled():
            gl_context.check_error(f"{frame.settings.trace_mode} trace")

    def inputs(self, frame: FrameContext, gather: bool = False) -> TraceInputs:
        """Everything a trace kernel binds: the scene, the BVH, the cube map and the
        lighting, the kernel's defines, and the counters (zeroed). ``gather``: for the
        diffuse-light kernel (passes/diffuse_light/), which traces through the same
        structures but draws no diagnostic view."""
        settings = frame.settings
        traced = traced_resources(settings)
        built = frame.read("bvh") if "bvh" in traced else None
        cube = frame.read("cube_map") if "cube_map" in traced else None
        lit = frame.read("cube_light") if "cube_light" in traced else None
        gpu, scene = frame.read("world_triangles"), frame.read("scene")
        targets, resources, view = frame.read("gbuffer"), frame.read("lighting"), frame.view
        ctx = self.ctx
        mode = settings.trace_mode
        diagnostic = is_diagnostic(settings) and not gather
        # A BVH whose arrays span several storage blocks needs the kernel compiled for them,
        # and the cube-map march its own defines (MarchableCubeMap.defines: the march kind,
        # the back layer, the hidden-exit rule); compiled once per define set, and without
        # any this is self.program.
        normal_split = split_blocks(gpu.triangle_count, NORMAL_BYTES, "tracer's shading normals")
        defines = {**(built.traversal_defines() if built is not None else {}),
                   **normal_split.defines("TRI_NORMAL_BLOCKS", "TRI_NORMAL_BLOCK_SIZE"),
                   **(cube.defines if cube is not None else {}),
                   **({"DIFFUSE_GATHER": 1} if settings.traces_diffuse else {}),
                   **(lit.defines if lit is not None else {}),
                   **({"DIAGNOSTIC": 1} if diagnostic else {}),
                   **gpu.defines,
                   **resources.defines,  # light linking (scene/light_linking.py)
                   # The traversal's any-hit alpha test (trace_ray.glsl), only where some
                   # surface is not wholly there: opaque scenes trace as without it.
                   **({"ALPHA_TEST": 1} if scene.materials.has_alpha else {})}
        if cube is not None and "u_cube_footprint" in cube.textures and (gather or MIRROR_FOOTPRINTS):
            # The march follows the stored surfaces' planes across their texels, so that a
            # thin wall seen edge-on, a texel or two wide in the map, stops the rays that
            # cross it (cube_march.glsl "Surface footprints"), where the paper's constant
            # depth per texel lets them through to the sky. The tracer's rays do not carry
            # the surface they leave, which only the diffuse paths' rule asks for.
            defines["CUBE_FOOTPRINT"] = 1
            if not gather:
                defines["CUBE_FOOTPRINT_OTHER_MATERIAL"] = 0
        self._counters.write(self._zero_counters)

        bvh = built.storage() if built is not None else dict.fromkeys(BVH_BLOCKS, self._dummy_ssbo)
        textures = {
            "u_depth": targets.depth,
            "u_normal_material": targets.normal_material,
            "u_albedo": targets.albedo,
            "u_emission_scale": targets.emission_scale,
            "u_surface": targets.surface,
            "u_cube_depth": self._dummy_depth,
            "u_cube_normal_material": self._dummy_rgba,
            "u_cube_surface": self._dummy_rgba,
            "u_cube_geometric": self._dummy_rg,
            "u_cube_tangent": self._dummy_rgba,  # node programs' cube hits (trace_ray.glsl)
            "u_cube_hiz": self._dummy_rg,
            # the diffuse paths' surface footprints (cube_march.glsl, CUBE_FOOTPRINT)
            "u_cube_footprint": self._dummy_rg,
            "u_cube_planes": self._dummy_rgba,
        }
        if cube is not None:
            textures.update(cube.textures)
        if lit is not None:
            textures.update(lit.textures)
        # Uniforms.
        center = frame.center
        values = {
            **view.uniforms(),
            "u_mode": TRACE_MODES[mode],
            "u_max_depth": int(settings.max_depth),
            "u_near_center": tuple(center),
            "u_near_half": float(settings.near_size),
            "u_bvh_half": float(settings.near_size + overlap_margin(settings.near_size, center)),
            "u_sample": frame.sample,
        }
        values.update(scene_bound_uniforms(SceneBounds.of(scene)))
        values["u_pixel_width"], values["u_pixel_spread"] = pixel_footprint(
            view.view_proj, view.height, view.orthographic)
        if cube is not None:
            values.update(cube.uniforms)
        if lit is not None:
            values.update(lit.uniforms)
        images = {"u_color": Image(targets.color, read=True, write=True)}
        if diagnostic:
            if self.diagnostic is None or self.diagnostic.size != (view.width, view.height):
                if self.diagnostic is not None:
                    self.diagnostic.release()
                self.diagnostic = ctx.texture((view.width, view.height), 1, dtype="f4")
            images["u_diagnostic"] = Image(self.diagnostic, read=False, write=True)
            values.update(diagnostic_uniforms(settings))
        return TraceInputs(
            defines=defines, parts=(gpu.bindings(), resources.bindings()),
            storage={**bvh, **split_storage("TriangleNormals", gpu.normals.buffer, normal_split),
                     "CounterBuffer": self._counters, "TriangleUVBuffer": gpu.uv_rows.buffer},
            textures=textures, images=images, uniforms=values, size=(view.width, view.height))

    def read_stats(self, max_depth: int) -> TraceStats:
        """The last trace's counters, read back now (a synchronisation point: tests; the
        frame deposits them instead), and the wave queues' overflow noted."""
        if self._waves is not None:
            self._waves.note_overflow()
        return TraceStats.of(np.frombuffer(self._counters.read(), np.uint32), max_depth)

    def queue_overflows(self) -> int:
        """How many frames so far wanted more rays than the wave queues held (their rays past
        the queues took the sky; the queues have grown since): a final render compares the
        count before and after its samples (frame/antialias.py). 0 for the megakernel."""
        if self._waves is None:
            return 0
        self._waves.note_overflow()
        return self._waves.overflows

    def read_diagnostic(self, view: RasterView) -> np.ndarray:
        """The diagnostic view's per-pixel counts of the last trace, (H, W) float32, row 0 at
        the bottom (trace/diagnostic_views.py)."""
        return np.frombuffer(self.diagnostic.read(), np.float32).reshape(view.height, view.width).copy()

    def release(self) -> None:
        if self.diagnostic is not None:
            self.diagnostic.release()
            self.diagnostic = None
        if self._waves is not None:
            self._waves.release()
            self._waves = None
        for obj in (self._counters, self._dummy_ssbo, self._dummy_depth, self._dummy_rgba, self._dummy_rg):
            obj.release()


def _bvh_counts(words: np.ndarray) -> dict[str, int]:
    return {"triangles_bvh": int(words[0])}


def _ray_counts(max_depth: int, words: np.ndarray) -> dict[str, int]:
    return TraceStats.of(words, max_depth).as_counts()

