# SPDX-License-Identifier: GPL-3.0-or-later
"""The hit-interval pyramid over the cube map's six faces (hierarchical march).

The paper marches each face with n_min..n_max equally spaced depth samples (§3.4). Most
secondary rays that reach the cube map cross regions that cannot stop them (sky, or
surfaces far behind or in front of the ray), and on a software GL every sample is a costly
texture fetch. The pyramid lets the march skip such regions whole: level 0 stores, per
texel, the NDC depth interval (A, B] a ray must reach to hit the stored surface (the
thickness rule of gpu_shaders/include/cube_march.glsl), and level L the (min A, max B) of
2^L x 2^L texels. Faces are padded to a power of two (``face_size``), so every cell lies in
one face and level L is simply the texture's mip level L.

Built every frame after the cube-map raster: one pass for level 0 and one small pass per
coarser level, all on the GPU.

With ``footprint``, the same passes also build the surface footprints
(gpu_shaders/include/cube_march.glsl, "Surface footprints") that the diffuse paths march: a
second pyramid (``footprint``) of the intervals each texel's surface plane reaches over its
square, and the planes themselves (``planes``, rgba16f: slopes and offsets, level 0's size),
so that a thin wall seen edge-on, whose depth changes across a texel by more than the bias
allows, is not stepped over. Mirror and glass rays keep walking ``texture``.
"""
from __future__ import annotations

import math

import moderngl

from ...gpu import shader_loader
from ...gpu.bindings import Image, bind
from ...gpu.dispatch import storage_barrier

WORKGROUP = 8  # local size of both pyramid shaders in x and y


def face_size(resolution: int) -> int:
    """The power-of-two face size of the pyramid for faces of ``resolution`` texels."""
    return 1 << max(0, math.ceil(math.log2(max(int(resolution), 1))))


class CubeHitPyramid:
    """GPU texture (rg32f, 6 * face_size x face_size, full mip chain) and its build passes;
    with the footprints (``build(geometric=...)``) ``footprint`` alike and ``planes``."""

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.base_prog = shader_loader.compute(ctx, "cube_map/cube_hiz_base.comp.glsl")
        self.reduce_prog = shader_loader.compute(ctx, "cube_map/cube_hiz_reduce.comp.glsl")
        self.texture: moderngl.Texture | None = None
        self.footprint: moderngl.Texture | None = None
        self.planes: moderngl.Texture | None = None
        self.face_size = 0
        self.levels = 0

    def _pyramid_texture(self, size: int, components: int = 2) -> moderngl.Texture:
        texture = self.ctx.texture((6 * size, size), components, dtype="f4")
        texture.build_mipmaps()  # allocates every level; the passes overwrite them
        texture.filter = (moderngl.NEAREST_MIPMAP_NEAREST, moderngl.NEAREST)
        return texture

    def _ensure_footprint(self) -> None:
        """The footprints' pyramid and planes (after ``_ensure_texture``), made when first
        asked for or when the faces change size."""
        if self.footprint is None or self.footprint.size != self.texture.size:
            if self.footprint is not None:
                self.footprint.release()
            self.footprint = self._pyramid_texture(self.face_size)
        if self.planes is None or self.planes.size != self.texture.size:
            if self.planes is not None:
                self.planes.release()
            self.planes = self.ctx.texture(self.texture.size, 4, dtype="f2")
            self.planes.filter = (moderngl.NEAREST, moderngl.NEAREST)

    def _ensure_texture(self, resolution: int) -> moderngl.Texture:
        size = face_size(resolution)
        if self.texture is None or self.face_size != size:
            if self.texture is not None:
                self.texture.release()
            self.texture = self._pyramid_texture(size)
            self.face_size = size
            self.levels = int(math.log2(size)) + 1
        return self.texture

    def build(self, depth, normal_material, materials_buffer, march_uniforms: dict,
              resolution: int, layer_defines: dict | None = None, geometric=None) -> None:
        """Fill every level from the cube atlas textures (``depth``, ``normal_material``)
        and the material table (thickness). ``march_uniforms`` are the cube_march.glsl
        uniform values of this frame's faces, ``layer_defines`` its back-layer define
        (CubeMapPass.layer_defines). ``geometric``, the faces' geometric normals: build the
        footprints too (``footprint``, ``planes``), in the same passes."""
        texture = self._ensure_texture(resolution)
        size = self.face_size
        defines = dict(layer_defines or {})
        images = {"u_level0": Image(texture, read=False, write=True, level=0)}
        if geometric is not None:
            self._ensure_footprint()
            defines["CUBE_FOOTPRINT_BUILD"] = 1
            images["u_footprint0"] = Image(self.footprint, read=False, write=True, level=0)
            images["u_planes"] = Image(self.planes, read=False, write=True)
        prog = (shader_loader.compute(self.ctx, "cube_map/cube_hiz_base.comp.glsl", defines)
                if defines else self.base_prog)
        bind(prog, storage={"MaterialBuffer": materials_buffer},
             textures={"u_cube_depth": depth, "u_cube_normal_material": normal_material,
                       "u_cube_geometric": geometric},
             images=images, uniforms={**march_uniforms, "u_cube_hiz_res": size})
        prog.run(math.ceil(6 * size / WORKGROUP), math.ceil(size / WORKGROUP), 1)
        reduce_prog = (shader_loader.compute(self.ctx, "cube_map/cube_hiz_reduce.comp.glsl",
                                             {"CUBE_FOOTPRINT_BUILD": 1})
                       if geometric is not None else self.reduce_prog)
        for level in range(1, self.levels):
            self.ctx.memory_barrier(moderngl.SHADER_IMAGE_ACCESS_BARRIER_BIT)
            cells = (6 * size >> level, size >> level)
            images = {"u_finer": Image(texture, read=True, write=False, level=level - 1),
                      "u_coarser": Image(texture, read=False, write=True, level=level)}
            if geometric is not None:
                images["u_footprint_finer"] = Image(self.footprint, read=True, write=False, level=level - 1)
                images["u_footprint_coarser"] = Image(self.footprint, read=False, write=True, level=level)
            bind(reduce_prog, images=images, uniforms={"u_size": cells})
            reduce_prog.run(math.ceil(cells[0] / WORKGROUP), math.ceil(cells[1] / WORKGROUP), 1)
        self.ctx.memory_barrier(moderngl.TEXTURE_FETCH_BARRIER_BIT | moderngl.SHADER_IMAGE_ACCESS_BARRIER_BIT)
        storage_barrier(self.ctx)

    def release(self) -> None:
        for name in ("texture", "footprint", "planes"):
            texture = getattr(self, name)
            if texture is not None:
                texture.release()
                setattr(self, name, None)
