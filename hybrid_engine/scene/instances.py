# SPDX-License-Identifier: GPL-3.0-or-later
"""Object-space meshes and the instances that place them: the scene as it lives on the GPU.

The paper keeps its meshes on the GPU and transforms them to world space there every frame
(§3.3), so that rigid motion costs a matrix, not a pass over the object's triangles on the
host. ``InstancedGeometry`` is that description: each mesh is stored once, indexed as
Blender stores it (vertices, corners, normals on their own domain), and each instance names
a mesh, an object-to-world matrix and the materials of its slots. The GPU produces the
world-space triangle soup every other pass reads (instance_transform.py); nothing on the
host makes it, except :meth:`InstancedGeometry.world_arrays` for the CPU oracles (embree,
the Whitted reference) and tests, with the same arithmetic as the shader.

An ``InstancedGeometry`` is a ``Geometry``: the per-object data the host passes use
(object ranges, bounds, closedness, names, the producer's edits) are plain arrays, and the
world-space arrays are made on first access.

Bounds of an instance are its mesh's object-space box, transformed corner by corner: never
smaller than the world-space box of its vertices, and what lets a moved object cost eight
points instead of all its vertices. The culling passes only need a box that contains the
object.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from .data import Geometry, GeometryEdit, SceneDataError

_mesh_ids = itertools.count(1)

# Corner order of a triangle seen through a mirroring transform (negative determinant): the
# winding reverses, so corners 1 and 2 swap to keep it counter-clockwise from outside.
MIRROR_CORNERS = np.array([0, 2, 1])


def new_mesh_id() -> int:
    """A process-unique identity for a mesh's topology; a deformation keeps it."""
    return next(_mesh_ids)


@dataclass
class ObjectMesh:
    """One mesh in object space, as Blender stores it.

    ``corner_vertices[3 t + c]`` indexes ``positions`` for corner c of triangle t, and
    ``corner_normals[3 t + c]`` indexes ``normals`` (the domain Blender keeps them on:
    vertex, face or corner). ``uvs`` are per corner. ``slots`` give each triangle's material
    slot, which each instance maps to a material of the scene's table.

    ``mesh_id`` names the topology (corners, slots, UVs) and ``version`` its vertex data: a
    deformed mesh keeps its id and bumps its version, so the GPU re-sends only positions and
    normals (instance_transform.py).
    """

    positions: np.ndarray  # (V, 3) float32
    corner_vertices: np.ndarray  # (3N,) int32
    normals: np.ndarray  # (D, 3) float32, unit
    corner_normals: np.ndarray  # (3N,) int32
    slots: np.ndarray  # (N,) int32
    uvs: np.ndarray | None = None  # (3N, 2) float32
    closed: bool = False  # solids.py: closed and wound outwards
    mesh_id: int = field(default_factory=new_mesh_id)
    version: int = 0
    bounds: np.ndarray = field(init=False)  # (2, 3) float32 box of the finite used vertices
    finite: bool = field(init=False)  # every used vertex is finite

    def __post_init__(self) -> None:
        self.positions = _array(self.positions, np.float32, (3,), "positions")
        self.normals = _array(self.normals, np.float32, (3,), "normals")
        self.corner_vertices = _array(self.corner_vertices, np.int32, (), "corner_vertices")
        self.corner_normals = _array(self.corner_normals, np.int32, (), "corner_normals")
        self.slots = _array(self.slots, np.int32, (), "slots")
        n = len(self.slots)
        if len(self.corner_vertices) != 3 * n or len(self.corner_normals) != 3 * n:
            raise SceneDataError(f"a mesh of {n} triangles needs {3 * n} corner indices, got "
                                 f"{len(self.corner_vertices)} and {len(self.corner_normals)}")
        if n and (self.corner_vertices.min() < 0 or self.corner_vertices.max() >= len(self.positions)
                  or self.corner_normals.min() < 0 or self.corner_normals.max() >= len(self.normals)):
            raise SceneDataError("corner indices point outside the mesh's vertices or normals")
        if self.uvs is not None:
            self.uvs = _array(self.uvs, np.float32, (2,), "uvs")
            if len(self.uvs) != 3 * n:
                raise SceneDataError(f"uvs has {len(self.uvs)} corners, the mesh {3 * n}")
        self._measure()

    def _measure(self) -> None:
        """Bounds and finiteness over all vertices, a column at a time (numpy reduces a
        strided column far faster than axis 0 of a three-wide array): a vertex no triangle
        uses can only make the box larger, which culling allows. Only a mesh with a
        non-finite vertex pays for finding the vertices its triangles use."""
        points = self.positions
        lo = np.array([points[:, k].min() for k in range(3)]) if len(points) else np.full(3, np.inf)
        hi = np.array([points[:, k].max() for k in range(3)]) if len(points) else np.full(3, -np.inf)
        self.finite = bool(np.isfinite(lo).all() and np.isfinite(hi).all())
        if not self.finite:
            used = np.zeros(len(points), bool)
            used[self.corner_vertices] = True
            finite_used = used & np.isfinite(points).all(axis=1)
            self.finite = bool((finite_used == used).all())
            points = points[finite_used]
            lo = points.min(axis=0) if len(points) else np.full(3, np.inf)
            hi = points.max(axis=0) if len(points) else np.full(3, -np.inf)
        self.bounds = np.stack([lo, hi]).astype(np.float32)

    @property
    def triangle_count(self) -> int:
        return int(len(self.slots))

    def deformed(self, positions: np.ndarray, normals: np.ndarray) -> "ObjectMesh":
        """The same topology with new vertex positions and normals (an armature, a shape
        key, a Wave modifier): same ``mesh_id``, next ``version``."""
        mesh = ObjectMesh.__new__(ObjectMesh)
        mesh.__dict__.update(self.__dict__)
        mesh.positions = _array(positions, np.float32, (3,), "positions")
        mesh.normals = _array(normals, np.float32, (3,), "normals")
        if len(mesh.positions) != len(self.positions) or len(mesh.normals) != len(self.normals):
            raise SceneDataError("a deformed mesh must keep its vertex and normal counts")
        mesh.version = self.version + 1
        mesh._measure()
        return mesh


@dataclass
class Instances:
    """Where each object stands: ``mesh[k]`` indexes ``meshes``, ``matrices[k]`` is its
    object-to-world matrix, ``slot_materials[k]`` the scene material of each of its slots
    (a triangle whose slot is missing uses material 0, the grey fallback)."""

    meshes: list[ObjectMesh]
    mesh: np.ndarray  # (K,) int32
    matrices: np.ndarray  # (K, 4, 4) float32
    slot_materials: list[np.ndarray]  # K arrays of int32

    def __post_init__(self) -> None:
        self.mesh = _array(self.mesh, np.int32, (), "instance meshes")
        self.matrices = np.ascontiguousarray(np.asarray(self.matrices, np.float32).reshape(-1, 4, 4))
        k = len(self.mesh)
        if len(self.matrices) != k or len(self.slot_materials) != k:
            raise SceneDataError(f"{k} instances need {k} matrices and slot lists, got "
                                 f"{len(self.matrices)} and {len(self.slot_materials)}")
        if k and (self.mesh.min() < 0 or self.mesh.max() >= len(self.meshes)):
            raise SceneDataError("an instance names a mesh that is not in the list")
        self.slot_materials = [np.asarray(s, np.int32).reshape(-1) for s in self.slot_materials]

    def __len__(self) -> int:
        return int(len(self.mesh))

    def slot_table(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The slot materials as one int32 array (at least one entry), each instance's first
        index into it and its count; kept until ``set_slots`` (thousands of instances
        would otherwise be concatenated every frame)."""
        cached = self.__dict__.get("_slot_table")
        if cached is None:
            counts = np.fromiter((len(s) for s in self.slot_materials), np.int64, len(self.slot_materials))
            flat = np.concatenate(self.slot_materials).astype(np.int32) if counts.sum() else np.zeros(1, np.int32)
            firsts = np.concatenate([[0], np.cumsum(counts)[:-1]]) if len(counts) else np.zeros(0, np.int64)
            cached = self.__dict__["_slot_table"] = (flat, firsts, counts)
        return cached

    def set_slots(self, row: int, materials: np.ndarray) -> None:
        """Give instance ``row`` new slot materials (the way to change them: it refreshes
        ``slot_table``)."""
        self.slot_materials[row] = np.asarray(materials, np.int32).reshape(-1)
        self.__dict__.pop("_slot_table", None)

    def triangle_counts(self) -> np.ndarray:
        counts = np.array([m.triangle_count for m in self.meshes], np.int64)
        return counts[self.mesh] if len(self.mesh) else np.zeros(0, np.int64)

    def mirrored(self, rows=slice(None)) -> np.ndarray:
        """Bool per instance of ``rows`` (all by default): the matrix reverses orientation."""
        return np.linalg.det(self.matrices[rows, :3, :3].astype(np.float64)) < 0

    def world_bounds(self, rows=slice(None)) -> np.ndarray:
        """(k, 2, 3) world boxes of the instances ``rows`` (all by default): each mesh's
        box, its eight corners transformed."""
        matrices = self.matrices[rows]
        k = len(matrices)
        out = np.empty((k, 2, 3), np.float32)
        if k == 0:
            return out
        boxes = np.stack([m.bounds for m in self.meshes])[self.mesh[rows]].astype(np.float64)  # (k, 2, 3)
        empty = ~(boxes[:, 0] <= boxes[:, 1]).all(axis=1)
        corners = np.stack([np.stack([boxes[:, (i >> axis) & 1, axis] for axis in range(3)], axis=1)
                            for i in range(8)], axis=1)  # (k, 8, 3)
        linear = matrices[:, :3, :3].astype(np.float64)
        world = np.einsum("kij,kcj->kci", linear, np.where(empty[:, None, None], 0.0, corners))
        world += matrices[:, None, :3, 3]
        out[:, 0], out[:, 1] = world.min(axis=1), world.max(axis=1)
        out[empty] = np.array([[np.inf] * 3, [-np.inf] * 3], np.float32)
        return out


def normal_matrices(matrices: np.ndarray) -> np.ndarray:
    """(K, 3, 3) inverse-transposes of the matrices' 3x3 parts, up to a positive scale:
    the cofactor matrix (columns a1×a2, a2×a0, a0×a1) times sign(det), defined for singular
    matrices (flattened objects) where the inverse is not. Normals are renormalised after."""
    linear = np.asarray(matrices, np.float64)[:, :3, :3]
    a0, a1, a2 = linear[:, :, 0], linear[:, :, 1], linear[:, :, 2]
    cofactor = np.stack([np.cross(a1, a2), np.cross(a2, a0), np.cross(a0, a1)], axis=2)
    sign = np.where(np.linalg.det(linear) < 0, -1.0, 1.0)
    return cofactor * sign[:, None, None]


class InstancedGeometry(Geometry):
    """A ``Geometry`` made of instances of object-space meshes (module docstring).

    ``triangles``, ``normals``, ``uvs`` and ``material_ids`` are the world-space arrays of
    ``Geometry``, made on the host only when read. ``edit`` works as for ``Geometry``: the
    producer lists the instances it changed since its last version.
    """

    def __init__(self, instances: Instances, names: list[str] | None = None,
                 edit: GeometryEdit | None = None) -> None:
        self.instances = instances
        counts = instances.triangle_counts()
        firsts = np.concatenate([[0], np.cumsum(counts)[:-1]]) if len(counts) else np.zeros(0, np.int64)
        self.object_ranges = np.stack([firsts, counts], axis=1).astype(np.int32).reshape(-1, 2)
        self.object_names = list(names) if names else [f"object_{i}" for i in range(len(instances))]
        self.edit = edit
        self._count = int(counts.sum())
        self.refresh()

    def refresh(self, rows: list[int] | None = None) -> None:
        """Recompute the per-object data after the producer changed ``instances`` in place
        (matrices, meshes of unchanged triangle counts, slot materials); ``rows`` limits the
        bounds to those instances. The host's world arrays, if made, are dropped."""
        instances = self.instances
        if rows is None:
            self.object_bounds = instances.world_bounds()
        elif rows:
            self.object_bounds[rows] = instances.world_bounds(rows)
        closed = np.array([m.closed and m.finite for m in instances.meshes], bool)
        self.object_closed = closed[instances.mesh] if len(instances) else np.zeros(0, bool)
        self._has_uvs = any(m.uvs is not None for m in instances.meshes)
        self._world = None

    @property
    def triangle_count(self) -> int:
        return self._count

    def clamp_material_ids(self, count: int) -> None:
        """Slot materials outside a table of ``count`` use material 0 (Geometry's fallback,
        applied to the instance table instead of per-triangle ids)."""
        instances = self.instances
        if not len(instances):
            return
        flat = instances.slot_table()[0]
        if flat.min() < 0 or flat.max() >= count:
            for row, table in enumerate(instances.slot_materials):
                instances.set_slots(row, np.where((table >= 0) & (table < count), table, 0))
            self._world = None

    def _array_of(self, name: str) -> np.ndarray | None:
        if self._world is None:
            self._world = self.world_arrays()
        return self._world[name]

    triangles = property(lambda self: self._array_of("triangles"))
    normals = property(lambda self: self._array_of("normals"))
    material_ids = property(lambda self: self._array_of("material_ids"))
    uvs = property(lambda self: self._array_of("uvs") if self._has_uvs else None)
    has_uvs = property(lambda self: self._has_uvs)

    def world_arrays(self) -> dict[str, np.ndarray]:
        """World-space triangle soup with the arithmetic of instance_transform.comp.glsl:
        positions through the matrix, normals through ``normal_matrices`` and renormalised
        (zero or non-finite ones become 0, as the upload leaves them for the G-buffer to
        replace), corners 1 and 2 swapped under a mirroring matrix, missing slots material
        0, and a triangle with a non-finite corner collapsed to the origin."""
        n = self._count
        out = {"triangles": np.zeros((n, 3, 3), np.float32), "normals": np.zeros((n, 3, 3), np.float32),
               "material_ids": np.zeros(n, np.int32), "uvs": np.zeros((n, 3, 2), np.float32)}
        instances = self.instances
        mirrored = instances.mirrored()
        normal_matrix = normal_matrices(instances.matrices).astype(np.float32)
        for k, (first, count) in enumerate(self.object_ranges):
            if count == 0:
                continue
            mesh = instances.meshes[instances.mesh[k]]
            matrix = instances.matrices[k]
            order = np.arange(3) if not mirrored[k] else MIRROR_CORNERS
            corners_v = mesh.corner_vertices.reshape(-1, 3)[:, order]
            corners_n = mesh.corner_normals.reshape(-1, 3)[:, order]
            with np.errstate(invalid="ignore", over="ignore"):
                world = mesh.positions @ matrix[:3, :3].T + matrix[:3, 3]
                normals = mesh.normals @ normal_matrix[k].T
                length = np.sqrt(np.einsum("ij,ij->i", normals, normals))
                ok = np.isfinite(length) & (length > 0)
                normals = np.where(ok[:, None], normals / np.where(ok, length, 1.0)[:, None], 0.0)
            tris = world[corners_v]
            bad = ~np.isfinite(tris).all(axis=(1, 2))
            tris[bad] = 0.0
            end = first + count
            out["triangles"][first:end] = tris
            out["normals"][first:end] = normals[corners_n]
            slots = mesh.slots
            table = instances.slot_materials[k]
            valid = (slots >= 0) & (slots < len(table))
            out["material_ids"][first:end] = np.where(valid, table[np.clip(slots, 0, max(len(table) - 1, 0))]
                                                      if len(table) else 0, 0)
            if mesh.uvs is not None:
                uvs = mesh.uvs.reshape(-1, 3, 2)[:, order]
                out["uvs"][first:end] = np.where(np.isfinite(uvs), uvs, 0.0)
        return out


def _array(values, dtype, tail: tuple[int, ...], name: str) -> np.ndarray:
    array = np.ascontiguousarray(np.asarray(values, dtype))
    if array.ndim != 1 + len(tail) or tuple(array.shape[1:]) != tail:
        raise SceneDataError(f"{name} must have shape (N{''.join(', ' + str(t) for t in tail)}), got {array.shape}")
    return array
