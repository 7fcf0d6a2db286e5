# SPDX-License-Identifier: GPL-3.0-or-later
"""The lamps as the GPU reads them: one ``struct Light`` row each (scene_layout.glsl), with
the shadow-map slots the shadow pass gave it (paper §3.5: deferred lighting from every lamp)."""
from __future__ import annotations

from dataclasses import fields

import numpy as np

from ...scene.data import LIGHT_AREA, LIGHT_SPOT, Lights, area_basis

# struct Light (gpu_shaders/include/scene_layout.glsl)              // total: 64 bytes
LIGHT_DTYPE = np.dtype(
    [("position", np.float32, 4), ("direction", np.float32, 4), ("color", np.float32, 4), ("info", np.int32, 4)]
)
assert LIGHT_DTYPE.itemsize == 64


def pack_lights(lights: Lights, shadow_slots: list[tuple[int, int]] | None = None) -> np.ndarray:
    """Rows of ``struct Light`` (std430 and std140 alike); ``shadow_slots[i] = (first, count)`` or (-1, 0)."""
    out = np.zeros(max(len(lights), 1), LIGHT_DTYPE)  # never a zero-sized buffer
    count = len(lights)
    if count == 0:
        return out
    direction = lights.direction.astype(np.float64)
    length = np.linalg.norm(direction, axis=1, keepdims=True)
    direction = np.where(length > 0, direction / np.where(length > 0, length, 1), [0.0, 0.0, -1.0])
    half = np.clip(lights.spot_size.astype(np.float64) * 0.5, 0.0, np.pi / 2)
    area = lights.kind == LIGHT_AREA
    # An area lamp's shape (scene_layout.glsl): its y half-size where spots keep their cone,
    # its x axis as an angle in area_basis where spots keep their blend, elliptic in info.w.
    t1, t2 = area_basis(direction)
    axis = lights.area_axis.astype(np.float64)
    angle = np.arctan2((axis * t2).sum(axis=1), (axis * t1).sum(axis=1))
    out["position"][:count, :3] = lights.position
    out["position"][:count, 3] = lights.radius
    out["direction"][:count, :3] = direction
    out["direction"][:count, 3] = np.where(lights.kind == LIGHT_SPOT, np.cos(half),
                                           np.where(area, lights.area_size_y, -1.0))
    out["color"][:count, :3] = np.nan_to_num(lights.color, nan=0.0, posinf=0.0, neginf=0.0)
    out["color"][:count, 3] = np.where(area, angle, np.clip(lights.spot_blend, 0.0, 1.0))
    out["info"][:count, 3] = area & lights.area_elliptic
    out["info"][:count, 0] = lights.kind
    slots = shadow_slots or [(-1, 0)] * count
    out["info"][:count, 1] = [s[0] for s in slots]
    out["info"][:count, 2] = [s[1] for s in slots]
    return out


def lamps_key(lights: Lights) -> bytes:
    """The lamps as bytes, compared from frame to frame (a few dozen numbers per lamp)."""
    return b"".join(np.ascontiguousarray(getattr(lights, f.name)).tobytes() for f in fields(lights)
                    if isinstance(getattr(lights, f.name), np.ndarray))
