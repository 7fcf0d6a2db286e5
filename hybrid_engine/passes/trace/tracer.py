# SPDX-License-Identifier: GPL-3.0-or-later
"""The hybrid tracer: secondary rays through the near-cube BVH and the G-buffer cube map.

Paper §3, steps 3 to 5. Every frame the triangles overlapping the near cube are culled
(:mod:`.near_cube`, §3.3) and an LBVH is built over them (:mod:`.lbvh`); one compute
megakernel (``gpu_shaders/trace/hybrid_trace.comp.glsl``) then walks, per pixel, a
depth-first stack of the reflected and refracted rays spawned by the primary G-buffer and
traces each through the BVH and the cube map (``gpu_shaders/include/cube_march.glsl``, §3.4),
adding their radiance to the deferred-shaded image. FULL_BVH, the paper's ground truth,
builds the LBVH over the whole scene and never touches the cube map.

The tracer reads the scene's geometry where GPUScene uploaded it (scene_upload/scene_buffers.py): the
triangles are the LBVH's input, and at a BVH hit the kernel interpolates the shading normals
and reads the material of the ORIGINAL triangle index the BVH reports (the face normal comes
from the hit leaf's own corners). Only the UV rows of textured triangles are its own. All
buffers are grow-only and the kernel is compiled once per context: a frame of the same
size as the last allocates nothing and compiles nothing.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...gpu import gl_context, shader_loader
from ...gpu.bindings import Image, bind, split_storage
from ...gpu.dispatch import GrowBuffer, split_blocks, storage_barrier
from ...gpu.render_targets import GBufferTargets
from ...scene.bounds import SceneBounds
from ...scene.changes import GeometryDelta
from ...scene.data import Geometry, SceneData, TEXTURE_SLOTS
from ...scene.raster_view import RasterView
from ...scene.settings import FIELD_LIMITS, RenderSettings
from ..cube_map.cube_map import CubeMapPass
from .diagnostic_views import is_diagnostic
from .diagnostic_views import kernel_uniforms as diagnostic_uniforms
from ..gbuffer.gbuffer import GBufferPass
from ..lbvh.lbvh import BVH_BLOCKS, BuiltLBVH, LBVHBuilder
from ..lighting.resources import FrameResources
from ..near_cube_cull.near_cube import CullResult, NearCubeCuller, overlap_margin
from ..scene_upload.scene_buffers import GPUScene, bytes_of
from ..scene_upload.textures import pixel_footprint

# Kernel modes (u_mode in hybrid_trace.comp.glsl).
TRACE_MODES = {"HYBRID": 0, "FULL_BVH": 1, "PROVENANCE": 2}

# Counter layout: uint[len(COUNTER_KINDS)][COUNTER_DEPTHS], index kind * COUNTER_DEPTHS + depth.
# The first six count rays (each at most once per kind); the last two sum the BVH nodes the
# rays visited and the march steps they took.
RAY_KINDS = ("traced", "cube_map", "sky", "bvh_reentry", "bvh_hit", "cube_hit")
WORK_KINDS = ("bvh_nodes", "cube_steps")
COUNTER_KINDS = RAY_KINDS + WORK_KINDS
COUNTER_DEPTHS = 17
assert FIELD_LIMITS["max_depth"][1] < COUNTER_DEPTHS, "the kernel's counters cover every depth"

WORKGROUP = 8  # the kernel's local size in x and y
NORMAL_BYTES = 36  # three float32 vec3 per triangle: Geometry.normals as uploaded


# struct TriangleUV (hybrid_trace.comp.glsl)                          // total: 32 bytes
TRIANGLE_UV_DTYPE = np.dtype([("uv01", np.float32, 4), ("uv2_scale", np.float32, 4)])
assert TRIANGLE_UV_DTYPE.itemsize == 32


# Padding of the scene bounds the tracer clips rays to (relative to their extent, plus an
# absolute floor): float rounding of the box slabs must not cut a surface on the boundary.
SCENE_BOUNDS_PADDING = 1e-3


def scene_bound_uniforms(bounds: SceneBounds) -> dict:
    """hybrid_trace.comp.glsl's u_scene_* uniforms: the padded bounds of all geometry, past
    which a ray can hit nothing (the sky), or unbounded for a scene with no finite geometry."""
    if bounds.empty:
        return {"u_scene_bounded": 0, "u_scene_lo": (0.0, 0.0, 0.0), "u_scene_hi": (0.0, 0.0, 0.0)}
    pad = SCENE_BOUNDS_PADDING * (float(np.max(bounds.hi - bounds.lo)) + 1.0)
    return {"u_scene_bounded": 1,
            "u_scene_lo": tuple(float(v) for v in bounds.lo - pad),
            "u_scene_hi": tuple(float(v) for v in bounds.hi + pad)}


def pack_triangle_uvs(scene: SceneData, geometry: Geometry | None = None) -> np.ndarray:
    """One TRIANGLE_UV_DTYPE row per triangle, original order: the corners' UVs and the
    triangle's ``uv_per_world`` = sqrt(UV area / world area) (the tracer's mip level,
    see textures.py). The tracer's own buffer, apart from the scene's raw UVs, because
    only textured materials read them: rows of untextured triangles stay zero and are not
    computed. Non-finite UVs become 0 (as in the vertex buffer); a degenerate triangle
    gets uv_per_world 0 (mip level 0).
    """
    geo, materials = geometry if geometry is not None else scene.geometry, scene.materials
    n = geo.triangle_count
    out = np.zeros(max(n, 1), TRIANGLE_UV_DTYPE)
    if n == 0 or geo.uvs is None or not materials.has_textures:
        return out
    textured = np.logical_or.reduce([getattr(materials, slot) >= 0 for slot in TEXTURE_SLOTS])
    rows = np.flatnonzero(textured[geo.material_ids])
    if len(rows) == 0:
        return out
    whole = len(rows) == n
    uvs = geo.uvs if whole else geo.uvs[rows]
    if not np.isfinite(uvs).all():
        uvs = np.where(np.isfinite(uvs), uvs, 0.0).astype(np.float32)
    tris = geo.triangles if whole else geo.triangles[rows]
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        e1, e2 = tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
        world = np.linalg.norm(np.cross(e1, e2), axis=1)
        f1, f2 = uvs[:, 1] - uvs[:, 0], uvs[:, 2] - uvs[:, 0]
        uv_area = np.abs(f1[:, 0] * f2[:, 1] - f1[:, 1] * f2[:, 0])
        scale = np.sqrt(uv_area / world)
    scale = np.where(np.isfinite(scale), scale, 0.0)
    flat = out.view(np.float32).reshape(-1, 8)
    if whole:
        flat[:, :6] = uvs.reshape(n, 6)
        flat[:, 6] = scale
    else:
        flat[rows, :6] = uvs.reshape(-1, 6)
        flat[rows, 6] = scale
    return out


@dataclass
class TraceStats:
    """What one frame's tracing did (goes into FrameResult.counts)."""

    per_depth: dict[str, list[int]]  # kind -> [count at depth 1, 2, ...]
    bvh_triangles: int

    def as_counts(self) -> dict[str, int]:
        counts = {"triangles_bvh": int(self.bvh_triangles)}
        for kind, values in self.per_depth.items():
            name = kind if kind in WORK_KINDS else f"rays_{kind}"
            counts[name] = int(sum(values))
            for depth, value in enumerate(values, start=1):
                counts[f"{name}_bounce_{depth}"] = int(value)
        return counts


class HybridTracer:
    """GPU state of the tracing passes: geometry buffers, culler, LBVH, cube map, kernel."""

    def __init__(self, ctx, gbuffer: GBufferPass) -> None:
        self.ctx = ctx
        self.program = shader_loader.compute(ctx, "trace/hybrid_trace.comp.glsl")
        self.cube_map = CubeMapPass(ctx, gbuffer)
        self.culler = NearCubeCuller(ctx)
        self.builder = LBVHBuilder(ctx)
        self._gpu: GPUScene | None = None  # the scene buffers of the last upload
        self._uvs = GrowBuffer(ctx, "tracer triangle uvs")
        self._counters = ctx.buffer(reserve=len(COUNTER_KINDS) * COUNTER_DEPTHS * 4)
        self._zero_counters = bytes(self._counters.size)
        self._dummy_ssbo = ctx.buffer(reserve=256)
        self._dummy_depth = ctx.depth_texture((1, 1))
        self._dummy_rgba = ctx.texture((1, 1), 4, dtype="f4")
        self._dummy_rg = ctx.texture((1, 1), 2, dtype="f4")
        self.diagnostic = None  # the diagnostic views' per-pixel counts (trace/diagnostic_views.py)
        self.triangle_count = 0
        self._synced = -1  # sequence of the last GeometryDelta applied (scene/changes.py)
        self._with_uvs = False
        self.built: BuiltLBVH | None = None
        self.cull_result: CullResult | None = None

    # -- per-frame steps -------------------------------------------------------------------
    def upload(self, gpu: GPUScene, scene: SceneData, delta: GeometryDelta | None = None) -> None:
        """Take this frame's geometry from ``gpu`` (already uploaded) and write the UV rows
        of textured triangles. With a ``delta`` that follows this tracer's last upload only
        its changed ranges are re-packed and written (scene/changes.py); otherwise all."""
        self._gpu = gpu
        geo = scene.geometry
        with_uvs = scene.materials.has_textures  # only textured BVH hits read UVs
        incremental = (delta is not None and not delta.full and delta.sequence == self._synced + 1
                       and geo.triangle_count == self.triangle_count and with_uvs == self._with_uvs)
        self._synced = delta.sequence if delta is not None else -1
        self._with_uvs = with_uvs
        self.triangle_count = geo.triangle_count
        if gpu.uv_rows_resident:
            self._synced = -1  # the instance transform wrote them; a later packing starts over
        elif not with_uvs:
            self._uvs.ensure(0)
        elif incremental:
            for first, count in delta.ranges:
                self._uvs.write_at(bytes_of(pack_triangle_uvs(scene, geo.rows(first, count))[:count]),
                                   first * TRIANGLE_UV_DTYPE.itemsize)
        else:
            self._uvs.upload(bytes_of(pack_triangle_uvs(scene)))

    def _uv_rows(self):
        """The per-triangle UV rows: the scene's when the GPU made them, else the tracer's."""
        if self._gpu is not None and self._gpu.uv_rows_resident:
            return self._gpu.uv_rows.buffer
        return self._uvs.buffer

    @property
    def _triangles(self):
        """The scene's triangle buffer ((N, 3, 3) float32, original order)."""
        if self._gpu is None:
            raise RuntimeError("HybridTracer.upload must run before the tracing passes")
        return self._gpu.positions.buffer

    def render_cube_map(self, gpu, scene: SceneData, center, settings: RenderSettings) -> int:
        """The six face G-buffers (§3.2) and, for the hierarchical march, their hit-interval
        pyramid; the tracer shades the texels its rays hit. The faces' draw lists are culled
        per triangle on the GPU from this frame's uploaded triangles (view_cull.py). Returns
        the triangles submitted."""
        return self.cube_map.render(gpu, scene, center, settings,
                                    triangles=(self._triangles, self.triangle_count))

    def cull(self, scene: SceneData, center, settings: RenderSettings) -> CullResult:
        """Triangles overlapping the near cube (§3.3)."""
        geo = scene.geometry
        self.cull_result = self.culler.cull(
            self._triangles, self.triangle_count, center, settings.near_size,
            geo.object_ranges, geo.object_bounds,
        )
        return self.cull_result

    def build(self, culled: CullResult | None) -> BuiltLBVH:
        """The LBVH over the culled triangles, or over all of them (``culled`` None)."""
        if culled is None:
            self.built = self.builder.build(self._triangles, self.triangle_count)
        else:
            self.built = self.builder.build(self._triangles, culled.count,
                                            indices=culled.indices, input_count=self.triangle_count)
        return self.built

    def trace(self, gpu: GPUScene, scene: SceneData, view: RasterView, targets: GBufferTargets,
              resources: FrameResources, settings: RenderSettings, center, sample: int = 0) -> None:
        """Run the megakernel over the primary G-buffer, lit by ``resources`` (the same
        lighting the deferred shading used); adds the traced radiance to ``targets.color``
        (or writes the provenance colours). ``sample`` picks this sample's directions in
        the glossy lobes (Renderer.render)."""
        self._run(gpu, scene, view, targets, resources, settings, center, sample, world_light=False)

    def gather_world_light(self, gpu: GPUScene, scene: SceneData, view: RasterView, targets: GBufferTargets,
                           resources: FrameResources, settings: RenderSettings, center,
                           sample: int = 0) -> None:
        """Fill ``targets.ambient`` by rays: one cosine-distributed ray per diffuse primary
        pixel through the BVH and the cube map, as the reflections are traced (the hybrid
        ambient occlusion of Reinbothe et al., the paper's reference [14], extended to one
        bounce): rgb the World's light it brings (the sky, or the light of the surface it
        meets), alpha the sky's visibility, at any distance. Runs before the shading, which
        smooths it as it does the screen-space estimate (the one-bounce pass of the kernel,
        WORLD_LIGHT_PASS)."""
        self._run(gpu, scene, view, targets, resources, settings, center, sample, world_light=True)

    def _run(self, gpu: GPUScene, scene: SceneData, view: RasterView, targets: GBufferTargets,
             resources: FrameResources, settings: RenderSettings, center, sample: int, world_light: bool) -> None:
        """Bind the scene, the BVH, the cube map and the lighting, and run the kernel: the
        reflections and refractions, or (``world_light``) its World-light variant."""
        ctx = self.ctx
        mode = settings.trace_mode
        diagnostic = is_diagnostic(settings) and not world_light
        built = self.built if mode != "PROVENANCE" else None
        # A BVH whose arrays span several storage blocks needs the kernel compiled for them,
        # and the cube-map march its own defines (CubeMapPass.march_defines: the march kind,
        # the back layer, the hidden-exit rule); compiled once per define set, and without
        # any this is self.program.
        normal_split = split_blocks(self.triangle_count, NORMAL_BYTES, "tracer's shading normals")
        defines = {**(built.traversal_defines() if built is not None else {}),
                   **normal_split.defines("TRI_NORMAL_BLOCKS", "TRI_NORMAL_BLOCK_SIZE"),
                   **(self.cube_map.march_defines() if mode == "HYBRID" else {}),
                   **({"WORLD_LIGHT_PASS": 1} if world_light else {}),
                   **({"DIAGNOSTIC": 1} if diagnostic else {})}
        prog = shader_loader.compute(ctx, "trace/hybrid_trace.comp.glsl", defines) if defines else self.program
        self._counters.write(self._zero_counters)

        cube = self.cube_map.targets if mode == "HYBRID" else None
        bvh = built.storage() if built is not None else dict.fromkeys(BVH_BLOCKS, self._dummy_ssbo)
        textures = {
            "u_depth": targets.depth,
            "u_normal_material": targets.normal_material,
            "u_albedo": targets.albedo,
            "u_emission_scale": targets.emission_scale,
            "u_surface": targets.surface,
            "u_cube_depth": self._dummy_depth,
            "u_cube_normal_material": self._dummy_rgba,
            "u_cube_surface": cube.surface if cube is not None else self._dummy_rgba,
            "u_cube_geometric": cube.geometric if cube is not None else self._dummy_rg,
            "u_cube_hiz": self._dummy_rg,
        }
        if cube is not None:
            textures.update(self.cube_map.march_textures())
        # Uniforms.
        center = np.asarray(center, np.float64)
        values = {
            **view.uniforms(),
            "u_mode": TRACE_MODES[mode],
            "u_max_depth": int(settings.max_depth),
            "u_near_center": tuple(center),
            "u_near_half": float(settings.near_size),
            "u_bvh_half": float(settings.near_size + overlap_margin(settings.near_size)),
            "u_sample": int(sample),
        }
        values.update(scene_bound_uniforms(SceneBounds.of(scene)))
        values["u_pixel_width"], values["u_pixel_spread"] = pixel_footprint(
            view.view_proj, view.height, view.orthographic)
        if cube is not None:
            values.update(self.cube_map.march_uniforms(settings))
        images = {"u_color": Image(targets.color, read=True, write=True),
                  "u_ambient": Image(targets.ambient, read=False, write=True)}
        if diagnostic:
            if self.diagnostic is None or self.diagnostic.size != (view.width, view.height):
                if self.diagnostic is not None:
                    self.diagnostic.release()
                self.diagnostic = ctx.texture((view.width, view.height), 1, dtype="f4")
            images["u_diagnostic"] = Image(self.diagnostic, read=False, write=True)
            values.update(diagnostic_uniforms(settings))
        bind(prog, gpu.bindings(), resources.bindings(),
             storage={**bvh, **split_storage("TriangleNormals", gpu.normals.buffer, normal_split),
                      "CounterBuffer": self._counters, "TriangleUVBuffer": self._uv_rows()},
             textures=textures, images=images, uniforms=values)
        prog.run(math.ceil(view.width / WORKGROUP), math.ceil(view.height / WORKGROUP), 1)
        storage_barrier(ctx)
        if gl_context.debug_checks_enabled():
            gl_context.check_error(f"{mode} {'world light' if world_light else 'trace'}")

    def read_stats(self, max_depth: int) -> TraceStats:
        raw = np.frombuffer(self._counters.read(), np.uint32).reshape(len(COUNTER_KINDS), COUNTER_DEPTHS)
        # Rays of depth 1 .. max_depth, and the one more the depth limit traces.
        depths = range(1, max(int(max_depth), 0) + min(max(int(max_depth), 0), 1) + 1)
        per_depth = {kind: [int(raw[k, d]) for d in depths] for k, kind in enumerate(COUNTER_KINDS)}
        bvh = 0 if self.built is None else int(self.built.leaf_count)
        return TraceStats(per_depth=per_depth, bvh_triangles=bvh)

    def read_diagnostic(self, view: RasterView) -> np.ndarray:
        """The diagnostic view's per-pixel counts of the last trace, (H, W) float32, row 0 at
        the bottom (trace/diagnostic_views.py)."""
        return np.frombuffer(self.diagnostic.read(), np.float32).reshape(view.height, view.width).copy()

    def release(self) -> None:
        if self.diagnostic is not None:
            self.diagnostic.release()
            self.diagnostic = None
        self.cube_map.release()
        self.culler.release()
        self.builder.release()
        self._uvs.release()
        for obj in (self._counters, self._dummy_ssbo, self._dummy_depth, self._dummy_rgba, self._dummy_rg):
            obj.release()


# Mirror of the probe's per-ray output (cube_march_probe.comp.glsl)   // total: 64 bytes
MARCH_RESULT_DTYPE = np.dtype(
    [("kind", np.int32), ("face", np.int32), ("texel", np.int32, 2), ("switches", np.int32),
     ("material", np.int32), ("steps", np.int32), ("pad", np.int32), ("position", np.float32, 3),
     ("t", np.float32),
     ("normal", np.float32, 3), ("pad2", np.float32)]
)
assert MARCH_RESULT_DTYPE.itemsize == 64
MARCH_SKY, MARCH_HIT, MARCH_TO_BVH = 0, 1, 2  # CUBE_* in cube_march.glsl
PROBE_LOCAL_SIZE = 64


def probe_cube_march(ctx, cube_map: CubeMapPass, materials_buffer, settings: RenderSettings,
                     origins: np.ndarray, directions: np.ndarray, t_start: np.ndarray) -> np.ndarray:
    """March rays through the cube map last rendered by ``cube_map`` and return one
    MARCH_RESULT_DTYPE row per ray (for tests and diagnostics; the tracer marches inside its
    megakernel with the same code)."""
    from ...gpu.dispatch import dispatch

    origins = np.asarray(origins, np.float32).reshape(-1, 3)
    directions = np.asarray(directions, np.float32).reshape(-1, 3)
    count = len(origins)
    rays = np.zeros((count, 2, 4), np.float32)
    rays[:, 0, :3] = origins
    rays[:, 0, 3] = np.broadcast_to(np.asarray(t_start, np.float32), (count,))
    rays[:, 1, :3] = directions
    prog = shader_loader.compute(ctx, "trace/cube_march_probe.comp.glsl",
                                 {"LOCAL_SIZE": PROBE_LOCAL_SIZE, **cube_map.march_defines()})
    ray_buf = ctx.buffer(rays.tobytes() or bytes(32))
    out_buf = ctx.buffer(reserve=max(count, 1) * MARCH_RESULT_DTYPE.itemsize)
    try:
        bind(prog, storage={"MaterialBuffer": materials_buffer, "Rays": ray_buf, "Results": out_buf},
             textures=cube_map.march_textures(),
             uniforms={"u_count": count, **cube_map.march_uniforms(settings)})
        dispatch(prog, count, PROBE_LOCAL_SIZE)
        storage_barrier(ctx)
        raw = out_buf.read(size=count * MARCH_RESULT_DTYPE.itemsize) if count else b""
    finally:
        ray_buf.release()
        out_buf.release()
    return np.frombuffer(raw, MARCH_RESULT_DTYPE).copy()
