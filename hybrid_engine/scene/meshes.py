# SPDX-License-Identifier: GPL-3.0-or-later
"""Object-space meshes and the instances that place them: the scene as it lives on the GPU.

The paper keeps its meshes on the GPU and transforms them to world space there every frame
(§3.3), so that rigid motion costs a matrix, not a pass over the object's triangles on the
host. ``ObjectMesh`` is a mesh stored once, indexed as Blender stores it (vertices,
corners, normals on their own domain); ``Instances`` name a mesh, an object-to-world matrix
and the materials of its slots for each object. ``geometry.InstancedGeometry`` holds them
for a frame; the GPU makes the world-space triangle soup every other pass reads
(passes/scene_upload/instance_transform.py).

Bounds of an instance are its mesh's object-space box, transformed corner by corner: never
smaller than the world-space box of its vertices, and what lets a moved object cost eight
points instead of all its vertices. The culling passes only need a box that contains the
object.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from .arrays import SceneDataError, as_array

# A vertex coordinate at or beyond this magnitude counts as non-finite. Blender stores an
# infinite coordinate as float32's largest value (its properties clamp to it): finite to
# numpy, it overflows the first product it meets (a bounds fit, a shadow map's texel size, an
# instance transform) and one bad vertex would bend every sun shadow. The limit also keeps
# every product and sum of the instance transform far from float32's range.
VERTEX_LIMIT = 1e18


def usable_vertices(points: np.ndarray) -> np.ndarray:
    """Bool per vertex of ``points`` (n, 3): finite and within ``VERTEX_LIMIT``."""
    with np.errstate(invalid="ignore"):
        return (np.abs(points) < VERTEX_LIMIT).all(axis=1)

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
    # The attributes the scene's node programs read (mesh_attributes.py), RGBA per corner,
    # by name; None or missing names read as mesh_attributes.MISSING.
    attributes: dict[str, np.ndarray] | None = None  # name -> (3N, 4) float32
    closed: bool = False  # solids.py: closed and wound outwards
    mesh_id: int = field(default_factory=new_mesh_id)
    version: int = 0
    bounds: np.ndarray = field(init=False)  # (2, 3) float32 box of the finite used vertices
    finite: bool = field(init=False)  # every used vertex is finite

    def __post_init__(self) -> None:
        self.positions = as_array(self.positions, np.float32, (3,), "positions")
        self.normals = as_array(self.normals, np.float32, (3,), "normals")
        self.corner_vertices = as_array(self.corner_vertices, np.int32, (), "corner_vertices")
        self.corner_normals = as_array(self.corner_normals, np.int32, (), "corner_normals")
        self.slots = as_array(self.slots, np.int32, (), "slots")
        n = len(self.slots)
        if len(self.corner_vertices) != 3 * n or len(self.corner_normals) != 3 * n:
            raise SceneDataError(f"a mesh of {n} triangles needs {3 * n} corner indices, got "
                                 f"{len(self.corner_vertices)} and {len(self.corner_normals)}")
        if n and (self.corner_vertices.min() < 0 or self.corner_vertices.max() >= len(self.positions)
                  or self.corner_normals.min() < 0 or self.corner_normals.max() >= len(self.normals)):
            raise SceneDataError("corner indices point outside the mesh's vertices or normals")
        if self.uvs is not None:
            self.uvs = as_array(self.uvs, np.float32, (2,), "uvs")
            if len(self.uvs) != 3 * n:
                raise SceneDataError(f"uvs has {len(self.uvs)} corners, the mesh {3 * n}")
        if self.attributes is not None:
            self.attributes = _checked_attributes(self.attributes, n)
        self._measure()

    def _measure(self) -> None:
        """Bounds and finiteness over all vertices, a column at a time (numpy reduces a
        strided column far faster than axis 0 of a three-wide array): a vertex no triangle
        uses can only make the box larger, which culling allows. Only a mesh with a
        non-finite vertex (``usable_vertices``) pays for finding the vertices its triangles use."""
        points = self.positions
        lo = np.array([points[:, k].min() for k in range(3)]) if len(points) else np.full(3, np.inf)
        hi = np.array([points[:, k].max() for k in range(3)]) if len(points) else np.full(3, -np.inf)
        with np.errstate(invalid="ignore"):
            self.finite = bool((np.abs(lo) < VERTEX_LIMIT).all() and (np.abs(hi) < VERTEX_LIMIT).all())
        if not self.finite:
            used = np.zeros(len(points), bool)
            used[self.corner_vertices] = True
            finite_used = used & usable_vertices(points)
            self.finite = bool((finite_used == used).all())
            points = points[finite_used]
            lo = points.min(axis=0) if len(points) else np.full(3, np.inf)
            hi = points.max(axis=0) if len(points) else np.full(3, -np.inf)
        self.bounds = np.stack([lo, hi]).astype(np.float32)

    @property
    def triangle_count(self) -> int:
        return int(len(self.slots))

    def deformed(self, positions: np.ndarray, normals: np.ndarray, slots: np.ndarray | None = None,
                 uvs: np.ndarray | None = None,
                 attributes: dict[str, np.ndarray] | None = None) -> "ObjectMesh":
        """The same topology with new vertex positions and normals (an armature, a shape
        key, a Wave modifier), and optionally new per-triangle slots or corner UVs of the
        same counts (a flat geometry's object whose materials or UVs were edited): same
        ``mesh_id``, next ``version``, so the GPU re-sends its arrays into place."""
        mesh = ObjectMesh.__new__(ObjectMesh)
        mesh.__dict__.update(self.__dict__)
        mesh.positions = as_array(positions, np.float32, (3,), "positions")
        mesh.normals = as_array(normals, np.float32, (3,), "normals")
        if len(mesh.positions) != len(self.positions) or len(mesh.normals) != len(self.normals):
            raise SceneDataError("a deformed mesh must keep its vertex and normal counts")
        if slots is not None:
            mesh.slots = as_array(slots, np.int32, (), "slots")
            if len(mesh.slots) != len(self.slots):
                raise SceneDataError("a deformed mesh must keep its triangle count")
        if uvs is not None:
            mesh.uvs = as_array(uvs, np.float32, (2,), "uvs")
            if self.uvs is None or len(mesh.uvs) != len(self.uvs):
                raise SceneDataError("a deformed mesh must keep its UV corners")
        if attributes is not None:
            mesh.attributes = _checked_attributes(attributes, len(self.slots))
        mesh.version = self.version + 1
        mesh._measure()
        return mesh


def _checked_attributes(attributes: dict[str, np.ndarray], triangles: int) -> dict[str, np.ndarray]:
    """Each attribute as (3 triangles, 4) float32 RGBA per corner."""
    out = {}
    for name, values in attributes.items():
        values = as_array(values, np.float32, (4,), f"attribute {name!r}")
        if len(values) != 3 * triangles:
            raise SceneDataError(f"attribute {name!r} has {len(values)} corners, the mesh {3 * triangles}")
        out[str(name)] = values
    return out


@dataclass
class Instances:
    """Where each object stands: ``mesh[k]`` indexes ``meshes``, ``matrices[k]`` is its
    object-to-world matrix, ``slot_materials[k]`` the scene material of each of its slots
    (a triangle whose slot is missing uses material 0, the grey fallback)."""

    meshes: list[ObjectMesh]
    mesh: np.ndarray  # (K,) int32
    matrices: np.ndarray  # (K, 4, 4) float32
    slot_materials: list[np.ndarray]  # K arrays of int32
    # Blender's random id of each instance (Object Info Random is it over 2^32 - 1, as in
    # Cycles); None: a hash of the instance's index stands in (scenes built without Blender).
    random_ids: np.ndarray | None = None  # (K,) uint32
    # Each instance's object colour (Object Info Color: the object's viewport display colour,
    # RGBA); None: white.
    colors: np.ndarray | None = None  # (K, 4) float32
    # Object and Instancer attributes (mesh_attributes.py): each instance's RGBA by
    # (source, name) key; None or missing keys read as mesh_attributes.MISSING.
    attributes: dict[tuple[str, str], np.ndarray] | None = None  # key -> (K, 4) float32

    def __post_init__(self) -> None:
        self.mesh = as_array(self.mesh, np.int32, (), "instance meshes")
        self.matrices = np.ascontiguousarray(np.asarray(self.matrices, np.float32).reshape(-1, 4, 4))
        k = len(self.mesh)
        if len(self.matrices) != k or len(self.slot_materials) != k:
            raise SceneDataError(f"{k} instances need {k} matrices and slot lists, got "
                                 f"{len(self.matrices)} and {len(self.slot_materials)}")
        if k and (self.mesh.min() < 0 or self.mesh.max() >= len(self.meshes)):
            raise SceneDataError("an instance names a mesh that is not in the list")
        self.slot_materials = [np.asarray(s, np.int32).reshape(-1) for s in self.slot_materials]
        if self.random_ids is not None:
            self.random_ids = np.asarray(self.random_ids, np.uint32).reshape(-1)
            if len(self.random_ids) != k:
                raise SceneDataError(f"{k} instances need {k} random ids, got {len(self.random_ids)}")
        if self.colors is not None:
            self.colors = as_array(self.colors, np.float32, (4,), "instance colours")
            if len(self.colors) != k:
                raise SceneDataError(f"{k} instances need {k} colours, got {len(self.colors)}")
        if self.attributes is not None:
            self.attributes = {key: as_array(v, np.float32, (4,), f"instance attribute {key!r}")
                               for key, v in self.attributes.items()}
            if any(len(v) != k for v in self.attributes.values()):
                raise SceneDataError(f"{k} instances need {k} values of each instance attribute")

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
