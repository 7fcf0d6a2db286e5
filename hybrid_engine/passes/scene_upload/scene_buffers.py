# SPDX-License-Identifier: GPL-3.0-or-later
"""Scene data on the GPU: vertex attributes, the material buffer, image textures.

Buffers are persistent and grow-only: a frame whose data fits reuses last frame's buffer
objects and only writes into them (paper §3.3: the BVH is rebuilt every frame so that any
deformation works, from world-space triangles made or written every frame).

An ``InstancedGeometry`` (the Blender adapter's) keeps its meshes on the GPU in object space
and has the world-space buffers below made there by instance_transform.py. Any other
``Geometry`` is uploaded as it arrives, one array per attribute, with no packing:
``Geometry.triangles`` (N, 3, 3) float32 is both the rasterizer's position attribute and
the tracer's LBVH input, ``Geometry.normals`` both the shading-normal attribute and the
normals the tracer interpolates at BVH hits, and the per-triangle material ids are read by
the G-buffer vertex stage (``gl_VertexID / 3``) and the tracer alike. Interleaving them into
vertex rows and packing separate tracer rows would cost three passes over every moved
triangle per frame; a raw range write costs one memcpy.

Non-finite input never reaches the rasterizer: a triangle with a NaN/inf corner is collapsed
to the origin (zero area: no fragments, and no ray hits it), and non-finite normals and UVs
are zeroed so that the G-buffer pass substitutes the geometric normal. The sanitising copies
are made only for ranges that hold such values.
"""
from __future__ import annotations

import time

import numpy as np

from ...gpu.bindings import Bindings
from ...gpu.dispatch import GrowBuffer
from ...scene.changes import GeometryDelta
from ...scene.data import Geometry, LIGHT_AREA, LIGHT_POINT, LIGHT_SPOT, Lights, MATERIAL_DTYPE, SceneData
from ...scene.instances import InstancedGeometry
from .instance_transform import InstanceTransformPass, OUTPUT_ROW_BYTES
from .textures import GPUTextures

# Per-vertex attributes: (GLSL input, moderngl format, GPUScene buffer attribute).
VERTEX_ATTRIBUTES = (("in_pos", "3f", "positions"), ("in_normal", "3f", "normals"), ("in_uv", "2f", "uvs"))

# struct Light (gpu_shaders/include/scene_layout.glsl)              // total: 64 bytes
LIGHT_DTYPE = np.dtype(
    [("position", np.float32, 4), ("direction", np.float32, 4), ("color", np.float32, 4), ("info", np.int32, 4)]
)
assert LIGHT_DTYPE.itemsize == 64


def finite_positions(triangles: np.ndarray) -> np.ndarray:
    """``triangles`` ((N, 3, 3) float32), with every triangle that has a non-finite corner
    collapsed to the origin; the input itself (no copy) when all corners are finite."""
    if np.isfinite(triangles).all():
        return triangles
    finite = np.isfinite(triangles).all(axis=(1, 2))
    return np.where(finite[:, None, None], triangles, np.float32(0.0)).astype(np.float32)


def finite_or_zero(values: np.ndarray) -> np.ndarray:
    """``values`` with non-finite entries zeroed; the input itself when all are finite."""
    if np.isfinite(values).all():
        return values
    return np.where(np.isfinite(values), values, np.float32(0.0)).astype(values.dtype)


def attribute_arrays(geometry: Geometry, zero_uvs: bool = True) -> dict[str, np.ndarray]:
    """The arrays GPUScene uploads for ``geometry`` (sanitised, C-contiguous), by buffer.
    Geometry without UVs gets zero UVs, or (``zero_uvs`` False: the buffer already holds
    them) none."""
    arrays = {
        "positions": np.ascontiguousarray(finite_positions(geometry.triangles), np.float32),
        "normals": np.ascontiguousarray(finite_or_zero(geometry.normals), np.float32),
        "triangle_materials": np.ascontiguousarray(geometry.material_ids, np.int32),
    }
    if geometry.uvs is not None:
        arrays["uvs"] = np.ascontiguousarray(finite_or_zero(geometry.uvs), np.float32)
    elif zero_uvs:
        arrays["uvs"] = np.zeros((geometry.triangle_count, 3, 2), np.float32)
    return arrays


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
        self.positions = GrowBuffer(ctx, "scene positions", 36)
        self.normals = GrowBuffer(ctx, "scene normals", 36)
        self.uvs = GrowBuffer(ctx, "scene uvs", 24)
        self.triangle_materials = GrowBuffer(ctx, "scene triangle materials", 4)
        self.materials = GrowBuffer(ctx, "scene materials", MATERIAL_DTYPE.itemsize)
        self._geometry_buffers = (self.positions, self.normals, self.uvs, self.triangle_materials)
        for buf in (*self._geometry_buffers, self.materials):
            buf.ensure(0)  # passes bind these before the first upload
        # The tracer's per-triangle UV rows when the GPU makes them (instanced geometry);
        # otherwise the tracer packs its own (tracer.pack_triangle_uvs).
        self.uv_rows = GrowBuffer(ctx, "scene triangle uv rows", 32)
        self.uv_rows_resident = False
        self.instance_transform = InstanceTransformPass(ctx)
        self.generation = 0  # bumps when a vertex attribute's buffer object changes
        # Host time of the last upload, the time inside its dispatch calls left out: a GPU
        # queues them and returns, a software driver runs the transform there, on the CPU.
        self.host_ms = 0.0
        self.triangle_count = 0
        self._synced = -1  # sequence of the last GeometryDelta applied (scene/changes.py)
        self.textures = GPUTextures(ctx)  # re-uploaded only when the scene's images change

    def vertex_content(self, program) -> list[tuple]:
        """moderngl vertex-array content of ``program``: one binding per attribute it reads
        (the GLSL compiler drops unused inputs)."""
        return [(getattr(self, buffer).buffer, fmt, name)
                for name, fmt, buffer in VERTEX_ATTRIBUTES if name in program]

    def bindings(self) -> Bindings:
        """The materials, the per-triangle material ids and the textures, by the names every
        pass that reads a material declares (scene_layout.glsl, textures.glsl)."""
        return Bindings(storage={"MaterialBuffer": self.materials.buffer,
                                 "TriangleMaterials": self.triangle_materials.buffer},
                        textures={"u_textures": self.textures.array})

    def upload(self, scene: SceneData, delta: GeometryDelta | None = None) -> None:
        """Geometry, materials and textures. With a ``delta`` that follows this scene's last
        upload only the changed triangle ranges are written (scene/changes.py)."""
        start = time.perf_counter()
        self.instance_transform.stats.dispatch_ms = 0.0
        try:
            self._upload(scene, delta)
        finally:
            spent = (time.perf_counter() - start) * 1e3
            self.host_ms = spent - (self.instance_transform.stats.dispatch_ms if self.uv_rows_resident else 0.0)

    def _upload(self, scene: SceneData, delta: GeometryDelta | None) -> None:
        geo = scene.geometry
        n = geo.triangle_count
        if isinstance(geo, InstancedGeometry) and self.instance_transform.fits(geo):
            self._upload_instanced(geo, delta)
            self.materials.upload(bytes_of(scene.materials.packed()))
            self.textures.upload(scene.materials.textures)
            return
        if self.uv_rows_resident:
            self.instance_transform.forget()  # the world buffers now hold host-made rows
            self.uv_rows_resident = False
        incremental = (delta is not None and not delta.full and delta.sequence == self._synced + 1
                       and n == self.triangle_count)
        self._synced = delta.sequence if delta is not None else -1
        if incremental:
            for first, count in delta.ranges:
                # (A delta never switches UVs on or off: that is a layout change.)
                for name, array in attribute_arrays(geo.rows(first, count), zero_uvs=False).items():
                    getattr(self, name).write_at(bytes_of(array), first * array.strides[0])
        else:
            allocations = [buf.allocations for buf in self._geometry_buffers]
            for name, array in attribute_arrays(geo).items():
                getattr(self, name).upload(bytes_of(array))  # byte views: tobytes() would copy
            if [buf.allocations for buf in self._geometry_buffers] != allocations:
                self.generation += 1  # a new buffer object: dependent VAOs must be rebuilt
            self.triangle_count = n
        self.materials.upload(bytes_of(scene.materials.packed()))
        self.textures.upload(scene.materials.textures)

    def _upload_instanced(self, geo: InstancedGeometry, delta: GeometryDelta | None) -> None:
        """The world rows made on the GPU from the object-space meshes and the instance table
        (instance_transform.py): only instances that changed are transformed."""
        n = geo.triangle_count
        buffers = {"positions": self.positions, "normals": self.normals, "uvs": self.uvs,
                   "triangle_materials": self.triangle_materials, "uv_rows": self.uv_rows}
        allocations = [buf.allocations for buf in buffers.values()]
        for name, buf in buffers.items():
            buf.ensure(n * OUTPUT_ROW_BYTES[name])
        grown = [buf.allocations for buf in buffers.values()] != allocations
        if grown or not self.uv_rows_resident or n != self.triangle_count:
            self.instance_transform.forget()
        if grown:
            self.generation += 1  # a new buffer object: dependent VAOs must be rebuilt
        self.instance_transform.update(geo, buffers)
        self.uv_rows_resident = True
        self.triangle_count = n
        self._synced = -1  # a later host-made upload starts over

    def release(self) -> None:
        for buf in (*self._geometry_buffers, self.materials, self.uv_rows):
            buf.release()
        self.instance_transform.release()
        self.textures.release()
