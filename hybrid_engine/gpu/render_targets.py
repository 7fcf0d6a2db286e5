# SPDX-License-Identifier: GPL-3.0-or-later
"""Textures of one size that the raster passes render into together.

A pass allocates its targets once and again only when the image size changes; the
G-buffer of the primary camera (paper §3.1) is one, the cube map's face atlas (§3.2,
cube_map.CubeFaceTargets) another.
"""
from __future__ import annotations

import numpy as np

from . import gl_context


def sampled_depth_texture(ctx, size: tuple[int, int]):
    """A depth texture that shaders read as plain depth values (``texelFetch`` through a
    ``sampler2D``): depth comparison off.

    moderngl turns comparison on for every depth texture it makes (TEXTURE_COMPARE_MODE
    COMPARE_REF_TO_TEXTURE, function "<="), and a non-shadow lookup of a depth texture
    with comparison on has undefined results (GLSL 4.60 §8.9, Texture Functions): a driver
    may hand back the comparison's 0 or 1 instead of the depth. Every depth texture the
    passes sample is read through plain samplers (the G-buffers' and the cube map's depth,
    the shadow atlas), none through a shadow sampler."""
    tex = ctx.depth_texture(size)
    tex.compare_func = ""
    return tex


def release_all(objects) -> None:
    """Release GL objects (None skipped), never deleting the bound framebuffer."""
    gl_context.park_framebuffer()
    for obj in objects:
        if obj is not None:
            obj.release()


class RenderTargets:
    """A depth texture and colour targets in one framebuffer, plus textures the passes fill
    otherwise (``extra``), all sampled texel by texel (NEAREST). Subclasses name them.
    :meth:`clear` resets depth and the colour targets named in ``cleared`` (all when None)."""

    def __init__(self, ctx, width: int, height: int, colour: dict[str, tuple[int, str]],
                 extra: dict[str, tuple[int, str]] | None = None,
                 cleared: tuple[str, ...] | None = None) -> None:
        self.size = (int(width), int(height))
        self.depth = sampled_depth_texture(ctx, self.size)
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
        dtype = {"f2": np.float16, "i4": np.int32}.get(tex.dtype, np.float32)
        return np.frombuffer(tex.read(), dtype).reshape(h, w, -1).astype(np.float32)

    def release(self) -> None:
        extra_fbo = () if self._clear_fbo is self.fbo else (self._clear_fbo,)
        release_all((self.fbo, *extra_fbo, *self._textures.values()))


class GBufferTargets(RenderTargets):
    """The primary camera's G-buffer (depth, normal + material, albedo, emission scale,
    surface: the roughness and metallic its images give, row: the world row each pixel
    shows; gbuffer.frag.glsl), its ambient
    estimate (the World's light: alpha the sky's visibility from screen_ao.py, or rgb the
    light the tracer's sky rays gathered as well) and its shaded colour, W x H texels.
    ``emission_scale`` holds the colour of the material's emission texture (1 without
    one); the shading multiplies the material's emission by it."""

    def __init__(self, ctx, width: int, height: int, surface_channels: int = 2) -> None:
        # Four surface channels where node programs run (roughness, metallic, transmission,
        # coat: include/node_program.glsl node_gbuffer_material).
        self.surface_channels = surface_channels
        # ``row``: each pixel's world row (an integer target), by which passes/surface_motion/
        # and the Vector pass find the pixel's instance and Cryptomatte its ids. Never cleared:
        # where the G-buffer shows no surface it is not read (a float clear of an integer
        # target is undefined).
        colour = {"normal_material": (4, "f4"), "albedo": (4, "f2"), "emission_scale": (4, "f2"),
                  "surface": (surface_channels, "f2"), "row": (1, "i4")}
        super().__init__(ctx, width, height, colour=colour, extra={"color": (4, "f4"), "ambient": (4, "f4")},
                         cleared=tuple(name for name in colour if name != "row"))

    def read_color(self) -> np.ndarray:
        """The shaded colour as (H, W, 4) float32, row 0 at the bottom."""
        return self.read("color")

    def read_albedo(self) -> np.ndarray:
        """The albedo target as (H, W, 4) float32, row 0 at the bottom (tests, diagnostics)."""
        return self.read("albedo")

    def read_emission_scale(self) -> np.ndarray:
        """The emission-scale target as (H, W, 4) float32, row 0 at the bottom."""
        return self.read("emission_scale")
