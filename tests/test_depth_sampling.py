# SPDX-License-Identifier: GPL-3.0-or-later
"""Depth textures the shaders read as values (gpu/render_targets.py sampled_depth_texture).

Every depth texture the passes sample -- the primary G-buffer's and the cube map's depth
(cube_march.glsl, the lit cube map's texel positions), the shadow atlas's layers
(lighting.glsl) -- is read with ``texelFetch`` through a plain ``sampler2D``. A non-shadow
lookup of a depth texture whose comparison is on has undefined results (GLSL 4.60 §8.9,
Texture Functions), and moderngl turns comparison on for every depth texture it makes, so
each of them must have it turned off."""
from __future__ import annotations

import ctypes

from hybrid_engine.gpu import gl_context
from hybrid_engine.gpu.render_targets import GBufferTargets, sampled_depth_texture
from hybrid_engine.passes.cube_map.cube_map import CubeFaceTargets
from hybrid_engine.passes.shadow_maps.shadow_atlas import ShadowAtlas

TEXTURE_COMPARE_MODE, NONE = 0x884C, 0


def compare_mode(texture) -> int:
    """``texture``'s TEXTURE_COMPARE_MODE as the GL holds it (moderngl's getter tells only
    the function it last set)."""
    get = gl_context._native.egl.eglGetProcAddress
    get.restype, get.argtypes = ctypes.c_void_p, [ctypes.c_char_p]
    address = get(b"glGetTextureParameteriv")
    query = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.c_uint, ctypes.POINTER(ctypes.c_int))(address)
    value = ctypes.c_int(-1)
    query(texture.glo, TEXTURE_COMPARE_MODE, ctypes.byref(value))
    return value.value


def test_the_depth_textures_shaders_read_through_plain_samplers_compare_nothing(ctx):
    gbuffer, faces, atlas = GBufferTargets(ctx, 8, 4), CubeFaceTargets(ctx, 12, 4), ShadowAtlas(ctx)
    single = sampled_depth_texture(ctx, (1, 1))  # the tracer's stand-in where no cube map is bound
    try:
        atlas.ensure_bindable()
        depths = {"G-buffer": gbuffer.depth, "cube faces": faces.depth, "static shadows": atlas.static,
                  "dynamic shadows": atlas.dynamic, "stand-in": single}
        assert {name: compare_mode(tex) for name, tex in depths.items()} == dict.fromkeys(depths, NONE)
    finally:
        single.release()
        atlas.release()
        faces.release()
        gbuffer.release()
