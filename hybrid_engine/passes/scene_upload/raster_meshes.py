# SPDX-License-Identifier: GPL-3.0-or-later
"""Object-space vertex and index buffers of the scene's meshes, for indexed raster draws.

The world-space rows of the instance transform (instance_transform.py) give every triangle
its own three vertices: what the LBVH, the near-cube cull and the tracer want, but a raster
pass drawing them transforms each vertex once per triangle corner. A GPU is built for the
other shape: a mesh's distinct vertices and an index list, drawn once per instance with the
instance's matrix applied in the vertex stage, where the post-transform cache shades a
vertex shared by several triangles once (the ``vertices`` kernel's "gpu" variant,
gpu/variants.py; view_cull/instanced_draw.py draws them).

A raster vertex is a distinct corner of a mesh: its position, its normal (Blender keeps
normals on their own domain: vertex, face or corner) and its UV (sanitised as the transform
does: a non-finite UV becomes 0). Each mesh has two index lists, its triangles in order and
the same with corners 1 and 2 swapped, which a mirroring instance draws: the transform swaps
them there (meshes.MIRROR_CORNERS), and the same corner order keeps the rasterizer's
arithmetic, and so the G-buffer, identical to drawing the rows.

Some instances keep the world-space rows (``InstanceDraws.instanced`` False):
* a mesh with no vertex shared between corners, such as the meshes a flat world-space
  ``Geometry`` becomes at the upload (geometry.py ``from_world``): indexing saves nothing;
* a mesh with a non-finite vertex: the transform collapses each triangle with a non-finite
  corner to the origin, which a vertex stage (seeing one vertex) cannot do;
* an instance whose coordinates could overflow float32 in the transform (entries beyond
  ``MAGNITUDE_LIMIT``): the rows hold what the transform made of them.
A deformed mesh re-sends its vertices into place.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ...gpu.dispatch import GrowBuffer
from ...scene.geometry import InstancedGeometry
from ...scene.meshes import MIRROR_CORNERS, VERTEX_LIMIT, ObjectMesh

# Interleaved object-space vertex: (GLSL input, moderngl format, bytes), in buffer order.
VERTEX_ATTRIBUTES = (("in_object_pos", "3f", 12), ("in_object_normal", "3f", 12), ("in_uv", "2f", 8))
VERTEX_DTYPE = np.dtype([("position", "<f4", 3), ("normal", "<f4", 3), ("uv", "<f4", 2)])
assert VERTEX_DTYPE.itemsize == sum(size for *_, size in VERTEX_ATTRIBUTES)

# Coordinates and matrix entries below this keep every product and sum of the transform far
# from float32's range (3.4e38), so that no vertex of a finite mesh becomes non-finite there.
MAGNITUDE_LIMIT = VERTEX_LIMIT


def _sanitised_uvs(mesh: ObjectMesh) -> np.ndarray:
    """Corner UVs as the transform reads them: 0 without UVs, and for a non-finite UV."""
    uvs = np.zeros((3 * mesh.triangle_count, 2), np.float32) if mesh.uvs is None else mesh.uvs.copy()
    uvs[~np.isfinite(uvs).all(axis=1)] = 0.0
    return uvs


def distinct_corners(mesh: ObjectMesh) -> tuple[np.ndarray, np.ndarray]:
    """``mesh``'s distinct corners (same position, normal and UV bits), each given by its
    first corner, in order of first use (which keeps neighbouring triangles' vertices
    together), and the (3N,) uint32 index list into them."""
    keys = np.empty((3 * mesh.triangle_count, 4), np.uint32)
    keys[:, 0] = mesh.corner_vertices
    keys[:, 1] = mesh.corner_normals
    keys[:, 2:] = _sanitised_uvs(mesh).view(np.uint32)
    _, first, inverse = np.unique(np.ascontiguousarray(keys).view(np.dtype((np.void, 16))).reshape(-1),
                                  return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")
    rank = np.empty(len(order), np.int64)
    rank[order] = np.arange(len(order))
    return first[order], rank[inverse.reshape(-1)].astype(np.uint32)


def vertex_rows(mesh: ObjectMesh, corners: np.ndarray) -> np.ndarray:
    """The raster vertices (VERTEX_DTYPE) of ``mesh``'s corners ``corners``."""
    rows = np.empty(len(corners), VERTEX_DTYPE)
    rows["position"] = mesh.positions[mesh.corner_vertices[corners]]
    rows["normal"] = mesh.normals[mesh.corner_normals[corners]]
    rows["uv"] = _sanitised_uvs(mesh)[corners]
    return rows


@dataclass(frozen=True, eq=False)
class _Placed:
    """Where a mesh lies in the raster buffers, and the version of it they hold."""

    vertex: int  # its first vertex (a draw's baseVertex)
    index: int  # its first index; the mirrored list follows 3 N indices later
    corners: np.ndarray  # the first corner of each stored vertex (none for a mesh that shares none)
    # No two corners share a position and a normal, so no UVs can make them share a vertex
    # (a flat geometry's meshes): a deformation of it needs no new look.
    never_shares: bool
    sent: ObjectMesh


def _pairs_distinct(mesh: ObjectMesh) -> bool:
    pairs = np.stack([mesh.corner_vertices, mesh.corner_normals], axis=1).astype(np.uint32)
    return len(np.unique(np.ascontiguousarray(pairs).view(np.uint64))) == len(pairs)


def _drawable(mesh: ObjectMesh) -> bool:
    """Whether the vertex stage can transform ``mesh``'s vertices as the transform does
    (module doc): all finite and of moderate size."""
    return bool(mesh.triangle_count and mesh.finite and (np.abs(mesh.bounds) < MAGNITUDE_LIMIT).all())


@dataclass(frozen=True)
class InstanceDraws:
    """Per instance of a geometry: whether it is drawn from the raster buffers, and its
    indexed draw's index count, first index and base vertex; ``vertices`` the vertices such
    a draw shades (the mesh's distinct corners), 3 N for an instance drawn from the rows."""

    instanced: np.ndarray  # (K,) bool
    count: np.ndarray  # (K,) uint32
    first_index: np.ndarray  # (K,) uint32
    base_vertex: np.ndarray  # (K,) int32
    vertices: np.ndarray  # (K,) int64


class RasterMeshes:
    """The raster vertex and index buffers of a geometry's meshes (module doc), kept from
    frame to frame: rebuilt when the list of meshes changes, a deformed mesh re-sent in place."""

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.vertices = GrowBuffer(ctx, "raster mesh vertices", VERTEX_DTYPE.itemsize)
        self.indices = GrowBuffer(ctx, "raster mesh indices", 12)
        self._placed: dict[int, _Placed] = {}
        self._order: list[tuple[int, int]] = []
        self.generation = 0  # bumps when a buffer object is replaced (vertex arrays follow)
        self.meshes_sent = 0  # meshes written by the last update (tests)
        # The last geometry's draws and what they were made from: a frame asks once per
        # layer of draws (primary view, shadow layers) for the same instances.
        self._draws: tuple[tuple, InstanceDraws] | None = None

    def update(self, geometry: InstancedGeometry) -> None:
        """Bring the buffers up to ``geometry``'s meshes."""
        meshes = geometry.instances.meshes
        order = [(m.mesh_id, m.triangle_count) for m in meshes]
        self.meshes_sent = 0
        if order != self._order:
            self._rebuild(meshes)
            self._order = order
            return
        for mesh in meshes:
            place = self._placed[mesh.mesh_id]
            if place.sent is mesh or place.sent.version == mesh.version:
                continue
            same_topology = (mesh.corner_vertices is place.sent.corner_vertices
                             and mesh.corner_normals is place.sent.corner_normals and mesh.uvs is place.sent.uvs)
            if not same_topology and not (place.never_shares and mesh.corner_vertices is place.sent.corner_vertices
                                          and mesh.corner_normals is place.sent.corner_normals):
                self._rebuild(meshes)  # new corners or UVs may join or split vertices
                return
            if len(place.corners):
                self.vertices.write_at(vertex_rows(mesh, place.corners).tobytes(),
                                       place.vertex * VERTEX_DTYPE.itemsize)
                self.meshes_sent += 1
            self._placed[mesh.mesh_id] = replace(place, sent=mesh)
            self._draws = None

    def _rebuild(self, meshes: list[ObjectMesh]) -> None:
        placed: dict[int, _Placed] = {}
        all_rows, index_rows = [], []
        vertex = index = 0
        for mesh in meshes:
            if mesh.mesh_id in placed:
                continue
            corners, indices = distinct_corners(mesh)
            shares = len(corners) < 3 * mesh.triangle_count
            if not shares:  # drawn from the rows: nothing to store
                corners, indices = corners[:0], indices[:0]
            rows = vertex_rows(mesh, corners)
            mirrored = indices.reshape(-1, 3)[:, MIRROR_CORNERS].reshape(-1)
            placed[mesh.mesh_id] = _Placed(vertex, index, corners.astype(np.int32),
                                           not shares and _pairs_distinct(mesh), mesh)
            all_rows.append(rows)
            index_rows += [indices, mirrored]
            vertex += len(rows)
            index += 2 * len(indices)
        self._placed = placed
        self._draws = None
        allocations = (self.vertices.allocations, self.indices.allocations)
        self.vertices.upload(np.concatenate(all_rows).tobytes() if all_rows else b"")
        self.indices.upload(np.concatenate(index_rows).astype(np.uint32).tobytes() if index_rows else b"")
        if (self.vertices.allocations, self.indices.allocations) != allocations:
            self.generation += 1
        self.meshes_sent = len(placed)

    def draws(self, geometry: InstancedGeometry) -> InstanceDraws:
        """Each instance's indexed draw (``update`` first); the same arrays again while
        neither the instances nor the buffers changed (the caller only reads them)."""
        instances = geometry.instances
        key = (instances.matrices.tobytes(), instances.mesh.tobytes(),
               tuple((m.mesh_id, m.version) for m in instances.meshes))
        if self._draws is not None and self._draws[0] == key:
            return self._draws[1]
        found = self._make_draws(instances)
        self._draws = (key, found)
        return found

    def _make_draws(self, instances) -> InstanceDraws:
        meshes = instances.meshes
        k = len(instances)
        places = [self._placed[m.mesh_id] for m in meshes]
        mesh_ok = np.array([len(p.corners) > 0 and _drawable(p.sent) for p in places], bool)
        mesh_first = np.array([p.index for p in places], np.int64)
        mesh_base = np.array([p.vertex for p in places], np.int64)
        mesh_vertices = np.array([len(p.corners) for p in places], np.int64)
        mesh_triangles = np.array([m.triangle_count for m in meshes], np.int64)
        if k == 0:
            empty = np.zeros(0, np.int64)
            return InstanceDraws(np.zeros(0, bool), empty.astype(np.uint32), empty.astype(np.uint32),
                                 empty.astype(np.int32), empty)
        which = instances.mesh
        matrices = instances.matrices.reshape(k, 16)
        small = np.isfinite(matrices).all(axis=1) & (np.abs(matrices) < MAGNITUDE_LIMIT).all(axis=1)
        instanced = mesh_ok[which] & small
        triangles = mesh_triangles[which]
        first = mesh_first[which] + np.where(instances.mirrored(), 3 * triangles, 0)
        vertices = np.where(instanced, mesh_vertices[which], 3 * triangles)
        return InstanceDraws(instanced, (3 * triangles).astype(np.uint32), first.astype(np.uint32),
                             mesh_base[which].astype(np.int32), vertices)

    def release(self) -> None:
        self.vertices.release()
        self.indices.release()
        self._placed.clear()
        self._order = []
        self._draws = None
