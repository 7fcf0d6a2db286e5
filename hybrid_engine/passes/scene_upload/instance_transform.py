# SPDX-License-Identifier: GPL-3.0-or-later
"""Instances to world space on the GPU (paper §3.3), with the meshes kept there.

Each mesh of an ``InstancedGeometry`` is uploaded once in object space (vertices, normals,
corner indices, slots, UVs) and shared by all its instances; a deformed mesh re-sends its
positions and normals only, into the same place. Per frame the instance table (matrix,
normal matrix, where its mesh lies, its slots' materials) is rebuilt on the host, compared
with the last one row by row, and only the instances whose row or mesh changed are
transformed by ``scene_upload/instance_transform.comp.glsl`` into the world-space buffers every
other pass reads (scene_upload/scene_buffers.py). Rigid motion therefore costs one table row and the
transform of that object's triangles on the GPU; an unchanged scene costs nothing.

The world-space outputs can exceed one storage block (128 MiB on llvmpipe, 3.7 M triangles
of positions): the work is cut into chunks of rows that fit, each bound from its first row,
so the shader never needs the split-array code. The object-space store is bound whole and a
store past the block limit fails with bindings' message naming it.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ...gpu import shader_loader
from ...gpu.bindings import Storage, bind
from ...gpu.dispatch import BLOCK_ITEM_GRANULE, GrowBuffer, dispatch, max_block_bytes
from ...scene.instances import InstancedGeometry, ObjectMesh, normal_matrices

LOCAL_SIZE = 64

# struct Instance of instance_transform.comp.glsl (std430).
INSTANCE_DTYPE = np.dtype([("matrix", np.float32, 16), ("normal_cols", np.float32, 12),
                           ("mesh", np.int32, 4), ("info", np.int32, 4), ("flags", np.int32, 4)])
assert INSTANCE_DTYPE.itemsize == 160

# Bytes per world-space row (one triangle) of each output, by GPUScene buffer name.
OUTPUT_ROW_BYTES = {"positions": 36, "normals": 36, "uvs": 24, "triangle_materials": 4, "uv_rows": 32}
_OUTPUT_BLOCKS = {"positions": "WorldPositions", "normals": "WorldNormals", "uvs": "WorldUVs",
                  "triangle_materials": "WorldMaterials", "uv_rows": "WorldUVRows"}


@dataclass(frozen=True)
class _Placement:
    """Where one mesh lies in the object-space store."""

    vertex: int
    normal: int
    triangle: int
    uv: int  # first UV corner, -1: the mesh has none
    version: int


@dataclass
class TransformStats:
    """What the last update did (tests, timing)."""

    meshes_uploaded: int = 0  # meshes whose data was written (whole or deformed)
    store_rebuilt: bool = False
    instances_written: int = 0  # table rows that changed
    triangles_transformed: int = 0
    dispatches: int = 0
    # Milliseconds inside the dispatch calls: a GPU queues them and returns, a software
    # driver (llvmpipe) runs the transform there, on the CPU.
    dispatch_ms: float = 0.0


def _concat(arrays: list[np.ndarray], dtype, width: int) -> np.ndarray:
    if not arrays:
        return np.zeros((1, width) if width else 1, dtype)
    return np.ascontiguousarray(np.concatenate(arrays).astype(dtype, copy=False))


def _rows_differ(old: np.ndarray, new: np.ndarray) -> np.ndarray:
    """Bool per instance-table row: does it differ bit for bit."""
    size = INSTANCE_DTYPE.itemsize
    return (old.view(np.uint8).reshape(len(old), size) != new.view(np.uint8).reshape(len(new), size)).any(axis=1)


def rows_per_chunk() -> int:
    """World rows one dispatch writes: the most whose widest output fits a storage block, a
    multiple of BLOCK_ITEM_GRANULE so every chunk starts at an aligned offset."""
    widest = max(OUTPUT_ROW_BYTES.values())
    return max(BLOCK_ITEM_GRANULE, max_block_bytes() // widest // BLOCK_ITEM_GRANULE * BLOCK_ITEM_GRANULE)


class InstanceTransformPass:
    """The object-space store, the instance table and the transform dispatch."""

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.program = shader_loader.compute(ctx, "scene_upload/instance_transform.comp.glsl", {"LOCAL_SIZE": LOCAL_SIZE})
        names = ("positions", "normals", "corner_vertices", "corner_normals", "slots", "uvs",
                 "slot_materials", "instances", "segments", "segment_starts")
        self._store = {name: GrowBuffer(ctx, f"instance {name.replace('_', ' ')}") for name in names}
        self._placements: dict[int, _Placement] = {}
        self._mesh_order: list[tuple] = []
        self._rows: np.ndarray | None = None
        self._slot_materials: np.ndarray | None = None
        self._seen: tuple | None = None  # (geometry id, edit) of the last update
        self.stats = TransformStats()

    @staticmethod
    def fits(geometry: InstancedGeometry) -> bool:
        """Whether each array of the object-space store fits one storage block. One that
        does not (over ten million unique triangles on a 128 MiB limit) is uploaded as
        world-space rows made on the host, as a ``Geometry`` is: a documented fallback
        that costs a transform of the whole scene per frame, never a failed frame."""
        seen, vertices, normals, triangles, uv_corners = set(), 0, 0, 0, 0
        for mesh in geometry.instances.meshes:
            if mesh.mesh_id in seen:
                continue
            seen.add(mesh.mesh_id)
            vertices += len(mesh.positions)
            normals += len(mesh.normals)
            triangles += mesh.triangle_count
            uv_corners += 3 * mesh.triangle_count if mesh.uvs is not None else 0
        largest = max(12 * vertices, 12 * normals, 12 * triangles, 8 * uv_corners, 160 * len(geometry.instances))
        return largest <= max_block_bytes()

    def forget(self) -> None:
        """The outputs were written by someone else: the next update transforms everything."""
        self._rows = None
        self._seen = None

    def update(self, geometry: InstancedGeometry, outputs: dict[str, object]) -> TransformStats:
        """Bring the store and the table up to ``geometry`` and write the world rows of every
        instance that changed into ``outputs`` (GPUScene's buffers by name, at least
        ``triangle_count`` rows each).

        A producer's version seen already (``Geometry.edit``) costs nothing; its next version
        costs the rows it lists (packed, compared, written); anything else packs and compares
        every row (a geometry without edits may have been changed in place)."""
        stats = self.stats = TransformStats()
        edit = geometry.edit
        seen = (id(geometry), edit.source, edit.generation) if edit is not None else None
        if seen is not None and seen == self._seen and self._rows is not None:
            return stats
        instances = geometry.instances
        deformed = self._update_store(instances.meshes, stats)
        slot_table = instances.slot_table()
        same_table = self._slot_materials is not None and np.array_equal(self._slot_materials, slot_table[0])
        follows = (seen is not None and self._seen is not None and edit.objects is not None
                   and self._seen == (seen[0], seen[1], seen[2] - 1))
        # Instances whose mesh was deformed: their rows may be equal, their triangles are not.
        of_deformed = (np.isin(instances.mesh, np.fromiter(deformed, np.int64)) if deformed
                       else np.zeros(len(instances), bool))
        if (follows and same_table and self._rows is not None and len(self._rows) == max(len(instances), 1)
                and not stats.store_rebuilt):
            which = np.union1d(np.asarray(edit.objects, np.int64), np.flatnonzero(of_deformed))
            rows = self._pack(geometry, which, slot_table)
            differs = _rows_differ(self._rows[which], rows) | of_deformed[which]
            changed = which[differs]
            self._rows[changed] = rows[differs]
            self._write_rows(changed)
        else:
            rows = self._pack(geometry, None, slot_table)
            if (self._rows is not None and len(self._rows) == len(rows) and not stats.store_rebuilt
                    and same_table):
                changed = np.flatnonzero(_rows_differ(self._rows, rows)[:len(instances)] | of_deformed)
            else:
                changed = np.arange(len(instances))
            self._rows = rows
            if len(changed):
                self._store["instances"].upload(rows.tobytes())
        if not same_table:
            self._store["slot_materials"].upload(slot_table[0].tobytes())
            self._slot_materials = slot_table[0].copy()
        if len(changed):
            self._transform(geometry, changed, outputs, stats)
        stats.instances_written = int(len(changed))
        self._seen = seen
        return stats

    def _write_rows(self, changed: np.ndarray) -> None:
        """Write the table rows ``changed`` (sorted) to the GPU: row by row when few, whole
        when many (one write beats thousands)."""
        if len(changed) > 256:
            self._store["instances"].upload(self._rows.tobytes())
            return
        size = INSTANCE_DTYPE.itemsize
        for row in changed:
            self._store["instances"].write_at(self._rows[row:row + 1].tobytes(), int(row) * size)

    # -- the object-space store --------------------------------------------------------------
    def _update_store(self, meshes: list[ObjectMesh], stats: TransformStats) -> set[int]:
        """Upload what changed among ``meshes``; returns the indices of deformed meshes (their
        instances must be transformed again). A different list of topologies rebuilds it."""
        order = [(m.mesh_id, len(m.positions), len(m.normals), m.triangle_count, m.uvs is not None) for m in meshes]
        if order != self._mesh_order:
            self._rebuild_store(meshes)
            self._mesh_order = order
            stats.store_rebuilt = True
            stats.meshes_uploaded = len(meshes)
            return set()
        deformed = set()
        for index, mesh in enumerate(meshes):
            place = self._placements[mesh.mesh_id]
            if place.version == mesh.version:
                continue
            self._store["positions"].write_at(np.ascontiguousarray(mesh.positions, np.float32).tobytes(),
                                              place.vertex * 12)
            self._store["normals"].write_at(np.ascontiguousarray(mesh.normals, np.float32).tobytes(),
                                            place.normal * 12)
            self._placements[mesh.mesh_id] = _Placement(place.vertex, place.normal, place.triangle, place.uv,
                                                        mesh.version)
            deformed.add(index)
        stats.meshes_uploaded = len(deformed)
        return deformed

    def _rebuild_store(self, meshes: list[ObjectMesh]) -> None:
        self._placements = {}
        vertex = normal = triangle = uv = 0
        unique: list[ObjectMesh] = []
        for mesh in meshes:
            if mesh.mesh_id in self._placements:
                continue
            has_uv = mesh.uvs is not None
            self._placements[mesh.mesh_id] = _Placement(vertex, normal, triangle, uv if has_uv else -1, mesh.version)
            vertex += len(mesh.positions)
            normal += len(mesh.normals)
            triangle += mesh.triangle_count
            uv += 3 * mesh.triangle_count if has_uv else 0
            unique.append(mesh)
        store = self._store
        store["positions"].upload(_concat([m.positions for m in unique], np.float32, 3).tobytes())
        store["normals"].upload(_concat([m.normals for m in unique], np.float32, 3).tobytes())
        store["corner_vertices"].upload(_concat([m.corner_vertices for m in unique], np.int32, 0).tobytes())
        store["corner_normals"].upload(_concat([m.corner_normals for m in unique], np.int32, 0).tobytes())
        store["slots"].upload(_concat([m.slots for m in unique], np.int32, 0).tobytes())
        store["uvs"].upload(_concat([m.uvs for m in unique if m.uvs is not None], np.float32, 2).tobytes())
        self._rows = None  # every instance's mesh offsets may have moved

    # -- the instance table ------------------------------------------------------------------
    def _pack(self, geometry: InstancedGeometry, which: np.ndarray | None,
              slot_table: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray:
        """Table rows of the instances ``which`` (all when None)."""
        instances = geometry.instances
        picked = np.arange(len(instances)) if which is None else which
        k = len(picked)
        rows = np.zeros(max(k, 1) if which is None else k, INSTANCE_DTYPE)
        if k == 0:
            return rows
        places = [self._placements[m.mesh_id] for m in instances.meshes]
        mesh_offsets = np.array([(p.vertex, p.normal, p.triangle, p.uv) for p in places], np.int32)
        matrices = instances.matrices[picked]
        rows["matrix"][:k] = matrices.transpose(0, 2, 1).reshape(k, 16)  # GLSL mat4 is column-major
        normal = normal_matrices(matrices).astype(np.float32)  # (k, 3, 3), columns normal[:, :, j]
        cols = rows["normal_cols"][:k].reshape(k, 3, 4)
        cols[:, :, :3] = normal.transpose(0, 2, 1)
        rows["mesh"][:k] = mesh_offsets[instances.mesh[picked]]
        ranges = geometry.object_ranges[picked]
        rows["info"][:k, 0] = ranges[:, 0]
        rows["info"][:k, 1] = ranges[:, 1]
        rows["info"][:k, 2] = slot_table[1][picked]
        rows["info"][:k, 3] = slot_table[2][picked]
        rows["flags"][:k, 0] = instances.mirrored(picked)
        return rows

    # -- the dispatch ------------------------------------------------------------------------
    def _transform(self, geometry: InstancedGeometry, which: np.ndarray, outputs: dict[str, object],
                   stats: TransformStats) -> None:
        ranges = geometry.object_ranges[which].astype(np.int64)
        keep = ranges[:, 1] > 0
        which, ranges = which[keep], ranges[keep]
        if len(which) == 0:
            return
        chunk = rows_per_chunk()
        store = self._store
        for chunk_first in range(int(ranges[:, 0].min()) // chunk * chunk, int((ranges[:, 0] + ranges[:, 1]).max()),
                                 chunk):
            chunk_end = chunk_first + chunk
            first = np.maximum(ranges[:, 0], chunk_first)
            end = np.minimum(ranges[:, 0] + ranges[:, 1], chunk_end)
            inside = end > first
            if not inside.any():
                continue
            segments = np.zeros((int(inside.sum()), 4), np.uint32)
            segments[:, 0] = which[inside]
            segments[:, 1] = first[inside] - ranges[inside, 0]  # first local triangle
            segments[:, 2] = end[inside] - first[inside]
            segments[:, 3] = first[inside] - chunk_first
            counts = segments[:, 2].astype(np.int64)
            starts = np.concatenate([[0], np.cumsum(counts)]).astype(np.uint32)
            total = int(counts.sum())
            store["segments"].upload(segments.tobytes())
            store["segment_starts"].upload(starts.tobytes())
            rows = min(chunk, geometry.triangle_count - chunk_first)
            bind(self.program,
                 storage={"MeshPositions": store["positions"].buffer, "MeshNormals": store["normals"].buffer,
                          "MeshCornerVertices": store["corner_vertices"].buffer,
                          "MeshCornerNormals": store["corner_normals"].buffer,
                          "MeshSlots": store["slots"].buffer, "MeshUVs": store["uvs"].buffer,
                          "SlotMaterials": store["slot_materials"].buffer,
                          "InstanceTable": store["instances"].buffer, "Segments": store["segments"].buffer,
                          "SegmentStarts": store["segment_starts"].buffer,
                          **{_OUTPUT_BLOCKS[name]: Storage(outputs[name].buffer, rows * size, chunk_first * size)
                             for name, size in OUTPUT_ROW_BYTES.items()}},
                 uniforms={"u_count": total, "u_segments": len(segments)})
            start = time.perf_counter()
            dispatch(self.program, total, LOCAL_SIZE)
            stats.dispatch_ms += (time.perf_counter() - start) * 1e3
            stats.dispatches += 1
            stats.triangles_transformed += total
        # The outputs are read as storage blocks and as vertex attributes: every barrier.
        self.ctx.memory_barrier()

    def release(self) -> None:
        for buf in self._store.values():
            buf.release()
