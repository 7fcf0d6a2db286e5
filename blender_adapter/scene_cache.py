# SPDX-License-Identifier: GPL-3.0-or-later
"""Per-object extraction cache for the viewport.

``extract.extract_scene`` reads the whole depsgraph; the viewport cannot afford that on
every edit. This cache keeps, per object instance, the local mesh data read from Blender
(``extract._MeshData``) and its world-space arrays, and refreshes only what the depsgraph
says changed (``depsgraph.updates``):

- ``is_updated_geometry`` on an object or its mesh: the mesh is read again (modifiers, shape
  keys, armatures, geometry nodes and simulations all arrive this way, also on frame changes
  during playback);
- a new world matrix (moved, parented, animated): only the world-space arrays are rebuilt
  from the cached local data, no Blender mesh access;
- a material: its row of the material table is recomputed (the ids stay valid because the
  table keeps one row per material for the cache's lifetime);
- the world: the sky is read again; lights are re-read on every sync (a handful of values).

Every sync still walks ``depsgraph.object_instances`` once (cheap: no per-vertex work) so
that added, removed, hidden and instanced objects are seen without trusting the update list
for structure. The assembled ``SceneData`` is reused as long as nothing changed.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..hybrid_engine.scene_data import Lights, SceneData, Sky
from . import extract

# Depsgraph update id types (bpy.types names) and what they refresh.
_OBJECT, _MESH, _MATERIAL, _LIGHT, _WORLD, _SCENE = "Object", "Mesh", "Material", "Light", "World", "Scene"


@dataclass
class Changes:
    """What ``depsgraph.updates`` reported since the last sync (original datablock pointers)."""

    geometry: set[int] = field(default_factory=set)  # objects whose evaluated geometry changed
    meshes: set[int] = field(default_factory=set)  # mesh datablocks whose geometry changed
    transforms: set[int] = field(default_factory=set)
    materials: set[int] = field(default_factory=set)
    lights: bool = False
    world: bool = False
    scene: bool = False

    @classmethod
    def from_updates(cls, updates) -> "Changes":
        """Classify ``depsgraph.updates`` (an iterable of ``DepsgraphUpdate``)."""
        changes = cls()
        for update in updates:
            datablock = update.id
            kind = type(datablock).__name__
            original = getattr(datablock, "original", None) or datablock
            key = original.as_pointer()
            if kind == _OBJECT:
                if update.is_updated_geometry:
                    changes.geometry.add(key)
                if update.is_updated_transform:
                    changes.transforms.add(key)
            elif kind == _MESH and update.is_updated_geometry:
                changes.meshes.add(key)
            elif kind == _MATERIAL:
                changes.materials.add(key)
            elif kind == _LIGHT:
                changes.lights = True
            elif kind == _WORLD:
                changes.world = True
            elif kind == _SCENE:
                changes.scene = True
        return changes


@dataclass
class SyncReport:
    """What one sync did: names of instances whose mesh was read again (``extracted``) or
    whose world arrays were rebuilt from cached local data (``transformed``)."""

    extracted: list[str] = field(default_factory=list)
    transformed: list[str] = field(default_factory=list)
    reused: int = 0
    removed: int = 0
    materials_refreshed: int = 0
    sky_refreshed: bool = False
    changed: bool = False
    ms: float = 0.0


@dataclass
class _Entry:
    """One cached object instance."""

    name: str
    data: object  # extract._MeshData (shared by the instances of one mesh within a sync)
    matrix: np.ndarray
    slot_ids: np.ndarray
    arrays: object | None  # extract._ObjectArrays, None when the instance has no triangles


class _PersistentMaterials(extract._MaterialTableBuilder):
    """The extractor's material table, kept across syncs so cached material ids stay valid;
    a changed material's row is recomputed in place.

    Setting ``material.hybrid_rt.thickness`` from a script does not tag the depsgraph (no
    Material update arrives), so each sync also compares the stored thickness of every known
    material with its current value: one attribute read per material.
    """

    def __init__(self) -> None:
        super().__init__()
        self._originals: dict[int, object] = {}
        self._thickness: dict[int, float] = {}

    def index_of(self, material) -> int:
        index = super().index_of(material)
        if material is not None:
            key = material.original.as_pointer()
            if key not in self._originals:
                self._originals[key] = material.original
                self._thickness[key] = _thickness(material.original)
        return index

    def refresh(self, original_pointers: set[int]) -> int:
        """Recompute the rows of the given materials plus any whose thickness changed;
        returns how many rows were recomputed."""
        stale = set(original_pointers) & set(self._index)
        for key, material in list(self._originals.items()):
            try:
                if _thickness(material) != self._thickness[key]:
                    stale.add(key)
            except ReferenceError:  # the material was deleted: its row stays, unused
                del self._originals[key]
                stale.discard(key)
        for key in stale:
            material = self._originals.get(key)
            if material is None:
                continue
            self.rows[self._index[key]] = extract.material_params(material)
            self._thickness[key] = _thickness(material)
        return len(stale)


def _thickness(material) -> float:
    return float(getattr(getattr(material, "hybrid_rt", None), "thickness", extract.DEFAULT_THICKNESS))


def _instance_key(instance, obj) -> tuple:
    if instance.is_instance:
        parent = instance.parent.original.as_pointer() if instance.parent is not None else 0
        return ("instance", parent, tuple(instance.persistent_id), obj.original.as_pointer())
    return ("object", obj.original.as_pointer())


class SceneCache:
    """Cached extraction of one view layer's depsgraph (see module docstring)."""

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Forget everything; the next sync reads the whole scene."""
        self._entries: dict[tuple, _Entry] = {}
        self._order: list[tuple] = []
        self._materials = _PersistentMaterials()
        self._sky: Sky | None = None
        self._world_key: int | None = None
        self._lights = Lights.empty()
        self._scene: SceneData | None = None
        self.synced = False

    @property
    def scene_data(self) -> SceneData:
        if self._scene is None:
            raise RuntimeError("the scene cache has not been synced with a depsgraph yet")
        return self._scene

    def sync(self, depsgraph, changes: Changes | None = None, *, full: bool = False) -> SyncReport:
        """Bring the cache up to date with ``depsgraph``.

        ``changes`` defaults to ``Changes.from_updates(depsgraph.updates)``. ``full`` (or a
        first sync) reads every mesh again, for callers that cannot trust the update list.
        """
        start = time.perf_counter()
        if changes is None:
            changes = Changes.from_updates(depsgraph.updates)
        full = full or not self.synced
        report = SyncReport()
        dirty_objects = changes.geometry
        dirty_meshes = changes.meshes

        # Materials first: their rows must be current before instances look up their ids.
        report.materials_refreshed = self._materials.refresh(changes.materials)

        mesh_reads: dict[int, object] = {}  # evaluated mesh pointer -> _MeshData (this sync)
        seen: list[tuple] = []
        light_rows: list[dict] = []
        changed = full or bool(report.materials_refreshed)
        for instance in depsgraph.object_instances:
            if not instance.show_self:
                continue
            obj = instance.object  # valid during this iteration step only
            kind = obj.type
            if kind == "LIGHT" and obj.data.type in extract._LIGHT_TYPES:
                name = _instance_name(instance, obj)
                light_rows.append(extract._light_row(name, obj.data, np.array(instance.matrix_world, np.float64)))
                continue
            if kind != "MESH":
                continue  # curves/text/metaballs reach us as mesh instances of their evaluation
            key = _instance_key(instance, obj)
            seen.append(key)
            matrix = np.array(instance.matrix_world, np.float64)
            mesh = obj.data
            entry = self._entries.get(key)
            owner = instance.parent.original.as_pointer() if instance.is_instance and instance.parent else 0
            geometry_dirty = (
                full or entry is None
                or obj.original.as_pointer() in dirty_objects
                or owner in dirty_objects
                or mesh.original.as_pointer() in dirty_meshes
            )
            slot_ids = extract._slot_lookup(obj, mesh, self._materials)
            if geometry_dirty:
                mesh_key = mesh.as_pointer()
                if mesh_key not in mesh_reads:
                    mesh_reads[mesh_key] = extract._read_mesh(mesh)
                data = mesh_reads[mesh_key]
                arrays = extract._instance_arrays(_instance_name(instance, obj), data, matrix, slot_ids) if data else None
                self._entries[key] = _Entry(_instance_name(instance, obj), data, matrix, slot_ids, arrays)
                report.extracted.append(_instance_name(instance, obj))
                changed = True
            elif not np.array_equal(entry.matrix, matrix) or not np.array_equal(entry.slot_ids, slot_ids):
                entry.matrix, entry.slot_ids = matrix, slot_ids
                entry.arrays = extract._instance_arrays(entry.name, entry.data, matrix, slot_ids) if entry.data else None
                report.transformed.append(entry.name)
                changed = True
            else:
                report.reused += 1

        removed = set(self._entries) - set(seen)
        for key in removed:
            del self._entries[key]
        report.removed = len(removed)
        changed = changed or bool(removed) or seen != self._order
        self._order = seen

        lights = Lights.from_rows(light_rows)
        world = depsgraph.scene.world
        world_key = world.original.as_pointer() if world is not None else 0
        if full or changes.world or world_key != self._world_key or self._sky is None:
            self._sky = extract.extract_sky(world)
            self._world_key = world_key
            report.sky_refreshed = changed = True
        if changed or self._scene is None or not _same_lights(lights, self._lights):
            objects = [self._entries[k].arrays for k in seen if self._entries[k].arrays is not None]
            self._scene = SceneData(geometry=extract._geometry(objects), materials=self._materials.table(),
                                    lights=lights, sky=self._sky)
            changed = True
        self._lights = lights
        self.synced = True
        report.changed = changed
        report.ms = (time.perf_counter() - start) * 1e3
        return report


def _instance_name(instance, obj) -> str:
    if instance.is_instance:
        return f"{instance.parent.name}/{obj.name}" if instance.parent else obj.name
    return obj.name


def _same_lights(a: Lights, b: Lights) -> bool:
    if len(a) != len(b):
        return False
    for name in ("kind", "position", "direction", "color", "radius", "spot_size", "spot_blend", "cast_shadow"):
        if not np.array_equal(getattr(a, name, None), getattr(b, name, None)):
            return False
    return True
