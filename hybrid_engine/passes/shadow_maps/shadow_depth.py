# SPDX-License-Identifier: GPL-3.0-or-later
"""The shadow-map pass (gpu_shaders/shadow_maps/shadow_depth.*.glsl, paper §3.5).

Every lamp that casts shadows gets slots in the shadow atlas (shadow_atlas.py) fitted to
the scene's bounds: a sun one orthographic map (after its cascades over the first stretches
of the view, sun_cascades.py), a spot one perspective map over its cone, a point or area
lamp (and a very wide spot) six 90° cube faces. Each slot has a static and a dynamic layer
(shadow_cache.py), and a frame re-renders only the layer whose objects changed; the
cascades, which follow the camera, keep a cache of their own, so that moving the camera
re-renders them alone, and of them only those whose matrices the move changed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...gpu import shader_loader
from ...gpu.bindings import bind as bind_storage
from ...scene.bounds import SceneBounds
from ..view_cull.draw import SceneDrawer
from ..view_cull.view_cull import MAX_VIEWS
from ...scene.camera import (Camera, cube_face_views, look_at, orthographic_matrix, perspective_matrix, view_from_world)
from ...scene.changes import GeometryDelta
from ...scene.data import ALL_LINK_SETS, LIGHT_AREA, LIGHT_POINT, LIGHT_SPOT, LIGHT_SUN, Lights, SceneData
from ...scene.light_linking import blockers, object_shadow_sets, shadow_linked
from ...scene.settings import RenderSettings
from ..frame_context import FrameContext, PassIO
from ..scene_upload.scene_buffers import GPUScene
from .shadow_atlas import ShadowAtlas, ShadowView
from .shadow_cache import ShadowCache, ShadowPlan, snapped_bounds
from .sun_cascades import sun_cascade_views

# Spots wider than this get a cube shadow: a single perspective map degenerates near 180°.
MAX_SPOT_SHADOW_FOV = math.radians(150.0)


def needs_cube_shadow(kind: int) -> bool:
    """Point and area lights shine in all directions of a hemisphere or more: six slots."""
    return kind in (LIGHT_POINT, LIGHT_AREA)


def shadow_key(lights: Lights) -> bytes:
    """What of the lamps the shadow maps depend on: kind, place, direction, size, cone and
    whether they cast shadows (not their colour or power)."""
    return b"".join(np.ascontiguousarray(a).tobytes() for a in (
        lights.kind, lights.position, lights.direction, lights.radius, lights.spot_size, lights.spot_blend,
        lights.cast_shadow, lights.area_axis, lights.area_size_y, lights.area_elliptic))


def alpha_key(materials) -> bytes:
    """What of the materials the shadow maps depend on: their coverage (alpha.glsl), and
    which images give it (the arrays are immutable, MaterialTable: their identity names
    their content). Empty for a table without alpha."""
    if not materials.has_alpha:
        return b""
    images = [id(materials.textures[i]) if i >= 0 else -1 for i in materials.alpha_texture]
    return b"".join(np.ascontiguousarray(a).tobytes() for a in (
        materials.alpha, materials.alpha_channel, materials.alpha_clip, np.asarray(images, np.int64)))


@dataclass
class ShadowLinks:
    """Shadow linking of a frame (scene/light_linking.py): each slot's lamp's mask of the
    blocker sets that cast its shadow, and each object's blocker set."""

    slot_masks: np.ndarray  # (slots,) uint64
    object_sets: np.ndarray  # (K,) int32

    @classmethod
    def of(cls, scene: SceneData, per_light: list[tuple[int, int]], slots: int) -> "ShadowLinks | None":
        """None for a scene whose lamps' shadows hold every object (no work at all then)."""
        lights = scene.lights
        if not shadow_linked(lights):
            return None
        masks = np.full(slots, ALL_LINK_SETS, np.uint64)
        for i, (first, count) in enumerate(per_light):
            if first >= 0:
                masks[first:first + count] = lights.shadow_mask[i]
        return cls(masks, object_shadow_sets(scene))

    def key(self) -> bytes:
        """What of the linking the maps depend on: an edit re-renders them."""
        return self.slot_masks.tobytes() + self.object_sets.tobytes()


@dataclass
class ShadowLayout:
    """Every shadow slot's view, each light's (first, count) slots, and which slots are sun
    cascades (they follow the camera; the others only the scene)."""

    views: list[ShadowView]
    per_light: list[tuple[int, int]]
    cascade: np.ndarray  # bool per slot


def shadow_views(scene: SceneData, bounds: SceneBounds, camera: Camera | None = None, cascades: int = 0,
                 resolution: int = 1024) -> ShadowLayout:
    """Every shadow slot's view and each light's (first, count) slots.

    Sun: ``cascades`` maps over the camera's view, finest first (sun_cascades.py, none
    without a camera), then an orthographic map fitted around the scene's bounding sphere.
    Spot: a perspective map covering the cone. Point and area (and very wide spots): six
    90° cube faces.
    """
    lights = scene.lights
    matrices: list[ShadowView] = []
    per_light: list[tuple[int, int]] = []
    cascade: list[bool] = []
    if bounds.empty:
        return ShadowLayout(matrices, [(-1, 0)] * len(lights), np.zeros(0, bool))
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
            if camera is not None:
                fitted = sun_cascade_views(camera, direction, bounds, cascades, resolution)
                matrices.extend(fitted)
                cascade.extend([True] * len(fitted))
            eye = center - direction * radius * 2.0
            view = view_from_world(look_at(eye, center))
            proj = orthographic_matrix(radius, radius, radius * 0.5, radius * 3.5)
            matrices.append(ShadowView(proj @ view, 2.0 * radius, False, radius * 0.5, radius * 3.5))
        else:
            far = float(np.linalg.norm(pos - center) + radius) * 1.01
            # A share of the far plane, never a length in scene units: one scene at 1 mm and
            # at 1 km keeps the same depth range, and a millimetre scene's blockers are not
            # clipped by a near plane as deep as the scene.
            near = far * 1e-4
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
        cascade.extend([False] * (len(matrices) - len(cascade)))
        per_light.append((first, len(matrices) - first))
    return ShadowLayout(matrices, per_light, np.asarray(cascade, bool))


def frame_shadow_views(scene: SceneData, camera: Camera | None = None, cascades: int = 0,
                       resolution: int = 1024) -> ShadowLayout:
    """This frame's shadow slots, fitted to the scene's bounds snapped to a grid (so that
    objects moving inside the scene keep the matrices, and with them the static layer)."""
    bounds = SceneBounds.of(scene)
    return shadow_views(scene, SceneBounds(*snapped_bounds(bounds.lo, bounds.hi)), camera, cascades, resolution)


@dataclass
class ShadowMaps:
    """What one frame's shadow pass did: the atlas it drew into, each light's (first,
    count) slots, whether any layer, the static layer and the sun cascades were re-rendered,
    and the triangles submitted."""

    atlas: ShadowAtlas
    per_light: list[tuple[int, int]]
    rendered: bool
    static_rendered: bool
    submitted: int
    cascades_rendered: bool = False
    cascade_maps_rendered: int = 0  # of the sun cascades, how many were drawn again

    def counts(self) -> dict[str, int]:
        return {"shadow_maps_rendered": int(self.rendered), "shadow_static_rendered": int(self.static_rendered),
                "shadow_cascades_rendered": int(self.cascades_rendered),
                "shadow_cascade_maps_rendered": int(self.cascade_maps_rendered),
                "shadow_triangles_submitted": int(self.submitted)}


@dataclass
class LayerDraws:
    """One group of slots' draws this frame: the slots whose static and whose dynamic layer
    are drawn again (bool per slot), the objects of the static layer, and the name of the
    group's cullers (view_cull/draw.py: one per layer, so that no index buffer is rewritten
    while an earlier draw of the frame may read it)."""

    name: str
    static_mask: np.ndarray
    static: np.ndarray
    dynamic: np.ndarray

    @classmethod
    def planned(cls, name: str, plan: ShadowPlan, slots: np.ndarray, moved: np.ndarray) -> "LayerDraws":
        """All of ``slots`` in each layer ``plan`` renders, else the ``moved`` ones (whose
        matrix changed: both their layers)."""
        return cls(name, plan.static_mask, slots if plan.render_static else moved,
                   slots if plan.render_dynamic else moved)

    def slots(self, dynamic: bool) -> np.ndarray:
        return self.dynamic if dynamic else self.static


class ShadowDepthPass:
    """Renders the shadow atlas's layers that this frame's changes invalidated."""

    name = "shadow_maps"

    def __init__(self, ctx, drawer: SceneDrawer) -> None:
        self.ctx = ctx
        self.drawer = drawer
        self.atlas = ShadowAtlas(ctx)  # every lamp's slots, in a static and a dynamic layer
        self.program = self.variant(False)
        self.cache = ShadowCache()  # the slots fitted to the scene
        self.cascade_cache = ShadowCache()  # the sun cascades, fitted to the view
        # The last frame's cascade matrices, None for the other slots (_moved_cascades).
        self._cascade_matrices: list[bytes | None] | None = None

    def io(self, settings: RenderSettings) -> PassIO:
        return PassIO(reads=("scene", "world_triangles", "delta"), writes=("shadow_maps",))

    def run(self, frame: FrameContext) -> None:
        shadows = self.render(frame.read("world_triangles"), frame.read("scene"), frame.camera, frame.settings,
                              self.atlas, frame.read("delta"))
        frame.counts.update(shadows.counts())
        frame.write("shadow_maps", shadows)

    def release(self) -> None:
        self.atlas.release()

    def render(self, gpu: GPUScene, scene: SceneData, camera: Camera | None, settings: RenderSettings,
               atlas: ShadowAtlas, delta: GeometryDelta) -> ShadowMaps:
        """Lay out this frame's slots in ``atlas`` and re-render the layers ``delta``
        invalidated (shadow_cache.py); the lights, the resolution and the slots' matrices
        key the cache, so any change to them renders both layers. The sun cascades follow
        ``camera``: they keep a cache of their own, and each cascade is re-rendered when its
        own matrix changes: a walking camera moves the finest cascade every few frames and
        the coarser ones far less often (sun_cascades.py), so only the finest is drawn
        again then."""
        resolution = int(settings.shadow_resolution)
        layout = frame_shadow_views(scene, camera, int(settings.shadow_cascades), resolution)
        views, cascade = layout.views, layout.cascade
        links = ShadowLinks.of(scene, layout.per_light, len(views))
        # -- closure alpha: an alpha program's values are coverage too (an edit is an upload of
        # words, nothing the table shows), and so are the images it may read
        programs = gpu.node_programs
        program_alpha = ((programs.alpha_key, tuple(id(t) for t in scene.materials.textures or ()))
                         if programs.closure_alpha else b"")
        key = (shadow_key(scene.lights), alpha_key(scene.materials), program_alpha, resolution, len(views), cascade.tobytes(),
               b"".join(np.asarray(v.view_proj, np.float64).tobytes() for v, c in zip(views, cascade) if not c),
               links.key() if links is not None else b"")
        ranges = scene.geometry.object_ranges
        draws = [LayerDraws.planned("shadow", self.cache.plan(ranges, delta, key), ~cascade, np.zeros_like(cascade))]
        moved = self._moved_cascades(views, cascade)
        if cascade.any():
            # The cache's plan covers what the objects did (keyed by the scene's key, so a
            # cascade's move alone keeps it); a moved cascade draws both its layers.
            draws.append(LayerDraws.planned("shadow_cascades", self.cascade_cache.plan(ranges, delta, key),
                                            cascade, moved))
        else:
            self.cascade_cache.reset()
        submitted = 0
        if any(draw.static.any() or draw.dynamic.any() for draw in draws):
            try:
                atlas.layout(views, resolution)
                for dynamic in (False, True):
                    wanted = [draw for draw in draws if draw.slots(dynamic).any()]
                    if not wanted:
                        continue
                    drawn = np.logical_or.reduce([draw.slots(dynamic) for draw in wanted])
                    atlas.begin_layer(dynamic, None if drawn.all() else
                                      [atlas.rect(int(i)) for i in np.flatnonzero(drawn)])
                    for draw in wanted:
                        include = ~draw.static_mask if dynamic else draw.static_mask
                        layer = f"{draw.name}_{'dynamic' if dynamic else 'static'}"
                        submitted += self.render_linked(layer, gpu, scene, atlas, views, draw.slots(dynamic),
                                                        dynamic, include, links)
            except BaseException:
                self.cache.reset()  # the layers are incomplete
                self.cascade_cache.reset()
                self._cascade_matrices = None
                raise
        cascade_maps = int((draws[-1].static | draws[-1].dynamic).sum()) if len(draws) > 1 else 0
        scene_static, scene_dynamic = bool(draws[0].static.any()), bool(draws[0].dynamic.any())
        return ShadowMaps(atlas, layout.per_light, scene_static or scene_dynamic or cascade_maps > 0, scene_static,
                          submitted, cascade_maps > 0, cascade_maps)

    def _moved_cascades(self, views: list[ShadowView], cascade: np.ndarray) -> np.ndarray:
        """Bool per slot: a cascade whose matrix differs from the last frame's (every cascade
        when the slots were laid out differently)."""
        matrices = [np.asarray(v.view_proj, np.float64).tobytes() if c else None for v, c in zip(views, cascade)]
        last = self._cascade_matrices
        self._cascade_matrices = matrices
        if last is None or len(last) != len(matrices):
            return cascade.copy()
        return np.array([m is not None and m != old for m, old in zip(matrices, last)], bool)

    def render_linked(self, layer: str, gpu: GPUScene, scene: SceneData, atlas: ShadowAtlas,
                      views: list[ShadowView], slots: np.ndarray, dynamic: bool, include: np.ndarray | None,
                      links: ShadowLinks | None) -> int:
        """``render_slots``, with shadow linking: the slots of the lamps whose blocker
        collection leaves objects out draw only their blockers, a group of slots per mask
        (each with cullers of its own, as each layer has); the others draw every object."""
        if links is None:
            return self.render_slots(layer, gpu, scene, atlas, views, slots, dynamic, include)
        submitted = 0
        for k, mask in enumerate(np.unique(links.slot_masks[slots])):
            group = slots & (links.slot_masks == mask)
            if mask == ALL_LINK_SETS:
                submitted += self.render_slots(layer, gpu, scene, atlas, views, group, dynamic, include)
                continue
            blocking = blockers(links.object_sets, int(mask))
            submitted += self.render_slots(f"{layer}_linked{k}", gpu, scene, atlas, views, group, dynamic,
                                           blocking if include is None else include & blocking)
        return submitted

    def render_slots(self, layer: str, gpu: GPUScene, scene: SceneData, atlas: ShadowAtlas,
                     views: list[ShadowView], slots: np.ndarray, dynamic: bool,
                     include: np.ndarray | None = None) -> int:
        """Draw the objects ``include`` selects (all when None) into the slots ``slots``
        selects of one layer of ``atlas`` (static or dynamic; begun by the caller), laid out
        for ``views`` (ShadowAtlas.layout); returns triangles submitted. ``layer`` names the
        drawer's cullers."""
        ctx = self.ctx
        chosen = np.flatnonzero(slots)
        if not len(chosen) or (include is not None and not include.any()):
            return 0
        alpha = scene.materials.has_alpha
        # -- closure alpha: the node programs' interpreter where some alpha is a program's
        programs = dict(gpu.defines) if alpha and gpu.node_programs.closure_alpha else {}
        prog = self.variant(alpha, **programs)
        faces_prog = self.faces_program(alpha, programs)

        def bind() -> None:
            ctx.enable(ctx.DEPTH_TEST)
            ctx.disable(ctx.CULL_FACE)
            if alpha:  # the alpha test reads the materials, the triangles' ids and the images
                for program in (prog, faces_prog) if faces_prog is not None else (prog,):
                    bind_storage(program, gpu.bindings())

        draws = [(views[i].view_proj, atlas.rect(int(i))) for i in chosen]
        if self.drawer.draws_instanced():
            table = gpu.instance_transform.instance_table

            def bind_program(program) -> None:
                bind()
                bind_storage(program, *((gpu.bindings(),) if alpha else ()), storage={"InstanceTable": table})

            return self.drawer.draw_instanced(layer, self.instanced_program(alpha, programs), prog, gpu, scene,
                                              atlas.layer_framebuffer(dynamic), draws, bind_program, include)
        return self.drawer.draw_views(layer, prog, self.drawer.vertex_array(prog, gpu), gpu, scene,
                                      atlas.layer_framebuffer(dynamic), draws, bind, include,
                                      faces_prog=faces_prog)

    def variant(self, alpha: bool, **defines):
        """The depth program with ``defines``, and with the alpha test (``ALPHA_TEST``,
        shadow_depth.frag.glsl) where ``alpha``: only scenes with alpha draw their shadows
        with a fragment stage that may discard. Compiled on first use, cached."""
        if alpha:
            defines["ALPHA_TEST"] = 1
        return shader_loader.program(self.ctx, vertex="shadow_maps/shadow_depth.vert.glsl",
                                     fragment="shadow_maps/shadow_depth.frag.glsl", defines=defines or None)

    def instanced_program(self, alpha: bool = False, programs: dict | None = None):
        """The depth program of the instanced, indexed draws (the ``vertices`` kernel's "gpu"
        variant, view_cull/instanced_draw.py). ``programs``: the node programs' defines,
        where some material's alpha is a program (GPUScene.defines)."""
        return self.variant(alpha, INSTANCED=1, **(programs or {}))

    def faces_program(self, alpha: bool = False, programs: dict | None = None):
        """The depth program that draws up to view_cull.MAX_VIEWS slots (a point lamp's six
        faces) in one multi-draw (draw.py SceneDrawer.draw_faces); None where the ``faces``
        kernel's "cpu" variant draws them one by one."""
        if not self.drawer.faces_in_one_draw():
            return None
        return self.variant(alpha, FACE_VIEWPORTS=MAX_VIEWS, **(programs or {}))
