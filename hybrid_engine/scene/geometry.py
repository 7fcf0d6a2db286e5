# SPDX-License-Identifier: GPL-3.0-or-later
"""The scene's geometry: world-space triangles grouped by object, or instances of
object-space meshes, and the one conversion between them.

Every pass reads world-space triangles grouped by object, so that the near-cube culling
(paper §3.3) can test an object's box first and only then its triangles. They reach the GPU
one way only: as instances of object-space meshes, transformed there
(passes/scene_upload/instance_transform.py). The Blender adapter hands over an
``InstancedGeometry`` (meshes.py); a flat ``Geometry`` (builders, tests, the CPU oracles'
world-space arrays) is converted at the boundary by ``as_instances``: one instance per
object, its triangles as the mesh, under the identity. Kept from frame to frame, the
conversion re-makes only the objects whose triangles changed (compared bit for bit: a caller
may edit its arrays in place), so an animation re-sends only what moved.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .arrays import SceneDataError, as_array
from .meshes import MIRROR_CORNERS, Instances, ObjectMesh, normal_matrices, usable_vertices

@dataclass(frozen=True)
class GeometryEdit:
    """How a producer that keeps one geometry up to date (the Blender adapter's scene cache)
    made this version of it: ``generation`` counts its versions, and ``objects`` lists the
    objects whose rows it rewrote in place since ``generation - 1``, with the layout (object
    ranges, triangle count, UVs present) unchanged; None when it rebuilt the arrays. A
    consumer that uploaded ``generation - 1`` of the same ``source`` re-sends just those
    objects' rows instead of comparing every triangle (InstancedGeometry.from_world,
    InstanceTransformer.update)."""

    source: int
    generation: int
    objects: tuple[int, ...] | None = None


@dataclass
class Geometry:
    """World-space triangles of all visible objects, grouped by object.

    ``triangles[i]`` holds the three corners of triangle i; ``normals[i]`` the three shading
    normals (smooth, flat or custom split normals, already in world space); ``uvs`` is
    optional. ``object_ranges[k] = (first, count)`` are the triangles of object k and
    ``object_bounds[k] = (min, max)`` its AABB (NaN corners excluded). ``object_closed``
    (optional, (K,) bool) marks objects whose triangles form closed surfaces wound
    counter-clockwise seen from outside (:func:`hybrid_engine.scene.solids.closed_outward`): the
    raster passes skip their back faces, which an outside eye never sees. Marking an open
    or inward-wound object lets the background show through it; None marks none.
    """

    triangles: np.ndarray  # (N, 3, 3) float32
    normals: np.ndarray  # (N, 3, 3) float32
    material_ids: np.ndarray  # (N,) int32, index into MaterialTable
    object_ranges: np.ndarray  # (K, 2) int32
    object_bounds: np.ndarray  # (K, 2, 3) float32
    object_names: list[str] = field(default_factory=list)
    uvs: np.ndarray | None = None  # (N, 3, 2) float32
    object_closed: np.ndarray | None = None  # (K,) bool
    edit: GeometryEdit | None = None  # set by a producer that edits the arrays in place

    def __post_init__(self) -> None:
        self.triangles = as_array(self.triangles, np.float32, (3, 3), "triangles")
        self.normals = as_array(self.normals, np.float32, (3, 3), "normals")
        self.material_ids = as_array(self.material_ids, np.int32, (), "material_ids")
        self.object_ranges = as_array(self.object_ranges, np.int32, (2,), "object_ranges")
        self.object_bounds = as_array(self.object_bounds, np.float32, (2, 3), "object_bounds")
        n = len(self.triangles)
        if len(self.normals) != n or len(self.material_ids) != n:
            raise SceneDataError(
                f"triangles ({n}), normals ({len(self.normals)}) and material_ids "
                f"({len(self.material_ids)}) must have the same length"
            )
        if self.uvs is not None:
            self.uvs = as_array(self.uvs, np.float32, (3, 2), "uvs")
            if len(self.uvs) != n:
                raise SceneDataError(f"uvs has {len(self.uvs)} rows, triangles {n}")
        if len(self.object_ranges) != len(self.object_bounds):
            raise SceneDataError("object_ranges and object_bounds must have one row per object")
        if self.object_closed is not None:
            self.object_closed = np.asarray(self.object_closed, bool).reshape(-1)
            if len(self.object_closed) != len(self.object_ranges):
                raise SceneDataError(f"object_closed has {len(self.object_closed)} entries, "
                                     f"object_ranges {len(self.object_ranges)}")
        if len(self.object_ranges):
            ends = self.object_ranges[:, 0].astype(np.int64) + self.object_ranges[:, 1]
            if (self.object_ranges < 0).any() or ends.max() > n:
                raise SceneDataError("object_ranges point outside the triangle array")

    @property
    def triangle_count(self) -> int:
        return int(len(self.triangles))

    @property
    def has_uvs(self) -> bool:
        """Whether ``uvs`` is given (asked without making arrays that are made on demand)."""
        return self.uvs is not None

    def clamp_material_ids(self, count: int) -> None:
        """Documented fallback: ids outside a table of ``count`` materials (empty material
        slots) use material 0."""
        ids = self.material_ids
        if len(ids) and (ids.min() < 0 or ids.max() >= count):
            self.material_ids = np.where((ids >= 0) & (ids < count), ids, 0).astype(np.int32)

    def rows(self, first: int, count: int) -> "Geometry":
        """Triangles [first, first + count) as a Geometry of views (no copies, no objects):
        what per-triangle packers need to re-pack a changed range."""
        end = first + count
        return Geometry(
            triangles=self.triangles[first:end], normals=self.normals[first:end],
            material_ids=self.material_ids[first:end], object_ranges=np.zeros((0, 2), np.int32),
            object_bounds=np.zeros((0, 2, 3), np.float32),
            uvs=None if self.uvs is None else self.uvs[first:end],
        )

    def as_instances(self, previous: "InstancedGeometry | None" = None) -> "InstancedGeometry":
        """This geometry as one instance per object, under the identity, the object's
        triangles its mesh: the form in which every triangle reaches the GPU (module
        docstring). ``previous``, the conversion of the last frame's geometry, lends the
        meshes of the objects that did not change (``InstancedGeometry.from_world``)."""
        return InstancedGeometry.from_world(self, previous)

    @classmethod
    def empty(cls) -> "Geometry":
        return cls(
            triangles=np.zeros((0, 3, 3), np.float32),
            normals=np.zeros((0, 3, 3), np.float32),
            material_ids=np.zeros(0, np.int32),
            object_ranges=np.zeros((0, 2), np.int32),
            object_bounds=np.zeros((0, 2, 3), np.float32),
        )

    @classmethod
    def from_objects(
        cls,
        objects: list[tuple[np.ndarray, np.ndarray | None, np.ndarray | int]],
        names: list[str] | None = None,
    ) -> "Geometry":
        """Concatenate per-object (triangles, normals or None for flat, material ids)."""
        if not objects:
            return cls.empty()
        tris, norms, mats, ranges, bounds = [], [], [], [], []
        start = 0
        for obj_tris, obj_normals, obj_mats in objects:
            t = np.asarray(obj_tris, np.float32).reshape(-1, 3, 3)
            nrm = flat_normals(t) if obj_normals is None else np.asarray(obj_normals, np.float32)
            m = np.broadcast_to(np.asarray(obj_mats, np.int32), (len(t),))
            tris.append(t)
            norms.append(nrm.reshape(-1, 3, 3))
            mats.append(m)
            ranges.append((start, len(t)))
            bounds.append(finite_bounds(t))
            start += len(t)
        return cls(
            triangles=np.concatenate(tris),
            normals=np.concatenate(norms),
            material_ids=np.concatenate(mats),
            object_ranges=np.array(ranges, np.int32).reshape(-1, 2),
            object_bounds=np.array(bounds, np.float32).reshape(-1, 2, 3),
            object_names=list(names) if names else [f"object_{i}" for i in range(len(objects))],
        )


def flat_normals(triangles: np.ndarray) -> np.ndarray:
    """Per-corner normals equal to each face normal; zero-area faces get +Z (documented
    fallback so that shading never divides by zero)."""
    t = np.asarray(triangles, np.float32).reshape(-1, 3, 3)
    with np.errstate(invalid="ignore", over="ignore"):
        n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
        length = np.linalg.norm(n, axis=1, keepdims=True)
        ok = np.isfinite(length) & (length > 0)
        n = np.where(ok, n / np.where(ok, length, 1), np.array([0, 0, 1], np.float32))
    return np.repeat(n[:, None, :], 3, axis=1).astype(np.float32)


def finite_bounds(triangles: np.ndarray) -> np.ndarray:
    """AABB over the finite vertices (``usable_vertices``); an object with none gets an
    inverted (empty) box."""
    pts = np.asarray(triangles, np.float32).reshape(-1, 3)
    pts = pts[usable_vertices(pts)]
    if len(pts) == 0:
        return np.array([[np.inf] * 3, [-np.inf] * 3], np.float32)
    return np.stack([pts.min(axis=0), pts.max(axis=0)]).astype(np.float32)


class InstancedGeometry(Geometry):
    """A ``Geometry`` made of instances of object-space meshes (module docstring).

    ``triangles``, ``normals``, ``uvs`` and ``material_ids`` are the world-space arrays of
    ``Geometry``, made on the host only when read. ``edit`` works as for ``Geometry``: the
    producer lists the instances it changed since its last version.
    """

    # Set by ``from_world``: made from a flat geometry, and that geometry's edit (source,
    # generation), which the next frame's conversion follows.
    _from_world = False
    _world_edit: tuple[int, int] | None = None

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

    def as_instances(self, previous: "InstancedGeometry | None" = None) -> "InstancedGeometry":
        """Already instances: itself (``previous`` is not needed, the instance transform
        compares the instance table with the last one)."""
        return self

    @classmethod
    def from_world(cls, geometry: Geometry, previous: "InstancedGeometry | None" = None) -> "InstancedGeometry":
        """``geometry``'s objects as instances of meshes made of their own triangles (a
        triangle soup: three vertices and normals per triangle, its material id its slot,
        each instance's slot table the identity), under the identity matrix. The meshes
        hold copies of the arrays, so that a caller may edit its arrays in place.

        With ``previous`` (the last frame's conversion, of the same layout: object ranges,
        UVs present) an object whose rows are bit for bit the same keeps its mesh; any other
        gets its mesh deformed (same identity, next version: the GPU re-sends its arrays into
        place, and only its instance is transformed again). An object whose first triangle
        moved is taken as changed without reading the rest of it (in an animation nearly all
        of such an object's rows changed). A
        geometry that says which objects its producer rewrote (``Geometry.edit``, the
        version after the one ``previous`` was made from) has only those compared."""
        ranges = geometry.object_ranges.astype(np.int64)
        n = geometry.triangle_count
        if len(ranges) and not (ranges[0, 0] == 0 and (ranges[1:, 0] == ranges[:-1].sum(axis=1)).all()
                                and ranges[-1].sum() == n) or (not len(ranges) and n):
            raise SceneDataError("a geometry's object ranges must cover its triangles in order, one after "
                                 "the other, to be converted to instances")
        triangles, normals, materials, uvs = geometry.triangles, geometry.normals, geometry.material_ids, geometry.uvs
        closed = geometry.object_closed if geometry.object_closed is not None else np.zeros(len(ranges), bool)
        old = previous.instances.meshes if previous is not None and _same_layout(previous, geometry) else None
        candidates = _edited_objects(previous, geometry) if old is not None else None
        meshes = []
        for k, (first, count) in enumerate(ranges):
            end = first + count
            rows = (triangles[first:end], normals[first:end], materials[first:end],
                    None if uvs is None else uvs[first:end])
            kept = old[k] if old is not None else None
            if kept is not None and kept.closed == bool(closed[k]):
                if candidates is not None and k not in candidates:
                    meshes.append(kept)
                    continue
                if _soup_changed(kept, *rows):
                    meshes.append(kept.deformed(
                        np.array(rows[0], np.float32).reshape(-1, 3), np.array(rows[1], np.float32).reshape(-1, 3),
                        np.array(rows[2], np.int32), None if rows[3] is None else np.array(rows[3], np.float32)
                        .reshape(-1, 2)))
                else:
                    meshes.append(kept)
                continue
            meshes.append(_soup_mesh(*rows, closed=bool(closed[k])))
        k = len(meshes)
        # Every instance's slot table is the identity over the materials the geometry names
        # (a soup mesh's slots are its material ids): one length for all, so that an edited
        # material changes the instance table only when it names a new highest material.
        identity = np.arange(int(materials.max()) + 1 if len(materials) else 1, dtype=np.int32)
        instances = Instances(meshes=meshes, mesh=np.arange(k, dtype=np.int32),
                              matrices=np.broadcast_to(np.eye(4, dtype=np.float32), (k, 4, 4)),
                              slot_materials=[identity] * k)
        converted = cls(instances, geometry.object_names or None)
        converted._world_edit = (geometry.edit.source, geometry.edit.generation) if geometry.edit is not None else None
        converted._from_world = True
        return converted

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


# -- the conversion of flat geometry (InstancedGeometry.from_world) --------------------------------

def _same_layout(previous: InstancedGeometry, geometry: Geometry) -> bool:
    """Whether ``previous`` was converted from a geometry of ``geometry``'s layout."""
    return (previous._from_world and previous.triangle_count == geometry.triangle_count
            and previous.has_uvs == geometry.has_uvs
            and np.array_equal(previous.object_ranges, geometry.object_ranges))


def _edited_objects(previous: InstancedGeometry, geometry: Geometry) -> set[int] | None:
    """The objects to compare when ``geometry``'s producer says what it rewrote since the
    version ``previous`` was converted from; None: compare every object."""
    edit, last = geometry.edit, previous._world_edit
    if edit is None or last is None or last[0] != edit.source:
        return None
    if last[1] == edit.generation:
        return set()
    if last[1] == edit.generation - 1 and edit.objects is not None:
        return {int(k) for k in edit.objects}
    return None


def _words(array: np.ndarray) -> np.ndarray:
    """The bits of a float or int array, for comparing (NaN equals itself)."""
    return np.ascontiguousarray(array).reshape(-1).view(np.uint32)


def _soup_changed(mesh: ObjectMesh, triangles, normals, materials, uvs) -> bool:
    """Whether an object's rows differ from its soup mesh in any bit (the first triangle's
    corners and normals first: a moved object is found without reading the rest)."""
    if len(triangles) and (not np.array_equal(_words(mesh.positions[:3]), _words(triangles[0]))
                           or not np.array_equal(_words(mesh.normals[:3]), _words(normals[0]))):
        return True
    return not (np.array_equal(_words(mesh.positions), _words(triangles))
                and np.array_equal(_words(mesh.normals), _words(normals))
                and np.array_equal(_words(mesh.slots), _words(materials))
                and (uvs is None or np.array_equal(_words(mesh.uvs), _words(uvs))))


_corner_indices = np.zeros(0, np.int32)


def _corners(count: int) -> np.ndarray:
    """0, 1, ..., 3 count - 1: a soup mesh's corners index its vertices and normals in order
    (one shared array, grown as needed; meshes only read it)."""
    global _corner_indices
    if len(_corner_indices) < 3 * count:
        _corner_indices = np.arange(max(3 * count, 2 * len(_corner_indices)), dtype=np.int32)
        _corner_indices.flags.writeable = False
    return _corner_indices[:3 * count]


def _soup_mesh(triangles, normals, materials, uvs, *, closed: bool) -> ObjectMesh:
    """A mesh of an object's world-space rows, copied: three vertices and normals per triangle."""
    corners = _corners(len(triangles))
    return ObjectMesh(positions=np.array(triangles, np.float32).reshape(-1, 3),
                      corner_vertices=corners,
                      normals=np.array(normals, np.float32).reshape(-1, 3),
                      corner_normals=corners,
                      slots=np.array(materials, np.int32),
                      uvs=None if uvs is None else np.array(uvs, np.float32).reshape(-1, 2),
                      closed=closed)
