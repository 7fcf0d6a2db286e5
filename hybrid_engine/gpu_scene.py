# SPDX-License-Identifier: GPL-3.0-or-later
"""Scene data on the GPU: vertex buffer, material and light buffers, image textures.

Buffers are persistent and grow-only: a frame whose data fits reuses last frame's buffer
objects and only writes into them, which matters in the viewport where every redraw
re-uploads deformed geometry (paper §3.3: the BVH is rebuilt every frame so that any
deformation works, so the triangles must be re-sent every frame too).

Non-finite input never reaches the rasterizer: a triangle with a NaN/inf corner is collapsed
to a point (zero area, no fragments), and non-finite normals are zeroed so that the
G-buffer pass substitutes the geometric normal.
"""
from __future__ import annotations

import numpy as np

from .gpu_dispatch import GrowBuffer
from .scene_delta import GeometryDelta
from .scene_data import LIGHT_AREA, LIGHT_POINT, LIGHT_SPOT, MATERIAL_DTYPE, Lights, SceneData
from .textures import GPUTextures

VERTEX_LAYOUT = (("3f", "in_pos", 12), ("3f", "in_normal", 12), ("2f", "in_uv", 8), ("1i", "in_material", 4))
VERTEX_DTYPE = np.dtype(
    [("pos", np.float32, 3), ("normal", np.float32, 3), ("uv", np.float32, 2), ("material", np.int32)]
)
assert VERTEX_DTYPE.itemsize == 36

# struct Light (gpu_shaders/include/scene_layout.glsl)              // total: 64 bytes
LIGHT_DTYPE = np.dtype(
    [("position", np.float32, 4), ("direction", np.float32, 4), ("color", np.float32, 4), ("info", np.int32, 4)]
)
assert LIGHT_DTYPE.itemsize == 64


def vertex_binding(program, buffer) -> tuple:
    """The moderngl vertex-array binding for ``program``: attributes the program does not use
    (the GLSL compiler drops them) are skipped as padding."""
    fmt, names = [], []
    for code, name, size in VERTEX_LAYOUT:
        if name in program:
            fmt.append(code)
            names.append(name)
        else:
            fmt.append(f"{size}x")
    return (buffer, " ".join(fmt), *names)


def pack_vertices(scene: SceneData, out: np.ndarray | None = None) -> np.ndarray:
    """Interleave the triangle soup into VERTEX_DTYPE rows, three per triangle.

    Writes straight into the interleaved array; the NaN/inf sanitising copies are made only
    when the input actually holds non-finite values (rare), since at a million triangles
    every extra pass over the arrays costs tens of milliseconds per frame. ``out`` is a
    reusable staging array (grown by the caller): a fresh 100 MB array costs as much in
    first-touch page faults as the packing itself.
    """
    geo = scene.geometry
    n = geo.triangle_count
    verts = np.empty(n * 3, VERTEX_DTYPE) if out is None or len(out) < n * 3 else out[: n * 3]
    if n == 0:
        return verts
    tris = geo.triangles
    if np.isfinite(tris).all():
        verts["pos"] = tris.reshape(-1, 3)
    else:
        finite = np.isfinite(tris).all(axis=(1, 2))
        verts["pos"] = np.where(finite[:, None, None], tris, 0.0).reshape(-1, 3)
    normals = geo.normals
    verts["normal"] = (normals if np.isfinite(normals).all() else np.where(np.isfinite(normals), normals, 0.0)).reshape(-1, 3)
    if geo.uvs is not None:
        uvs = geo.uvs
        verts["uv"] = (uvs if np.isfinite(uvs).all() else np.where(np.isfinite(uvs), uvs, 0.0)).reshape(-1, 2)
    else:
        verts["uv"] = 0.0
    verts["material"].reshape(n, 3)[:] = geo.material_ids[:, None]
    return verts


def pack_lights(lights: Lights, shadow_slots: list[tuple[int, int]] | None = None) -> np.ndarray:
    """std430 rows of ``struct Light``; ``shadow_slots[i] = (first, count)`` or (-1, 0)."""
    out = np.zeros(max(len(lights), 1), LIGHT_DTYPE)  # never a zero-sized buffer
    count = len(lights)
    if count == 0:
        return out
    direction = lights.direction.astype(np.float64)
    length = np.linalg.norm(direction, axis=1, keepdims=True)
    direction = np.where(length > 0, direction / np.where(length > 0, length, 1), [0.0, 0.0, -1.0])
    half = np.clip(lights.spot_size.astype(np.float64) * 0.5, 0.0, np.pi / 2)
    out["position"][:count, :3] = lights.position
    out["position"][:count, 3] = lights.radius
    out["direction"][:count, :3] = direction
    out["direction"][:count, 3] = np.where(lights.kind == LIGHT_SPOT, np.cos(half), -1.0)
    out["color"][:count, :3] = np.nan_to_num(lights.color, nan=0.0, posinf=0.0, neginf=0.0)
    out["color"][:count, 3] = np.clip(lights.spot_blend, 0.0, 1.0)
    out["info"][:count, 0] = lights.kind
    slots = shadow_slots or [(-1, 0)] * count
    out["info"][:count, 1] = [s[0] for s in slots]
    out["info"][:count, 2] = [s[1] for s in slots]
    return out


def needs_cube_shadow(kind: int) -> bool:
    """Point and area lights shine in all directions of a hemisphere or more: six slots."""
    return kind in (LIGHT_POINT, LIGHT_AREA)


def bytes_of(array: np.ndarray) -> np.ndarray:
    """A flat uint8 view of a contiguous array (no copy)."""
    return np.ascontiguousarray(array).reshape(-1).view(np.uint8)


class GPUScene:
    """The scene's buffers on the shared context, reused from frame to frame."""

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.vertices = GrowBuffer(ctx, "scene vertices", VERTEX_DTYPE.itemsize * 3)
        self.materials = GrowBuffer(ctx, "scene materials", MATERIAL_DTYPE.itemsize)
        self.lights = GrowBuffer(ctx, "scene lights", 64)
        for buf in (self.vertices, self.materials, self.lights):
            buf.ensure(0)  # passes bind these before the first upload
        self.generation = 0  # bumps when the vertex buffer object changes
        self._staging: np.ndarray | None = None  # host-side packing array, reused per frame
        self.vertex_count = 0
        self._synced = -1  # sequence of the last GeometryDelta applied (scene_delta.py)
        self.textures = GPUTextures(ctx)  # re-uploaded only when the scene's images change

    def upload(self, scene: SceneData, delta: GeometryDelta | None = None) -> None:
        """Vertices, materials and textures. With a ``delta`` that follows this scene's last
        upload only the changed triangle ranges are re-packed and written (scene_delta.py)."""
        geo = scene.geometry
        needed = geo.triangle_count * 3
        incremental = (delta is not None and not delta.full and delta.sequence == self._synced + 1
                       and needed == self.vertex_count)
        self._synced = delta.sequence if delta is not None else -1
        if self._staging is None or len(self._staging) < max(needed, 3):
            self._staging = np.empty(max(needed, 3), VERTEX_DTYPE)
        if incremental:
            for first, count in delta.ranges:
                part = SceneData(geo.rows(first, count), scene.materials)
                verts = pack_vertices(part, self._staging)
                self.vertices.write_at(bytes_of(verts), first * 3 * VERTEX_DTYPE.itemsize)
        else:
            verts = pack_vertices(scene, self._staging)
            allocations = self.vertices.allocations
            self.vertices.upload(bytes_of(verts))  # a byte view: tobytes() would copy ~100 MB
            if self.vertices.allocations != allocations:
                self.generation += 1  # a new buffer object: dependent VAOs must be rebuilt
            self.vertex_count = len(verts)
        self.materials.upload(bytes_of(scene.materials.packed()))
        self.textures.upload(scene.materials.textures)

    def upload_lights(self, lights: Lights, shadow_slots: list[tuple[int, int]]) -> None:
        self.lights.upload(bytes_of(pack_lights(lights, shadow_slots)))

    def release(self) -> None:
        for buf in (self.vertices, self.materials, self.lights):
            buf.release()
        self.textures.release()
