# SPDX-License-Identifier: GPL-3.0-or-later
"""A probe kernel that marches given rays through a rendered cube map, one result per ray:
the test-side entry point to the march the tracer runs inside its megakernel
(tests/shaders/cube_march_probe.comp.glsl includes gpu_shaders/include/cube_march.glsl)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from hybrid_engine.gpu import shader_loader
from hybrid_engine.gpu.bindings import bind
from hybrid_engine.gpu.dispatch import dispatch, storage_barrier
from hybrid_engine.passes.cube_map.cube_map import CubeMapPass
from hybrid_engine.scene.settings import RenderSettings

PROBE_SHADER = Path(__file__).resolve().parent / "shaders" / "cube_march_probe.comp.glsl"
MARCH_SKY, MARCH_HIT, MARCH_TO_BVH = 0, 1, 2  # CUBE_* in cube_march.glsl

# Mirror of the probe's per-ray output (cube_march_probe.comp.glsl)   // total: 64 bytes
MARCH_RESULT_DTYPE = np.dtype(
    [("kind", np.int32), ("face", np.int32), ("texel", np.int32, 2), ("switches", np.int32),
     ("material", np.int32), ("steps", np.int32), ("pad", np.int32), ("position", np.float32, 3),
     ("t", np.float32),
     ("normal", np.float32, 3), ("pad2", np.float32)]
)
assert MARCH_RESULT_DTYPE.itemsize == 64

PROBE_LOCAL_SIZE = 64


def probe_cube_march(ctx, cube_map: CubeMapPass, materials_buffer, settings: RenderSettings,
                     origins: np.ndarray, directions: np.ndarray, t_start: np.ndarray) -> np.ndarray:
    """March rays through the cube map last rendered by ``cube_map`` and return one
    MARCH_RESULT_DTYPE row per ray (the tracer marches inside its megakernel with the same
    code, gpu_shaders/include/cube_march.glsl)."""
    marchable = cube_map.marchable(settings)
    origins = np.asarray(origins, np.float32).reshape(-1, 3)
    directions = np.asarray(directions, np.float32).reshape(-1, 3)
    count = len(origins)
    rays = np.zeros((count, 2, 4), np.float32)
    rays[:, 0, :3] = origins
    rays[:, 0, 3] = np.broadcast_to(np.asarray(t_start, np.float32), (count,))
    rays[:, 1, :3] = directions
    prog = shader_loader.compute(ctx, PROBE_SHADER,
                                 {"LOCAL_SIZE": PROBE_LOCAL_SIZE, **marchable.defines})
    ray_buf = ctx.buffer(rays.tobytes() or bytes(32))
    out_buf = ctx.buffer(reserve=max(count, 1) * MARCH_RESULT_DTYPE.itemsize)
    try:
        bind(prog, storage={"MaterialBuffer": materials_buffer, "Rays": ray_buf, "Results": out_buf},
             textures=marchable.textures,
             uniforms={"u_count": count, **marchable.uniforms})
        dispatch(prog, count, PROBE_LOCAL_SIZE)
        storage_barrier(ctx)
        raw = out_buf.read(size=count * MARCH_RESULT_DTYPE.itemsize) if count else b""
    finally:
        ray_buf.release()
        out_buf.release()
    return np.frombuffer(raw, MARCH_RESULT_DTYPE).copy()
