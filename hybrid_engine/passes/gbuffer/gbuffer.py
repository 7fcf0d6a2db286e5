# SPDX-License-Identifier: GPL-3.0-or-later
"""The G-buffer pass (gpu_shaders/gbuffer/gbuffer.*.glsl): paper §3.1's primary visibility
and §3.2's cube-map faces.

The primary G-buffer's normal alpha holds the material index; its targets are allocated
once and again only when the image size changes. The cube-map faces use a variant of the
same shaders (``CUBE_FACE``) that leaves refractive surfaces out and stores UVs instead of
sampling the textures: a variant of its own, also because a shader that may discard loses
the early depth test.

The primary view is drawn in one of two shapes (the ``vertices`` kernel, gpu/variants.py):
from the instance transform's world-space rows, per-triangle culled (view_cull/draw.py; the
"cpu" variant, faster on llvmpipe), or instanced and indexed from object-space meshes
(view_cull/instanced_draw.py, shaders with ``INSTANCED``; the "gpu" variant, where the
post-transform cache shades shared vertices once). Both write the same G-buffer bit for bit.
"""
from __future__ import annotations

from ...gpu import shader_loader
from ...gpu.bindings import bind, set_uniforms
from ...gpu.render_targets import GBufferTargets, RenderTargets
from ...scene.data import SceneData
from ...scene.raster_view import RasterView, gl_matrix
from ...scene.settings import RenderSettings
from ..frame_context import FrameContext, PassIO
from ..scene_upload.scene_buffers import GPUScene
from ..view_cull.draw import SceneDrawer
from ..view_cull.view_cull import MAX_VIEWS


class GBufferPass:
    """Rasterizes views into G-buffers: the primary camera's (the frame's ``primary_raster``
    pass) and the cube map's faces (for cube_map.py)."""

    name = "primary_raster"

    def __init__(self, ctx, drawer: SceneDrawer | None = None) -> None:
        self.ctx = ctx
        self.drawer = drawer if drawer is not None else SceneDrawer(ctx)
        self._owns_drawer = drawer is None
        self.program = self.variant(None, False)
        self.cube_program = self.variant(None, False, CUBE_FACE=1)
        self.primary: GBufferTargets | None = None
        self._camera: dict = {}  # the primary view's camera uniforms (node programs read them)

    def variant(self, gpu: GPUScene | None, alpha: bool, **defines):
        """The G-buffer program with ``defines``; with the alpha test (``ALPHA_TEST``,
        gbuffer.frag.glsl) where ``alpha``: only scenes with alpha draw with a fragment stage
        that may discard, which costs the early depth test; and with the node-program
        interpreter where the scene's materials have programs (``gpu.defines``). Compiled on
        first use, then cached by the loader."""
        if alpha:
            defines["ALPHA_TEST"] = 1
        if gpu is not None:
            defines.update(gpu.defines)
        return shader_loader.program(self.ctx, vertex="gbuffer/gbuffer.vert.glsl",
                                     fragment="gbuffer/gbuffer.frag.glsl", defines=defines or None)

    def primary_targets(self, width: int, height: int, surface_channels: int = 2) -> GBufferTargets:
        """The primary camera's G-buffer, reallocated only when the image size (or the
        surface target's channels: four where node programs run) changes."""
        if (self.primary is None or self.primary.size != (width, height)
                or self.primary.surface_channels != surface_channels):
            old, self.primary = self.primary, GBufferTargets(self.ctx, width, height, surface_channels)
            if old is not None:
                old.release()
        return self.primary

    def _bind(self, gpu: GPUScene, prog, sample: int = 0) -> None:
        ctx = self.ctx
        ctx.enable(ctx.DEPTH_TEST)
        ctx.disable(ctx.CULL_FACE)  # Blender shades both sides of a face
        bind(prog, gpu.bindings(), storage={"InstanceTable": gpu.instance_transform.instance_table})
        set_uniforms(prog, {"u_alpha_sample": int(sample)})  # skipped without ALPHA_TEST
        if gpu.defines:  # node programs: Geometry Incoming and the like need the camera
            set_uniforms(prog, self._camera)

    def io(self, settings: RenderSettings) -> PassIO:
        return PassIO(reads=("scene", "world_triangles"), writes=("gbuffer",))

    def run(self, frame: FrameContext) -> None:
        targets, submitted = self.render_primary(frame.read("world_triangles"), frame.read("scene"), frame.view,
                                                 frame.sample)
        frame.counts["triangles_primary_submitted"] = int(submitted)
        frame.write("gbuffer", targets)

    def render_primary(self, gpu: GPUScene, scene: SceneData, view: RasterView,
                       sample: int = 0) -> tuple[GBufferTargets, int]:
        """Clear the primary G-buffer and rasterize ``view`` into it (§3.1), its draws culled
        per triangle (view_cull/draw.py). ``sample``: the view's sample index, which draws
        the alpha test's numbers afresh. Returns the targets and the triangles submitted."""
        targets = self.primary_targets(view.width, view.height, 4 if gpu.defines else 2)
        self._camera = view.uniforms()
        targets.clear()
        alpha = scene.materials.has_alpha
        prog = self.variant(gpu, alpha)
        if self.drawer.draws_instanced():
            return targets, self.drawer.draw_instanced(
                "primary", self.variant(gpu, alpha, INSTANCED=1), prog, gpu, scene, targets.fbo,
                [(view.view_proj, (0, 0, view.width, view.height))], lambda p: self._bind(gpu, p, sample))
        vao = self.drawer.vertex_array(prog, gpu)
        submitted = self.drawer.draw_views("primary", prog, vao, gpu, scene, targets.fbo,
                                           [(view.view_proj, (0, 0, view.width, view.height))],
                                           lambda: self._bind(gpu, prog, sample))
        return targets, submitted

    @property
    def last_instanced(self):
        """What the last instanced primary draw drew (None before the first)."""
        return self.drawer.instanced.get("primary")

    def render_cube_faces(self, gpu: GPUScene, scene: SceneData, views: list[RasterView], targets: RenderTargets,
                          culled=None, culled_back=None, back_layer: bool = False) -> int:
        """Rasterize the six face ``views`` side by side into ``targets`` (cube_map.py's
        atlas, cleared by the caller; §3.2), and with ``back_layer`` a second row holding
        only the back faces of closed objects. Refractive surfaces are left out: the faces
        hold what lies behind them (paper Figure 8; gbuffer.frag.glsl). ``culled`` and
        ``culled_back`` (view_cull.CulledDraws, the faces culled at once by cube_map.py)
        draw each face's GPU-culled list; None draws its object list (the culler's
        fallback). Returns the triangles submitted after per-object frustum culling."""
        alpha = scene.materials.has_alpha
        prog = self.variant(gpu, alpha, CUBE_FACE=1)
        vao = self.drawer.vertex_array(prog, gpu)
        targets.fbo.use()
        self._bind(gpu, prog)
        closed = scene.geometry.object_closed
        rows = [(0, culled, False)]
        if back_layer and closed is not None:
            rows.append((1, culled_back, True))
        submitted = 0
        one_draw = self.drawer.faces_in_one_draw()
        for row, row_culled, back_faces in rows:
            rects = [(i * view.width, row * view.height, view.width, view.height) for i, view in enumerate(views)]
            if one_draw and row_culled is not None:
                drawn = self.drawer.draw_faces(self.cube_faces_program(gpu, alpha), gpu, targets.fbo, row_culled,
                                               [(view.view_proj, rect) for view, rect in zip(views, rects)],
                                               "front" if back_faces else None)
                if drawn is not None:
                    submitted += drawn
                    continue
            for i, view in enumerate(views):
                targets.fbo.viewport = rects[i]
                set_uniforms(prog, {"u_view_proj": gl_matrix(view.view_proj)})
                if row_culled is None:
                    submitted += self.drawer.draw_world(vao, view.view_proj, scene,
                                                        include=closed if back_faces else None,
                                                        back_faces=back_faces)
                else:
                    with self.drawer.face_culling(view.view_proj, "front" if back_faces else None):
                        submitted += row_culled.draw(prog, gpu, i)
        return submitted

    def cube_faces_program(self, gpu: GPUScene, alpha: bool = False):
        """The cube-face program that draws all six faces in one multi-draw (the ``faces``
        kernel's "gpu" variant, draw.py SceneDrawer.draw_faces), bound like the per-face one."""
        prog = self.variant(gpu, alpha, CUBE_FACE=1, FACE_VIEWPORTS=MAX_VIEWS)
        self._bind(gpu, prog)
        return prog

    def release(self) -> None:
        if self.primary is not None:
            self.primary.release()
            self.primary = None
        if self._owns_drawer:
            self.drawer.release()
