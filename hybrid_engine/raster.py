# SPDX-License-Identifier: GPL-3.0-or-later
"""Rasterization passes: primary G-buffer, shadow maps and deferred shading.

Paper §3.1 (primary visibility into a G-buffer whose normal alpha holds the material
index) and §3.5 (deferred shading with shadow maps). These passes are the whole of RASTER
mode and the first two steps of every other mode; the G-buffer cube map of §3.2 reuses the
G-buffer pass with six face cameras.

All GL objects are created once and resized only when the image size or shadow resolution
changes; programs come from the shader loader's per-context cache.

The primary view and the shadow slots draw GPU-culled triangle lists (view_cull.py, as the
cube-map faces do): a dense mesh far from the camera puts many triangles on every pixel, and
most of them cover no pixel centre or face away. The culling compute pass drops them before
the rasterizer sets them up, and the images are bit-identical to drawing the object lists.
On a software GL this matters twice over: vertex processing and triangle setup run on one
thread there, the compute pass on all of them. A dense model far away (Sponza's dragon
covers a few thousand pixels) keeps a small fraction of its triangles.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from . import gl_context, shader_loader
from .camera import (
    Camera,
    cube_face_views,
    look_at,
    orthographic_matrix,
    perspective_matrix,
    view_from_world,
)
from .frustum import beyond_near_plane, draw_ranges, front_face_winding, visible_objects
from .gpu_scene import GPUScene, needs_cube_shadow
from .scene_data import LIGHT_SPOT, LIGHT_SUN, SceneData
from .frame_resources import FrameResources
from .settings import RenderSettings
from .shadow_atlas import ShadowAtlas, ShadowView
from .shadow_cache import snapped_bounds
from .view_cull import MAX_VIEWS, CullView, ViewTriangleCuller

# Spots wider than this get a cube shadow: a single perspective map degenerates near 180°.
MAX_SPOT_SHADOW_FOV = math.radians(150.0)
# Scenes with fewer triangles draw their object lists directly: the culling pass's three
# dispatches cost more than it saves.
CULL_MIN_TRIANGLES = 16384


def gl_matrix(m: np.ndarray) -> bytes:
    """Row-major numpy matrix → column-major float32 bytes for a GLSL mat4."""
    return np.ascontiguousarray(np.asarray(m, np.float32).T).tobytes()


@dataclass
class SceneBounds:
    """Finite bounds of all geometry, used to fit shadow frusta."""

    lo: np.ndarray
    hi: np.ndarray

    @property
    def empty(self) -> bool:
        return not (np.isfinite(self.lo).all() and (self.lo <= self.hi).all())

    @property
    def center(self) -> np.ndarray:
        return (self.lo + self.hi) * 0.5

    @property
    def radius(self) -> float:
        return float(max(np.linalg.norm(self.hi - self.lo) * 0.5, 1e-3))

    @classmethod
    def of(cls, scene: SceneData) -> "SceneBounds":
        b = scene.geometry.object_bounds.astype(np.float64)
        valid = np.isfinite(b).all(axis=(1, 2)) & (b[:, 0] <= b[:, 1]).all(axis=1) if len(b) else np.zeros(0, bool)
        if not valid.any():
            return cls(np.full(3, np.inf), np.full(3, -np.inf))
        return cls(b[valid, 0].min(axis=0), b[valid, 1].max(axis=0))


def shadow_views(scene: SceneData, bounds: SceneBounds) -> tuple[list[ShadowView], list[tuple[int, int]]]:
    """Every shadow slot's view and each light's (first, count) slots.

    Sun: an orthographic map fitted around the scene's bounding sphere. Spot: a perspective
    map covering the cone. Point and area (and very wide spots): six 90° cube faces.
    """
    lights = scene.lights
    matrices: list[ShadowView] = []
    per_light: list[tuple[int, int]] = []
    if bounds.empty:
        return matrices, [(-1, 0)] * len(lights)
    center, radius = bounds.center, bounds.radius
    for i in range(len(lights)):
        kind = int(lights.kind[i])
        if not lights.cast_shadow[i] or not np.isfinite(lights.position[i]).all():
            per_light.append((-1, 0))
            continue
        pos = lights.position[i].astype(np.float64)
        direction = lights.direction[i].astype(np.float64)
        norm = np.linalg.norm(direction)
        direction = direction / norm if norm > 0 else np.array([0.0, 0.0, -1.0])
        first = len(matrices)
        if kind == LIGHT_SUN:
            eye = center - direction * radius * 2.0
            view = view_from_world(look_at(eye, center))
            proj = orthographic_matrix(radius, radius, radius * 0.5, radius * 3.5)
            matrices.append(ShadowView(proj @ view, 2.0 * radius, False, radius * 0.5, radius * 3.5))
        else:
            far = float(np.linalg.norm(pos - center) + radius) * 1.01
            near = max(far * 1e-4, 1e-3)
            spot_fov = float(lights.spot_size[i])
            if kind == LIGHT_SPOT and spot_fov <= MAX_SPOT_SHADOW_FOV:
                view = view_from_world(look_at(pos, pos + direction))
                fov = spot_fov * 1.02
                matrices.append(ShadowView(perspective_matrix(fov, 1.0, near, far) @ view, 2.0 * math.tan(fov / 2), True,
                                           near, far))
            else:
                assert needs_cube_shadow(kind) or kind == LIGHT_SPOT
                proj = perspective_matrix(math.radians(90.0), 1.0, near, far)
                matrices.extend(ShadowView(proj @ v, 2.0, True, near, far) for v in cube_face_views(pos))
        per_light.append((first, len(matrices) - first))
    return matrices, per_light


def _release_all(objects) -> None:
    gl_context.park_framebuffer()  # never delete the bound framebuffer
    for obj in objects:
        if obj is not None:
            obj.release()


@dataclass(frozen=True)
class RasterView:
    """What a G-buffer pass needs of a camera: the primary camera or a cube-map face."""

    view_proj: np.ndarray
    position: np.ndarray
    forward: np.ndarray
    orthographic: bool
    width: int
    height: int

    @classmethod
    def from_camera(cls, camera: Camera) -> "RasterView":
        return cls(camera.view_projection(), camera.position, camera.forward,
                   camera.projection == "ORTHO", int(camera.width), int(camera.height))

    def view_proj_bytes(self) -> bytes:
        """The view-projection as a GLSL mat4 (passes that project points into the view)."""
        return gl_matrix(self.view_proj)

    def uniforms(self) -> dict:
        """The camera uniforms that the passes reconstructing positions from a G-buffer
        share (deferred_shade.comp.glsl, hybrid_trace.comp.glsl)."""
        return {
            "u_inv_view_proj": gl_matrix(np.linalg.inv(self.view_proj)),
            "u_camera_position": tuple(np.asarray(self.position, float)),
            "u_camera_forward": tuple(np.asarray(self.forward, float)),
            "u_orthographic": int(self.orthographic),
            "u_size": (self.width, self.height),
        }


class RenderTargets:
    """Textures of one size rendered together: a depth texture and colour targets in one
    framebuffer, plus textures the passes fill otherwise (``extra``), all sampled texel by
    texel (NEAREST). Subclasses name them. :meth:`clear` resets depth and the colour targets
    named in ``cleared`` (all when None)."""

    def __init__(self, ctx, width: int, height: int, colour: dict[str, tuple[int, str]],
                 extra: dict[str, tuple[int, str]] | None = None,
                 cleared: tuple[str, ...] | None = None) -> None:
        self.size = (int(width), int(height))
        self.depth = ctx.depth_texture(self.size)
        self._textures = {"depth": self.depth}
        for name, (components, dtype) in {**colour, **(extra or {})}.items():
            self._textures[name] = ctx.texture(self.size, components, dtype=dtype)
            setattr(self, name, self._textures[name])
        for tex in self._textures.values():
            tex.filter = (ctx.NEAREST, ctx.NEAREST)
        self.fbo = ctx.framebuffer(color_attachments=[self._textures[name] for name in colour],
                                   depth_attachment=self.depth)
        self._clear_fbo = self.fbo if cleared is None else ctx.framebuffer(
            color_attachments=[self._textures[name] for name in cleared], depth_attachment=self.depth)

    def clear(self) -> None:
        self._clear_fbo.use()
        self._clear_fbo.viewport = (0, 0, *self.size)
        self._clear_fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)

    def read(self, name: str) -> np.ndarray:
        """Texture ``name`` as (H, W, C) float32, row 0 at the bottom (tests, diagnostics)."""
        tex = self._textures[name]
        w, h = self.size
        dtype = np.float16 if tex.dtype == "f2" else np.float32
        return np.frombuffer(tex.read(), dtype).reshape(h, w, -1).astype(np.float32)

    def release(self) -> None:
        extra_fbo = () if self._clear_fbo is self.fbo else (self._clear_fbo,)
        _release_all((self.fbo, *extra_fbo, *self._textures.values()))


class GBufferTargets(RenderTargets):
    """A G-buffer (depth, normal + material, albedo, emission scale, surface: the roughness
    and metallic its images give, gbuffer.frag.glsl), its ambient estimate
    (the World's light: alpha the sky's visibility from screen_ao.py, or rgb the light the
    tracer's sky rays gathered as well) and its shaded colour, W x H texels. ``emission_scale`` holds the colour of the material's emission texture
    (1 without one); the shading multiplies the material's emission by it.

    The primary camera owns one; the cube map's faces keep UVs instead of colours
    (cube_map.CubeFaceTargets).
    """

    def __init__(self, ctx, width: int, height: int) -> None:
        super().__init__(ctx, width, height,
                         colour={"normal_material": (4, "f4"), "albedo": (4, "f2"), "emission_scale": (4, "f2"),
                                 "surface": (2, "f2")},
                         extra={"color": (4, "f4"), "ambient": (4, "f4")})

    def read_color(self) -> np.ndarray:
        """The shaded colour as (H, W, 4) float32, row 0 at the bottom."""
        return self.read("color")

    def read_albedo(self) -> np.ndarray:
        """The albedo target as (H, W, 4) float32, row 0 at the bottom (tests, diagnostics)."""
        return self.read("albedo")

    def read_emission_scale(self) -> np.ndarray:
        """The emission-scale target as (H, W, 4) float32, row 0 at the bottom."""
        return self.read("emission_scale")


class RasterPasses:
    """G-buffer, shadow-map and deferred-shading passes on the shared context."""

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.gbuffer_prog = shader_loader.program(
            ctx, vertex="raster/gbuffer.vert.glsl", fragment="raster/gbuffer.frag.glsl"
        )
        # The cube-map faces' variant leaves refractive surfaces out and stores UVs instead
        # of sampling the textures (gbuffer.frag.glsl). A variant of its own, also because a
        # shader that may discard loses the early depth test.
        self.cube_gbuffer_prog = shader_loader.program(
            ctx, vertex="raster/gbuffer.vert.glsl", fragment="raster/gbuffer.frag.glsl",
            defines={"CUBE_FACE": 1})
        self.shadow_prog = shader_loader.program(
            ctx, vertex="raster/shadow_depth.vert.glsl", fragment="raster/shadow_depth.frag.glsl"
        )
        self.shade_prog = shader_loader.compute(ctx, "raster/deferred_shade.comp.glsl")
        self._size: tuple[int, int] | None = None
        self._gbuffer_vao = None
        self._cube_gbuffer_vao = None
        self._shadow_vao = None
        self._vao_generation = -1
        self.primary: GBufferTargets | None = None
        # Per-triangle culling of the primary and shadow draws (module doc). One culler per
        # layer and batch of views, so that no index buffer is rewritten in a frame while an
        # earlier draw of that frame may still read it. False draws the object lists.
        self.cull_triangles = True
        self._cullers: dict[tuple[str, int], ViewTriangleCuller] = {}
        # Each layer's last culled batches (None: drawn from the object lists), for tests and
        # statistics: CulledDraws.drawn() reads the survivors' counts back.
        self.culled: dict[str, list] = {}

    # -- resources -------------------------------------------------------------------------
    def primary_targets(self, width: int, height: int) -> GBufferTargets:
        """The primary camera's G-buffer, reallocated only when the image size changes."""
        if self.primary is None or self.primary.size != (width, height):
            old, self.primary = self.primary, GBufferTargets(self.ctx, width, height)
            if old is not None:
                old.release()
        return self.primary

    def _ensure_vaos(self, gpu: GPUScene) -> None:
        if self._vao_generation == gpu.generation and self._gbuffer_vao is not None:
            return
        for vao in (self._gbuffer_vao, self._cube_gbuffer_vao, self._shadow_vao):
            if vao is not None:
                vao.release()
        self._gbuffer_vao = self.ctx.vertex_array(self.gbuffer_prog, gpu.vertex_content(self.gbuffer_prog))
        self._cube_gbuffer_vao = self.ctx.vertex_array(self.cube_gbuffer_prog,
                                                       gpu.vertex_content(self.cube_gbuffer_prog))
        self._shadow_vao = self.ctx.vertex_array(self.shadow_prog, gpu.vertex_content(self.shadow_prog))
        self._vao_generation = gpu.generation

    # -- passes ----------------------------------------------------------------------------
    def draw_world(self, vao, view_proj: np.ndarray, scene: SceneData, include: np.ndarray | None = None,
                   back_faces: bool = False) -> int:
        """Draw the objects whose bounds touch the frustum (and, given ``include``, that it
        selects); returns triangles submitted. ``back_faces`` draws only their back faces
        (the cube map's back layer; the caller selects closed objects)."""
        geo = scene.geometry
        mask = visible_objects(view_proj, geo.object_bounds)
        if include is not None:
            mask &= include
        if back_faces:
            groups = ((mask, "front"),)
        else:
            # Closed outward-wound objects wholly in front of the near plane lose nothing
            # visible by back-face culling (solids.py); the rest is drawn two-sided.
            culled = np.zeros_like(mask)
            if geo.object_closed is not None and mask.any():
                culled = mask & geo.object_closed & beyond_near_plane(view_proj, geo.object_bounds)
            groups = ((mask & ~culled, None), (culled, "back"))
        submitted = 0
        ctx = self.ctx
        for group, cull in groups:
            ranges = draw_ranges(group, geo.object_ranges)
            if not ranges:
                continue
            with self._face_culling(view_proj, cull):
                for first, count in ranges:
                    vao.render(ctx.TRIANGLES, vertices=count * 3, first=first * 3)
                    submitted += count
        return submitted

    @contextmanager
    def _face_culling(self, view_proj: np.ndarray, cull: str | None):
        """GL face culling of ``cull`` ("back", "front") faces for the draws of the block,
        with the view's front-face winding; none for None."""
        ctx = self.ctx
        if cull is None:
            yield
            return
        ctx.front_face = front_face_winding(view_proj)
        ctx.cull_face = cull
        ctx.enable(ctx.CULL_FACE)
        try:
            yield
        finally:
            ctx.disable(ctx.CULL_FACE)
            ctx.front_face = "ccw"

    def draw_views(self, layer: str, prog, vao, gpu: GPUScene, scene: SceneData, fbo,
                   views: list[tuple[np.ndarray, tuple[int, int, int, int]]], bind: Callable[[], None],
                   include: np.ndarray | None = None) -> int:
        """Draw the scene with ``prog`` into ``fbo`` once per (view_proj, viewport) of
        ``views``: the objects whose bounds touch the view and that ``include`` selects (all
        when None). Returns triangles submitted after per-object culling. The draws are
        culled per triangle on the GPU first (module doc), in batches of view_cull.MAX_VIEWS
        views, unless ``cull_triangles`` is off, the scene is small
        (``CULL_MIN_TRIANGLES``) or a batch's index buffer would not fit one storage block
        (then that batch draws its object lists: the documented fallback). ``bind`` sets
        the draws' GL state; it runs after the culling, whose dispatches rebind storage
        buffers. ``layer`` names the caller's cullers."""
        geo = scene.geometry
        batches = [views[start:start + MAX_VIEWS] for start in range(0, len(views), MAX_VIEWS)]
        culled = [None] * len(batches)
        if self.cull_triangles and gpu.triangle_count >= CULL_MIN_TRIANGLES:
            for b, batch in enumerate(batches):
                culler = self._cullers.get((layer, b))
                if culler is None:
                    culler = self._cullers[(layer, b)] = ViewTriangleCuller(self.ctx)
                culled[b] = culler.cull(gpu.positions.buffer, gpu.triangle_count,
                                        [CullView(view_proj, rect[2], rect[3]) for view_proj, rect in batch],
                                        geo.object_ranges, geo.object_bounds, geo.object_closed, include)
        self.culled[layer] = culled
        fbo.use()
        bind()
        submitted = 0
        for batch, batch_culled in zip(batches, culled):
            for i, (view_proj, rect) in enumerate(batch):
                fbo.viewport = rect
                prog["u_view_proj"].write(gl_matrix(view_proj))
                if batch_culled is not None:
                    submitted += batch_culled.draw(prog, gpu, i)
                else:
                    submitted += self.draw_world(vao, view_proj, scene, include)
        return submitted

    def gbuffer(self, gpu: GPUScene, scene: SceneData, view: RasterView, targets,
                origin: tuple[int, int] = (0, 0), culled=None, view_index: int = 0,
                cube_face: bool = False, back_faces: bool = False) -> int:
        """Rasterize ``view`` into the region of ``targets`` (GBufferTargets, or
        cube_map.CubeFaceTargets for a face) at ``origin`` (§3.1); returns the triangles
        submitted after per-object frustum culling. The caller clears targets.
        ``cube_face`` draws a cube-map face (§3.2): refractive surfaces are left out and
        UVs stored (gbuffer.frag.glsl), and ``culled`` (view_cull.CulledDraws, the six faces culled
        at once by cube_map.py) draws view ``view_index``'s GPU-culled list, or, when None
        (the culler's fallback), the object lists. ``back_faces`` (with ``cube_face``) draws
        the face's back layer: only the back faces of closed objects. The primary view is
        culled on its own (:meth:`draw_views`)."""
        ctx = self.ctx
        self._ensure_vaos(gpu)
        prog, vao = ((self.cube_gbuffer_prog, self._cube_gbuffer_vao) if cube_face
                     else (self.gbuffer_prog, self._gbuffer_vao))
        viewport = (int(origin[0]), int(origin[1]), view.width, view.height)

        def bind() -> None:
            ctx.enable(ctx.DEPTH_TEST)
            ctx.disable(ctx.CULL_FACE)  # Blender shades both sides of a face
            gpu.materials.buffer.bind_to_storage_buffer(0)
            gpu.bind_triangle_materials()
            gpu.textures.use(0)
            if "u_textures" in prog:
                prog["u_textures"].value = 0

        if not cube_face:
            return self.draw_views("primary", prog, vao, gpu, scene, targets.fbo, [(view.view_proj, viewport)],
                                   bind)
        targets.fbo.use()
        targets.fbo.viewport = viewport
        bind()
        prog["u_view_proj"].write(gl_matrix(view.view_proj))
        if culled is None:
            closed = scene.geometry.object_closed if back_faces else None
            if back_faces and closed is None:
                return 0
            return self.draw_world(vao, view.view_proj, scene, include=closed, back_faces=back_faces)
        with self._face_culling(view.view_proj, "front" if back_faces else None):
            return culled.draw(prog, gpu, view_index)

    def shadow_views(self, scene: SceneData) -> tuple[list[ShadowView], list[tuple[int, int]]]:
        """This frame's shadow slots, fitted to the scene's bounds snapped to a grid (so that
        objects moving inside the scene keep the matrices, and with them the static layer)."""
        bounds = SceneBounds.of(scene)
        return shadow_views(scene, SceneBounds(*snapped_bounds(bounds.lo, bounds.hi)))

    def render_shadow_layer(self, gpu: GPUScene, scene: SceneData, atlas: ShadowAtlas, views: list[ShadowView],
                            dynamic: bool, include: np.ndarray | None = None) -> int:
        """Clear one layer of ``atlas`` (static or dynamic) and draw the objects ``include``
        selects (all when None) into every slot laid out for ``views``
        (ShadowAtlas.layout); returns triangles submitted."""
        ctx = self.ctx
        fbo = atlas.begin_layer(dynamic)
        if not views or (include is not None and not include.any()):
            return 0
        self._ensure_vaos(gpu)

        def bind() -> None:
            ctx.enable(ctx.DEPTH_TEST)
            ctx.disable(ctx.CULL_FACE)

        draws = [(view.view_proj, atlas.rect(i)) for i, view in enumerate(views)]
        return self.draw_views("shadow_dynamic" if dynamic else "shadow_static", self.shadow_prog,
                               self._shadow_vao, gpu, scene, fbo, draws, bind, include)

    def shadows(self, gpu: GPUScene, scene: SceneData, settings: RenderSettings,
                atlas: ShadowAtlas) -> list[tuple[int, int]]:
        """Render every light's shadow slots into ``atlas`` from scratch, all objects in the
        static layer (§3.5); returns each light's (first, count) slots."""
        views, per_light = self.shadow_views(scene)
        atlas.layout(views, int(settings.shadow_resolution))
        self.render_shadow_layer(gpu, scene, atlas, views, dynamic=False)
        self.render_shadow_layer(gpu, scene, atlas, views, dynamic=True, include=np.zeros(0, bool))
        return per_light

    def shade(self, gpu: GPUScene, scene: SceneData, view: RasterView, targets: GBufferTargets,
              resources: FrameResources, origin: tuple[int, int] = (0, 0), *,
              traced_specular: bool = False, transparent: bool = False, sample: int = 0) -> None:
        """Deferred shading of the G-buffer region at ``origin`` into ``targets.color``, lit
        by ``resources``. ``traced_specular`` leaves the lobes the tracer follows out (every
        traced mode); ``transparent`` makes the background (0, 0, 0, 0) instead of the sky
        (film.py). ``sample`` is this sample's index among the samples of one view.
        The World's light is read from ``targets.ambient`` (screen_ao.py or the
        tracer's sky rays, run first)."""
        prog = self.shade_prog
        gpu.materials.buffer.bind_to_storage_buffer(0)
        units = {"u_depth": targets.depth, "u_normal_material": targets.normal_material, "u_albedo": targets.albedo,
                 "u_emission_scale": targets.emission_scale, "u_ambient": targets.ambient,
                 "u_surface": targets.surface}
        for unit, (name, tex) in enumerate(units.items()):
            tex.use(location=unit)
            if name in prog:
                prog[name].value = unit
        resources.bind(prog, len(units))
        targets.color.bind_to_image(0, read=False, write=True)
        shader_loader.set_uniforms(prog, {
            **view.uniforms(),
            "u_origin": (int(origin[0]), int(origin[1])),
            "u_traced_specular": int(traced_specular),
            "u_transparent_background": int(transparent),
            "u_sample": int(sample),
        })
        prog.run(math.ceil(view.width / 8), math.ceil(view.height / 8), 1)

    def release(self) -> None:
        if self.primary is not None:
            self.primary.release()
        _release_all((self._gbuffer_vao, self._cube_gbuffer_vao, self._shadow_vao))
        for culler in self._cullers.values():
            culler.release()
        self._cullers.clear()
