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
so the shader never needs the split-array code. The object-space store is cut into pages
the same way: whole meshes, as many as fit one block in every array, each page bound on its
own for the instances of its meshes. Only a single mesh larger than a block cannot be
placed; it fails with a message naming its object and the limit.

The work is two steps, so that timings follow them: ``update`` is the host's part (the store,
the table, which instances changed: the frame's ``upload``), ``transform`` the GPU's (the
dispatches: ``instance_transform``).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from ...gpu import shader_loader
from ...gpu.bindings import Storage, bind
from ...gpu.dispatch import BLOCK_ITEM_GRANULE, GrowBuffer, SceneLimitError, dispatch, max_block_bytes
from ...scene.geometry import InstancedGeometry
from ...scene.meshes import ObjectMesh, normal_matrices
from .previous_rows import PreviousRows

LOCAL_SIZE = 64

# struct Instance of instance_transform.comp.glsl (std430).
INSTANCE_DTYPE = np.dtype([("matrix", np.float32, 16), ("normal_cols", np.float32, 12),
                           ("mesh", np.int32, 4), ("info", np.int32, 4), ("flags", np.int32, 4)])
assert INSTANCE_DTYPE.itemsize == 160

# Bytes per world-space row (one triangle) of each output, by GPUScene buffer name.
OUTPUT_ROW_BYTES = {"positions": 36, "normals": 36, "uvs": 24, "triangle_materials": 4, "uv_rows": 32}
_OUTPUT_BLOCKS = {"positions": "WorldPositions", "normals": "WorldNormals", "uvs": "WorldUVs",
                  "triangle_materials": "WorldMaterials", "uv_rows": "WorldUVRows"}


# The object-space store's arrays and their bytes per vertex, normal, triangle or UV'd triangle
# of a mesh; a store page keeps each of them within one storage block.
STORE_ARRAYS = ("positions", "normals", "corner_vertices", "corner_normals", "slots", "uvs")


def mesh_store_bytes(mesh: ObjectMesh) -> dict[str, int]:
    """Bytes ``mesh`` takes in each array of a store page."""
    n = mesh.triangle_count
    return {"positions": 12 * len(mesh.positions), "normals": 12 * len(mesh.normals),
            "corner_vertices": 12 * n, "corner_normals": 12 * n, "slots": 4 * n,
            "uvs": 24 * n if mesh.uvs is not None else 0}


@dataclass(frozen=True, eq=False)
class _Placement:
    """Where one mesh lies in the object-space store (its page and its first items there),
    and the version of it the store holds."""

    page: int
    vertex: int
    normal: int
    triangle: int
    uv: int  # first UV corner, -1: the mesh has none
    sent: ObjectMesh


@dataclass
class TransformStats:
    """What the last update did (tests, timing)."""

    meshes_uploaded: int = 0  # meshes whose data was written (whole or deformed)
    store_rebuilt: bool = False
    store_pages: int = 0
    rows_packed: int = 0  # table rows packed and compared (a producer's edit limits them)
    instances_written: int = 0  # table rows that changed
    # The instances whose rows the transform (re)writes, sorted, and their triangles.
    changed: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    # Those of them whose mesh was deformed (the same triangles, new vertices), sorted.
    deformed: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
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


class InstanceTransformer:
    """The object-space store, the instance table and the transform dispatch."""

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.program = shader_loader.compute(ctx, "scene_upload/instance_transform.comp.glsl", {"LOCAL_SIZE": LOCAL_SIZE})
        names = ("slot_materials", "instances", "segments", "segment_starts")
        self._store = {name: GrowBuffer(ctx, f"instance {name.replace('_', ' ')}") for name in names}
        self._pages: list[dict[str, GrowBuffer]] = []  # the object-space store, page by page
        self._placements: dict[int, _Placement] = {}
        self._pending: tuple | None = None  # (geometry, instances, outputs) for ``transform``
        self._mesh_order: list[tuple] = []
        self._rows: np.ndarray | None = None
        self._slot_materials: np.ndarray | None = None
        self._seen: tuple | None = None  # (geometry id, edit) of the last update
        self.stats = TransformStats()
        # Last frame's rows of the instances this frame deformed (previous_rows.py), copied
        # only while the world buffers hold what the last transform wrote.
        self.previous = PreviousRows(ctx, OUTPUT_ROW_BYTES)
        self._outputs_hold_rows = False

    @property
    def instance_table(self):
        """The instance table's GL buffer (INSTANCE_DTYPE rows; instance_space.glsl's struct
        Instance), which the raster passes' indexed draws also read (view_cull/instanced_draw.py)."""
        return self._store["instances"].buffer

    def store_capacity(self) -> dict[str, int]:
        """Bytes allocated for each array of the object-space store, over all its pages
        (what the meshes cost on the GPU)."""
        return {name: sum(page[name].capacity for page in self._pages) for name in STORE_ARRAYS}

    def forget(self) -> None:
        """The outputs were written by someone else: the next update transforms everything."""
        self._rows = None
        self._seen = None
        self._outputs_hold_rows = False

    def update(self, geometry: InstancedGeometry, outputs: dict[str, object]) -> TransformStats:
        """Bring the store and the table up to ``geometry`` and plan the world rows of every
        instance that changed into ``outputs`` (GPUScene's buffers by name, at least
        ``triangle_count`` rows each), which ``transform`` then writes on the GPU;
        ``stats.changed`` lists those instances.

        A producer's version seen already (``Geometry.edit``) costs nothing; its next version
        costs the rows it lists (packed, compared, written); anything else packs and compares
        every row (a geometry without edits may have been changed in place)."""
        stats = self.stats = TransformStats()
        self.previous.clear()
        edit = geometry.edit
        seen = (id(geometry), edit.source, edit.generation) if edit is not None else None
        if seen is not None and seen == self._seen and self._rows is not None:
            return stats
        instances = geometry.instances
        deformed = self._update_store(geometry, stats)
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
            stats.rows_packed = len(which)
            differs = _rows_differ(self._rows[which], rows) | of_deformed[which]
            changed = which[differs]
            self._rows[changed] = rows[differs]
            self._write_rows(changed)
        else:
            rows = self._pack(geometry, None, slot_table)
            stats.rows_packed = len(instances)
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
        self._pending = (geometry, changed, outputs) if len(changed) else None
        stats.instances_written = int(len(changed))
        stats.changed = changed
        stats.deformed = changed[of_deformed[changed]] if len(changed) else changed
        stats.triangles_transformed = int(geometry.object_ranges[changed, 1].astype(np.int64).sum())
        self._seen = seen
        return stats

    def transform(self, keep_previous: bool = True) -> None:
        """Write the world rows the last ``update`` planned (the GPU's part of the step);
        ``keep_previous``: first copy the rows of the instances whose mesh deformed into
        ``previous`` (while the outputs hold what the last transform wrote)."""
        if self._pending is None:
            return
        geometry, changed, outputs = self._pending
        self._pending = None
        deformed = self.stats.deformed
        if keep_previous and len(deformed) and self._outputs_hold_rows and not self.stats.store_rebuilt:
            self.previous.capture(deformed, geometry.object_ranges[deformed], outputs)
        self._transform(geometry, changed, outputs, self.stats)
        self._outputs_hold_rows = True

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
    def _update_store(self, geometry: InstancedGeometry, stats: TransformStats) -> set[int]:
        """Upload what changed among the geometry's meshes; returns the indices of deformed
        meshes (their instances must be transformed again). A different list of topologies
        rebuilds it."""
        meshes = geometry.instances.meshes
        order = [(m.mesh_id, len(m.positions), len(m.normals), m.triangle_count, m.uvs is not None) for m in meshes]
        if order != self._mesh_order:
            instances = geometry.instances
            names = {}
            for row, mesh_index in enumerate(instances.mesh):
                names.setdefault(meshes[mesh_index].mesh_id, geometry.object_names[row])
            self._rebuild_store(meshes, names)
            self._mesh_order = order
            stats.store_rebuilt = True
            stats.store_pages = len(self._pages)
            stats.meshes_uploaded = len(meshes)
            return set()
        deformed = set()
        for index, mesh in enumerate(meshes):
            place = self._placements[mesh.mesh_id]
            if place.sent.version == mesh.version:
                continue
            page = self._pages[place.page]
            page["positions"].write_at(np.ascontiguousarray(mesh.positions, np.float32).tobytes(), place.vertex * 12)
            page["normals"].write_at(np.ascontiguousarray(mesh.normals, np.float32).tobytes(), place.normal * 12)
            # A deformation keeps the slot and UV arrays (the same objects); an edited flat
            # object brings new ones, written into place too.
            if mesh.slots is not place.sent.slots:
                page["slots"].write_at(np.ascontiguousarray(mesh.slots, np.int32).tobytes(), place.triangle * 4)
            if mesh.uvs is not None and mesh.uvs is not place.sent.uvs:
                page["uvs"].write_at(np.ascontiguousarray(mesh.uvs, np.float32).tobytes(), place.uv * 8)
            self._placements[mesh.mesh_id] = replace(place, sent=mesh)
            deformed.add(index)
        stats.meshes_uploaded = len(deformed)
        return deformed

    def _rebuild_store(self, meshes: list[ObjectMesh], names: dict[int, str]) -> None:
        """Place every unique mesh in a page (a new page when the next mesh would overflow a
        block in any array) and upload the pages. ``names`` gives a mesh's object for the
        message about a mesh too large for any page."""
        limit = max_block_bytes()
        self._placements = {}
        pages: list[list[ObjectMesh]] = [[]]
        used = dict.fromkeys(STORE_ARRAYS, 0)
        for mesh in meshes:
            if mesh.mesh_id in self._placements:
                continue
            need = mesh_store_bytes(mesh)
            if any(size > limit for size in need.values()):
                raise SceneLimitError(
                    f"the mesh of {names.get(mesh.mesh_id, 'an object')!r} ({mesh.triangle_count:,} triangles, "
                    f"{len(mesh.positions):,} vertices) is larger than one GPU storage block "
                    f"({limit / 2**20:,.0f} MiB) holds: split it into several objects or decimate it")
            if pages[-1] and any(used[name] + need[name] > limit for name in STORE_ARRAYS):
                pages.append([])
                used = dict.fromkeys(STORE_ARRAYS, 0)
            self._placements[mesh.mesh_id] = _Placement(
                len(pages) - 1, used["positions"] // 12, used["normals"] // 12, used["slots"] // 4,
                used["uvs"] // 8 if mesh.uvs is not None else -1, mesh)
            for name in STORE_ARRAYS:
                used[name] += need[name]
            pages[-1].append(mesh)
        while len(self._pages) < len(pages):
            index = len(self._pages)
            self._pages.append({name: GrowBuffer(self.ctx, f"instance mesh {name.replace('_', ' ')} (page {index})")
                                for name in STORE_ARRAYS})
        for extra in self._pages[len(pages):]:
            for buf in extra.values():
                buf.release()
        del self._pages[len(pages):]
        for page, unique in zip(self._pages, pages):
            page["positions"].upload(_concat([m.positions for m in unique], np.float32, 3).tobytes())
            page["normals"].upload(_concat([m.normals for m in unique], np.float32, 3).tobytes())
            page["corner_vertices"].upload(_concat([m.corner_vertices for m in unique], np.int32, 0).tobytes())
            page["corner_normals"].upload(_concat([m.corner_normals for m in unique], np.int32, 0).tobytes())
            page["slots"].upload(_concat([m.slots for m in unique], np.int32, 0).tobytes())
            page["uvs"].upload(_concat([m.uvs for m in unique if m.uvs is not None], np.float32, 2).tobytes())
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
        mesh_offsets = np.array([(p.vertex, p.normal, p.triangle, p.uv) for p in places], np.int32).reshape(-1, 4)
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
        instances = geometry.instances
        page_of_mesh = np.array([self._placements[m.mesh_id].page for m in instances.meshes], np.int64)
        pages = page_of_mesh[instances.mesh[which]]
        for page in np.unique(pages):
            on_page = pages == page
            self._transform_page(self._pages[int(page)], geometry, which[on_page], ranges[on_page], outputs, stats)
        # The outputs are read as storage blocks and as vertex attributes: every barrier.
        self.ctx.memory_barrier()

    def _transform_page(self, page: dict[str, GrowBuffer], geometry: InstancedGeometry, which: np.ndarray,
                        ranges: np.ndarray, outputs: dict[str, object], stats: TransformStats) -> None:
        """The dispatches for the instances ``which`` (whose meshes all lie in ``page``), chunk
        by chunk of output rows."""
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
                 storage={"MeshPositions": page["positions"].buffer, "MeshNormals": page["normals"].buffer,
                          "MeshCornerVertices": page["corner_vertices"].buffer,
                          "MeshCornerNormals": page["corner_normals"].buffer,
                          "MeshSlots": page["slots"].buffer, "MeshUVs": page["uvs"].buffer,
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

    def release(self) -> None:
        self.previous.release()
        for buf in self._store.values():
            buf.release()
        for page in self._pages:
            for buf in page.values():
                buf.release()
        self._pages = []
