# SPDX-License-Identifier: GPL-3.0-or-later
"""The tracer's per-triangle UV rows computed with numpy: the oracle for the rows the
instance transform writes on the GPU (gpu_shaders/scene_upload/instance_transform.comp.glsl).

Each row holds the corners' UVs and the triangle's ``uv_per_world`` = sqrt(UV area / world
area), the tracer's texture level (passes/scene_upload/textures.py). Non-finite UVs become 0
(as in the vertex buffer); a degenerate triangle gets 0 (mip level 0)."""
from __future__ import annotations

import numpy as np

# struct TriangleUV (hybrid_trace.comp.glsl)                          // total: 32 bytes
TRIANGLE_UV_DTYPE = np.dtype([("uv01", np.float32, 4), ("uv2_scale", np.float32, 4)])
assert TRIANGLE_UV_DTYPE.itemsize == 32


def triangle_uv_rows(triangles: np.ndarray, uvs: np.ndarray | None) -> np.ndarray:
    """One TRIANGLE_UV_DTYPE row per world-space triangle of ``triangles`` ((N, 3, 3))."""
    n = len(triangles)
    out = np.zeros(n, TRIANGLE_UV_DTYPE)
    if n == 0 or uvs is None:
        return out
    uvs = np.where(np.isfinite(uvs), uvs, 0.0).astype(np.float32)
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        e1, e2 = triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]
        world = np.linalg.norm(np.cross(e1, e2), axis=1)
        f1, f2 = uvs[:, 1] - uvs[:, 0], uvs[:, 2] - uvs[:, 0]
        uv_area = np.abs(f1[:, 0] * f2[:, 1] - f1[:, 1] * f2[:, 0])
        scale = np.where(world > 0, np.sqrt(uv_area / world), 0.0)
    flat = out.view(np.float32).reshape(-1, 8)
    flat[:, :6] = uvs.reshape(n, 6)
    flat[:, 6] = np.where(np.isfinite(scale), scale, 0.0)
    return out
