# SPDX-License-Identifier: GPL-3.0-or-later
"""Drawing the scene's triangles for a raster pass: per-object frustum culling, GL face
culling where it loses nothing, and per-triangle culling on the GPU.

The G-buffer pass (primary view and cube-map faces, paper §3.1, §3.2) and the shadow-map
pass (§3.5) draw the scene the same way; one ``SceneDrawer`` per renderer serves both.

The primary view and the shadow slots draw GPU-culled triangle lists (view_cull.py, as the
cube-map faces do): a dense mesh far from the camera puts many triangles on every pixel, and
most of them cover no pixel centre or face away. The culling compute pass drops them before
the rasterizer sets them up, and the images are bit-identical to drawing the object lists.
On a software GL this matters twice over: vertex processing and triangle setup run on one
thread there, the compute pass on all of them. A dense model far away, covering fewer
pixels than it has triangles, keeps a small fraction of its triangles.

The views of one culled batch -- the cube map's six faces, a point lamp's six shadow faces --
are drawn one draw per view (the ``faces`` kernel's "cpu" variant, gpu/variants.py: the
faster on llvmpipe, whose draws cost little to issue) or all in one multi-draw, each view
picking its viewport in the vertex stage (the "gpu" variant, :meth:`SceneDrawer.draw_faces`:
one submission instead of six, as a GPU wants). Both write the same images bit for bit.
"""
from __future__ import annotations

from collections.abc import Callable
from contextlib import contextmanager

import numpy as np

from ...gpu import variants
from ...gpu.bindings import set_uniforms
from ...gpu.viewport_array import viewport_array
from ...scene.data import SceneData
from ...scene.raster_view import gl_matrix
from ..scene_upload.scene_buffers import GPUScene
from .frustum import beyond_near_plane, draw_ranges, front_face_winding, visible_objects
from .instanced_draw import InstancedDrawer, InstancedStats
from .view_cull import CullView, CulledDraws, MAX_VIEWS, ViewTriangleCuller

# Scenes with fewer triangles draw their object lists directly: the culling pass's three
# dispatches cost more than it saves.
CULL_MIN_TRIANGLES = 16384

# A draw: the view-projection and the viewport rectangle (x, y, w, h) it draws into.
ViewDraw = tuple[np.ndarray, tuple[int, int, int, int]]


class SceneDrawer:
    """Draws the scene's uploaded triangles into the bound framebuffer for one program."""

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        # Per-triangle culling (module doc). One culler per layer and batch of views, so
        # that no index buffer is rewritten in a frame while an earlier draw of that frame
        # may still read it. False draws the object lists.
        self.cull_triangles = True
        self._cullers: dict[tuple[str, int], ViewTriangleCuller] = {}
        # Each layer's last culled batches (None: drawn from the object lists), for tests and
        # statistics: CulledDraws.drawn() reads the survivors' counts back.
        self.culled: dict[str, list] = {}
        # The ``vertices`` kernel's "gpu" variant: instanced, indexed draws (instanced_draw.py),
        # one drawer per layer, and each layer's last InstancedStats.
        self._instanced: dict[str, InstancedDrawer] = {}
        self.instanced: dict[str, InstancedStats] = {}

    def draws_instanced(self) -> bool:
        """Whether the raster passes draw instanced and indexed from object-space meshes (the
        ``vertices`` kernel's "gpu" variant) rather than from the world-space rows."""
        return variants.choose("vertices") == "gpu"

    def draw_instanced(self, layer: str, prog, rows_prog, gpu: GPUScene, scene: SceneData, fbo,
                       views: list[ViewDraw], bind_program: Callable[[object], None],
                       include: np.ndarray | None = None) -> int:
        """:meth:`draw_views` in the ``vertices`` kernel's "gpu" shape: the objects whose bounds
        touch each view (and that ``include`` selects) drawn instanced and indexed with
        ``prog`` (an INSTANCED program), those the raster meshes cannot draw from the rows
        with ``rows_prog`` (instanced_draw.py); no per-triangle culling. ``bind_program(p)``
        binds program p and sets the draws' GL state. Returns triangles submitted;
        ``instanced[layer]`` holds what was drawn."""
        drawer = self._instanced.get(layer)
        if drawer is None:
            drawer = self._instanced[layer] = InstancedDrawer(self.ctx)
        gpu.raster_meshes.update(scene.geometry)
        self.culled[layer] = [None]
        fbo.use()
        stats = drawer.draw(prog, bind_program, rows_prog, self.vertex_array(rows_prog, gpu), gpu.raster_meshes,
                            scene, fbo, views, self.face_culling, include)
        self.instanced[layer] = stats
        return stats.triangles

    def vertex_array(self, prog, gpu: GPUScene):
        """``prog``'s vertex array over ``gpu``'s buffers, rebuilt only when they change."""
        return gpu.vertex_array(prog)

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
            with self.face_culling(view_proj, cull):
                for first, count in ranges:
                    vao.render(ctx.TRIANGLES, vertices=count * 3, first=first * 3)
                    submitted += count
        return submitted

    def faces_in_one_draw(self) -> bool:
        """Whether culled batches of views are drawn by one multi-draw (the ``faces``
        kernel's "gpu" variant, where the context has viewport arrays) or one draw per view."""
        return variants.choose("faces") == "gpu" and viewport_array(self.ctx) is not None

    def draw_faces(self, prog, gpu: GPUScene, fbo, culled: CulledDraws, views: list[ViewDraw],
                   cull: str | None = None) -> int | None:
        """Draw the survivors of all ``views`` (one culled batch, in ``culled``'s order) with
        one multi-draw: ``prog`` is a FACE_VIEWPORTS variant whose draw d takes view d's
        matrix and viewport (gbuffer.vert.glsl, shadow_depth.vert.glsl), ``cull`` the GL face
        culling of the draws as in :meth:`face_culling`. Returns the triangles submitted, or
        None where one draw cannot do it (no viewport array, or views of different front-face
        windings under face culling): the caller then draws view by view."""
        array = viewport_array(self.ctx)
        if array is None or not 1 <= len(views) <= min(MAX_VIEWS, array.count):
            return None
        if cull is not None and len({front_face_winding(view_proj) for view_proj, _ in views}) > 1:
            return None
        matrices = [gl_matrix(view_proj) for view_proj, _ in views]
        matrices += [matrices[0]] * (MAX_VIEWS - len(matrices))  # the declared array's size
        set_uniforms(prog, {"u_face_view_proj": b"".join(matrices)})
        array.set([rect for _, rect in views])
        try:
            with self.face_culling(views[0][0], cull):
                return culled.draw_all(prog, gpu)
        finally:
            fbo.viewport = fbo.viewport  # glViewport: every viewport back to moderngl's one

    @contextmanager
    def face_culling(self, view_proj: np.ndarray, cull: str | None):
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
                   views: list[ViewDraw], bind: Callable[[], None],
                   include: np.ndarray | None = None, faces_prog=None) -> int:
        """Draw the scene with ``prog`` into ``fbo`` once per (view_proj, viewport) of
        ``views``: the objects whose bounds touch the view and that ``include`` selects (all
        when None). Returns triangles submitted after per-object culling. The draws are
        culled per triangle on the GPU first (module doc), in batches of view_cull.MAX_VIEWS
        views, unless ``cull_triangles`` is off, the scene is small
        (``CULL_MIN_TRIANGLES``) or a batch's index buffer would not fit one storage block
        (then that batch draws its object lists: the documented fallback). ``bind`` sets
        the draws' GL state; it runs after the culling, whose dispatches rebind storage
        buffers. ``layer`` names the caller's cullers. ``faces_prog``, the FACE_VIEWPORTS
        variant of ``prog``, draws each culled batch in one multi-draw where the ``faces``
        kernel's variant asks for it (:meth:`draw_faces`)."""
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
        one_draw = faces_prog is not None and self.faces_in_one_draw()
        for batch, batch_culled in zip(batches, culled):
            if one_draw and batch_culled is not None:
                drawn = self.draw_faces(faces_prog, gpu, fbo, batch_culled, batch)
                if drawn is not None:
                    submitted += drawn
                    continue
            for i, (view_proj, rect) in enumerate(batch):
                fbo.viewport = rect
                set_uniforms(prog, {"u_view_proj": gl_matrix(view_proj)})
                if batch_culled is not None:
                    submitted += batch_culled.draw(prog, gpu, i)
                else:
                    submitted += self.draw_world(vao, view_proj, scene, include)
        return submitted

    def release(self) -> None:
        for drawer in self._instanced.values():
            drawer.release()
        self._instanced.clear()
        for culler in self._cullers.values():
            culler.release()
        self._cullers.clear()
