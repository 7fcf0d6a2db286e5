# SPDX-License-Identifier: GPL-3.0-or-later
"""The G-buffer cube map of paper §3.2.

Six G-buffers (depth, normal + material index, surface UV, geometric normal) rendered
from the camera position every frame. Each face camera has a field of view of 90.2° rather
than 90°, so that a ray lying in one of the diagonal planes between two faces always
belongs to at least one face (paper Figure 3). Each face's near plane lies at ``near_size``: the six near
planes are the faces of the *near cube*, the boundary between BVH traversal inside and
image-based ray marching outside, and geometry inside the near cube is clipped away here.

The faces share one atlas, face i occupying texels [i * res, (i + 1) * res) in x, in the
order +X, -X, +Y, -Y, +Z, -Z. Because all faces share the centre, the face-to-face
matrices M_j M_i^-1 that the marcher uses to switch faces (§3.4) do not depend on the
camera position and are computed once per (near, far).

The back layer (``settings.cube_back_layer``, off by default) goes past the paper's single
layer (§4.1: "objects that have some thickness ... are not represented"): a second row of
the atlas, texels [res, 2 res) in y, holds each face rasterized again with only the back
faces of closed objects, so the marcher knows where such an object ends along each line of
sight and what its hidden side looks like (gpu_shaders/include/cube_march.glsl).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...gpu.render_targets import RenderTargets
from ...scene import matrix4
from ...scene.camera import CUBE_FACE_DIRECTIONS, cube_face_views, perspective_matrix
from ...scene.data import SceneData
from ...scene.raster_view import RasterView, gl_matrix
from ...scene.settings import RenderSettings
from ..frame_context import FrameContext, PassIO
from ..gbuffer.gbuffer import GBufferPass
from ..scene_upload.scene_buffers import GPUScene
from ..view_cull.view_cull import CullView, CulledDraws, ViewTriangleCuller
from .cube_pyramid import CubeHitPyramid

CUBE_FACE_FOV = math.radians(90.2)  # paper §3.2, Figure 3
FACE_NAMES = ("+X", "-X", "+Y", "-Y", "+Z", "-Z")


class CubeFaceTargets(RenderTargets):
    """The six faces' G-buffers as one atlas (face i covers texels [i * res, (i + 1) * res)
    in x): ``depth``; ``normal_material`` as the primary G-buffer's (render_targets.GBufferTargets);
    ``surface`` (RGBA32F): UV and UV density (sqrt of UV area per world area); ``geometric``
    (RG16F): the octahedral geometric normal; with ``tangent`` (node programs), ``tangent``
    (RGBA16F): the triangle's UV directions on axes around that normal
    (include/cube_tangent.glsl), which a cube hit's tangent-space Normal Map and UV-reading
    Bump need as a BVH hit does.

    The faces keep texture coordinates rather than colours: the tracer samples the
    textures only at the texels its rays hit, with the ray cone's mip level as at BVH
    hits (gbuffer.frag.glsl, CUBE_FACE). Float32 UVs because repeated textures carry
    coordinates far past [0, 1]."""

    def __init__(self, ctx, width: int, height: int, tangent: bool = False) -> None:
        # clear() resets depth and ``normal_material`` only. A texel is empty where its
        # material word is 0, and the march reads ``surface`` and ``geometric`` only at texels
        # it hits, so what those two hold elsewhere is never read; clearing them would be more
        # than half of the 40 bytes per texel written. ``tangent`` likewise.
        self.has_tangent = tangent
        colour = {"normal_material": (4, "f4"), "surface": (4, "f4"), "geometric": (2, "f2")}
        if tangent:
            colour["tangent"] = (4, "f2")
        super().__init__(ctx, width, height, colour=colour, cleared=("normal_material",))


@dataclass(frozen=True)
class CubeFaces:
    """The six face cameras of one frame."""

    center: np.ndarray  # (3,)
    near: float
    far: float
    view_proj: np.ndarray  # (6, 4, 4) world -> clip
    inv_view_proj: np.ndarray  # (6, 4, 4)
    face_to_face: np.ndarray  # (6, 6, 4, 4): clip of face i -> clip of face j

    @classmethod
    def at(cls, center, near: float, far: float) -> "CubeFaces":
        c = np.asarray(center, np.float64)
        proj = perspective_matrix(CUBE_FACE_FOV, 1.0, near, far)
        vp = np.stack([proj @ v for v in cube_face_views(c)])
        inv = np.stack([matrix4.inverse(m) for m in vp])
        f2f = np.einsum("jab,ibc->ijac", vp, inv)
        return cls(c, float(near), float(far), vp, inv, f2f)

    def views(self, resolution: int) -> list[RasterView]:
        return [
            RasterView(self.view_proj[i], self.center, CUBE_FACE_DIRECTIONS[i], False, resolution, resolution)
            for i in range(6)
        ]


def face_of_direction(direction: np.ndarray) -> np.ndarray:
    """The face whose axis is the major axis of each direction (the first face that
    contains it; the 0.1° overlap means neighbours contain it too)."""
    d = np.asarray(direction, np.float64).reshape(-1, 3)
    axis = np.argmax(np.abs(d), axis=1)
    negative = d[np.arange(len(d)), axis] < 0
    return axis * 2 + negative


@dataclass(frozen=True)
class MarchableCubeMap:
    """What a ray needs to march a rendered cube map (cube_march.glsl, paper §3.4): the
    marching shaders' defines, its samplers' textures (the faces' depth, normals and
    materials, hit-interval pyramid, surface UVs and geometric normals) and its uniforms."""

    defines: dict
    textures: dict
    uniforms: dict


class CubeMapPass:
    """Renders the six face G-buffers into one atlas and prepares them for marching (the
    frame's ``cube_map_raster`` pass).

    The faces are neither shaded nor textured here: the tracer shades the few texels its
    rays hit (with the ray's own view direction and the ray cone's texture level) instead
    of all 6 res^2, which on a software GL costs as much as the face rasterisation itself.
    The HIERARCHICAL march needs the hit-interval pyramid (:mod:`.cube_pyramid`), built
    here after the faces.
    """

    name = "cube_map_raster"
    # Whether the pyramid pass builds the surface footprints where the rays march the map
    # (``marches_footprints``); off only to measure the march without them.
    footprints = True

    def __init__(self, ctx, gbuffer: GBufferPass) -> None:
        self.ctx = ctx
        self.gbuffer = gbuffer
        self.targets: CubeFaceTargets | None = None
        self.faces: CubeFaces | None = None
        self.pyramid = CubeHitPyramid(ctx)
        self.culler: ViewTriangleCuller | None = None
        self.back_culler: ViewTriangleCuller | None = None
        self.culled: CulledDraws | None = None  # this frame's per-triangle culling, if any
        self.culled_back: CulledDraws | None = None  # the same for the back layer
        self.resolution = 0
        self.back_layer = False
        self.hidden_exit = False
        self.sampled = False
        self.footprint = False  # the last render built the surface footprints

    def _ensure_targets(self, resolution: int, layers: int, tangent: bool) -> CubeFaceTargets:
        size = (6 * resolution, layers * resolution)
        if self.targets is None or self.targets.size != size or self.targets.has_tangent != tangent:
            old, self.targets = self.targets, CubeFaceTargets(self.ctx, *size, tangent=tangent)
            if old is not None:
                old.release()
        return self.targets

    def io(self, settings: RenderSettings) -> PassIO:
        return PassIO(reads=("scene", "world_triangles"), writes=("cube_map",))

    def run(self, frame: FrameContext) -> None:
        """The faces around the eye, their draws culled per triangle from the frame's world
        triangles."""
        buffers = frame.read("world_triangles")
        submitted = self.render(buffers, frame.read("scene"), frame.center, frame.settings,
                                triangles=(buffers.positions.buffer, buffers.triangle_count))
        frame.counts["triangles_cube_map_submitted"] = int(submitted)
        frame.write("cube_map", self.marchable(frame.settings))

    def marchable(self, settings: RenderSettings) -> MarchableCubeMap:
        """The last render, as a ray marching it binds it (with node programs, the texels'
        tangent frames as ``u_cube_tangent``)."""
        tangent = {"u_cube_tangent": self.targets.tangent} if self.targets.has_tangent else {}
        return MarchableCubeMap(
            defines=self.march_defines(),
            textures={**self.march_textures(), "u_cube_surface": self.targets.surface,
                      "u_cube_geometric": self.targets.geometric, **tangent},
            uniforms=self.march_uniforms(settings))

    def render(self, gpu: GPUScene, scene: SceneData, center, settings: RenderSettings,
               triangles: tuple[object, int] | None = None) -> int:
        """Rasterize all six faces (and their back layer, ``settings.cube_back_layer``);
        returns the triangles submitted (after per-face object culling, which also drops
        objects wholly inside the near cube). ``triangles`` -- the scene's world triangles
        in a GL buffer and their count -- enables per-triangle culling of the faces' draws
        on the GPU (view_cull.py: same G-buffers, a fraction of the triangles rasterized);
        without it, or past the culler's buffer limit, each face draws its object list
        directly."""
        res = int(settings.cube_resolution)
        geo = scene.geometry
        self.back_layer = bool(settings.cube_back_layer)
        self.hidden_exit = bool(settings.cube_hidden_exit)
        self.sampled = settings.cube_march != "HIERARCHICAL"
        # Node programs: the faces' fragment stage writes each texel's tangent frame too.
        targets = self._ensure_targets(res, 2 if self.back_layer else 1, "NODE_PROGRAMS" in gpu.defines)
        self.faces = CubeFaces.at(center, settings.near_size, settings.cube_far)
        self.resolution = res
        targets.clear()
        views = self.faces.views(res)
        closed = geo.object_closed
        draw_back = self.back_layer and closed is not None and bool(np.any(closed))
        self.culled = self.culled_back = None
        if triangles is not None and geo.triangle_count:
            if self.culler is None:
                self.culler = ViewTriangleCuller(self.ctx)
            cull_views = [CullView(v.view_proj, v.width, v.height) for v in views]
            if draw_back:
                # One test per triangle for both layers' lists.
                if self.back_culler is None:
                    self.back_culler = ViewTriangleCuller(self.ctx)
                self.culled, self.culled_back = self.culler.cull_with_back(
                    self.back_culler, triangles[0], triangles[1], cull_views,
                    geo.object_ranges, geo.object_bounds, closed)
            else:
                self.culled = self.culler.cull(triangles[0], triangles[1], cull_views,
                                               geo.object_ranges, geo.object_bounds, closed)
        submitted = self.gbuffer.render_cube_faces(gpu, scene, views, targets, self.culled, self.culled_back,
                                                   back_layer=draw_back)
        self.footprint = self.marches_footprints(settings)
        if settings.cube_march == "HIERARCHICAL":
            self.pyramid.build(targets.depth, targets.normal_material, gpu.materials.buffer,
                               self.march_uniforms(settings), res, self.layer_defines(),
                               geometric=targets.geometric if self.footprint else None)
        return submitted

    def marches_footprints(self, settings: RenderSettings) -> bool:
        """Whether the rays march this map by its surface footprints (cube_march.glsl
        "Surface footprints"): the tracer's and the diffuse paths' in HYBRID, with the
        hierarchical march, which alone follows them."""
        return self.footprints and settings.trace_mode == "HYBRID" and settings.cube_march == "HIERARCHICAL"

    def march_uniforms(self, settings: RenderSettings) -> dict:
        """Values of cube_march.glsl's uniforms (samplers excluded) for the last render."""
        faces = self.faces
        return {
            "u_face_view_proj": b"".join(gl_matrix(m) for m in faces.view_proj),
            "u_face_inv_view_proj": b"".join(gl_matrix(m) for m in faces.inv_view_proj),
            "u_face_to_face": b"".join(gl_matrix(faces.face_to_face[i, j])
                                       for i in range(6) for j in range(6)),
            "u_cube_center": tuple(faces.center),
            "u_cube_near": float(faces.near),
            "u_cube_far": float(faces.far),
            "u_cube_res": int(self.resolution),
            "u_n_min": int(settings.n_min),
            "u_n_max": int(settings.n_max),
            "u_cube_hiz_res": int(self.pyramid.face_size),
            "u_cube_hiz_levels": int(self.pyramid.levels),
        }

    def layer_defines(self) -> dict:
        """The back layer's define (cube_march.glsl), for the last render: compiled in only
        when the atlas holds one. All the hit-interval pyramid needs."""
        return {"CUBE_BACK_LAYER": 1} if self.back_layer else {}

    def march_defines(self) -> dict:
        """Defines of the marching shaders (cube_march.glsl), for the last render: the
        sampled march when the settings ask for it (the hierarchical one, the default, needs
        none), the layer's, and the hidden-exit rule when the settings ask for it."""
        return {**({"CUBE_SAMPLED": 1} if self.sampled else {}), **self.layer_defines(),
                **({"CUBE_HIDDEN_EXIT": 1} if self.hidden_exit else {})}

    def march_textures(self) -> dict:
        """cube_march.glsl's samplers → textures of the last render."""
        textures = {"u_cube_depth": self.targets.depth,
                    "u_cube_normal_material": self.targets.normal_material}
        if self.pyramid.texture is not None:
            textures["u_cube_hiz"] = self.pyramid.texture
        if self.footprint:
            textures["u_cube_footprint"] = self.pyramid.footprint
            textures["u_cube_planes"] = self.pyramid.planes
        return textures

    def release(self) -> None:
        self.pyramid.release()
        for culler in (self.culler, self.back_culler):
            if culler is not None:
                culler.release()
        self.culler = self.back_culler = None
        if self.targets is not None:
            self.targets.release()
            self.targets = None
