# SPDX-License-Identifier: GPL-3.0-or-later
"""The shadow-map pass (gpu_shaders/raster/shadow_depth.*.glsl, paper §3.5).

Every lamp that casts shadows gets slots in the shadow atlas (shadow_atlas.py) fitted to
the scene's bounds: a sun one orthographic map, a spot one perspective map over its cone,
a point or area lamp (and a very wide spot) six 90° cube faces. Each slot has a static and
a dynamic layer (shadow_cache.py), and a frame re-renders only the layer whose objects
changed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import shader_loader
from .camera import cube_face_views, look_at, orthographic_matrix, perspective_matrix, view_from_world
from .gpu_scene import GPUScene, needs_cube_shadow, pack_lights
from .scene_bounds import SceneBounds
from .scene_data import LIGHT_SPOT, LIGHT_SUN, SceneData
from .scene_delta import GeometryDelta
from .scene_draw import SceneDrawer
from .settings import RenderSettings
from .shadow_atlas import ShadowAtlas, ShadowView
from .shadow_cache import ShadowCache, snapped_bounds

# Spots wider than this get a cube shadow: a single perspective map degenerates near 180°.
MAX_SPOT_SHADOW_FOV = math.radians(150.0)


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


def frame_shadow_views(scene: SceneData) -> tuple[list[ShadowView], list[tuple[int, int]]]:
    """This frame's shadow slots, fitted to the scene's bounds snapped to a grid (so that
    objects moving inside the scene keep the matrices, and with them the static layer)."""
    bounds = SceneBounds.of(scene)
    return shadow_views(scene, SceneBounds(*snapped_bounds(bounds.lo, bounds.hi)))


@dataclass
class ShadowMaps:
    """What one frame's shadow pass did: each light's (first, count) slots, whether any
    layer and the static layer were re-rendered, and the triangles submitted."""

    per_light: list[tuple[int, int]]
    rendered: bool
    static_rendered: bool
    submitted: int

    def counts(self) -> dict[str, int]:
        return {"shadow_maps_rendered": int(self.rendered), "shadow_static_rendered": int(self.static_rendered),
                "shadow_triangles_submitted": int(self.submitted)}


class ShadowDepthPass:
    """Renders the shadow atlas's layers that this frame's changes invalidated."""

    def __init__(self, ctx, drawer: SceneDrawer) -> None:
        self.ctx = ctx
        self.drawer = drawer
        self.program = shader_loader.program(
            ctx, vertex="raster/shadow_depth.vert.glsl", fragment="raster/shadow_depth.frag.glsl")
        self.cache = ShadowCache()

    def render(self, gpu: GPUScene, scene: SceneData, settings: RenderSettings, atlas: ShadowAtlas,
               delta: GeometryDelta) -> ShadowMaps:
        """Lay out this frame's slots in ``atlas`` and re-render the layers ``delta``
        invalidated (shadow_cache.py); the lights, the resolution and the slots' matrices
        key the cache, so any change to them renders both layers."""
        views, per_light = frame_shadow_views(scene)
        key = (pack_lights(scene.lights).tobytes(), int(settings.shadow_resolution),
               b"".join(np.asarray(v.view_proj, np.float64).tobytes() for v in views))
        plan = self.cache.plan(scene.geometry.object_ranges, delta, key)
        submitted = 0
        if plan.anything:
            try:
                atlas.layout(views, int(settings.shadow_resolution))
                if plan.render_static:
                    submitted += self.render_layer(gpu, scene, atlas, views, dynamic=False,
                                                   include=plan.static_mask)
                if plan.render_dynamic:
                    submitted += self.render_layer(gpu, scene, atlas, views, dynamic=True,
                                                   include=~plan.static_mask)
            except BaseException:
                self.cache.reset()  # the layers are incomplete
                raise
        return ShadowMaps(per_light, plan.anything, plan.render_static, submitted)

    def render_layer(self, gpu: GPUScene, scene: SceneData, atlas: ShadowAtlas, views: list[ShadowView],
                     dynamic: bool, include: np.ndarray | None = None) -> int:
        """Clear one layer of ``atlas`` (static or dynamic) and draw the objects ``include``
        selects (all when None) into every slot laid out for ``views``
        (ShadowAtlas.layout); returns triangles submitted."""
        ctx = self.ctx
        fbo = atlas.begin_layer(dynamic)
        if not views or (include is not None and not include.any()):
            return 0
        prog = self.program

        def bind() -> None:
            ctx.enable(ctx.DEPTH_TEST)
            ctx.disable(ctx.CULL_FACE)

        draws = [(view.view_proj, atlas.rect(i)) for i, view in enumerate(views)]
        return self.drawer.draw_views("shadow_dynamic" if dynamic else "shadow_static", prog,
                                      self.drawer.vertex_array(prog, gpu), gpu, scene, fbo, draws, bind, include)
