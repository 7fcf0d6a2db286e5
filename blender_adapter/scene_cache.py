# SPDX-License-Identifier: GPL-3.0-or-later
"""The exporter: the evaluated depsgraph as ``SceneData``, re-read only where it changed.

Every path reads the scene through this cache: the viewport (one per view layer), a timing
report (``TrackedScene``), F12 (kept across renders with Persistent Data, ``engine.py``) and
a one-off read (``extract_scene``). It keeps, per object instance, the local mesh data read
from Blender (``export.meshes.MeshData``), its object-space mesh and its matrix, and refreshes only what
the depsgraph says changed (``depsgraph.updates``):

- ``is_updated_geometry`` on an object or its mesh: the mesh is read again (modifiers, shape
  keys, armatures, geometry nodes and simulations all arrive this way, also on frame changes
  during playback);
- a new world matrix (moved, parented, animated): only the instance's matrix changes; the
  GPU transforms its mesh (hybrid_engine/passes/scene_upload/instance_transform.py), no Blender mesh access and
  no pass over its vertices on the host;
- a material: its row of the material table is recomputed (the ids stay valid because the
  table keeps one row per material for the cache's lifetime);
- the world: the sky is read again; lights are re-read on every sync (a handful of values).

A sync walks ``depsgraph.object_instances`` once (no per-vertex work) so that added,
removed, hidden and instanced objects are seen without trusting the update list for
structure; only when nothing but cameras changed does it skip the walk, and the assembled
``SceneData`` is reused as long as nothing changed.

The geometry is an ``InstancedGeometry`` (hybrid_engine/scene/meshes.py, scene/geometry.py): each evaluated mesh
read once in object space and shared by its instances, and an instance table kept across
syncs. While the instances and their triangle counts stay the same, a sync writes the
matrices, meshes and slot materials of the instances it refreshed into the table in place
and says which (``Geometry.edit``); anything else (an object added, removed or re-ordered,
a changed triangle count or topology) builds the table anew.
"""
from __future__ import annotations

import itertools
import time
from dataclasses import dataclass, field

import numpy as np

from ..hybrid_engine.scene.geometry import InstancedGeometry
from ..hybrid_engine.scene.meshes import Instances, ObjectMesh
from ..hybrid_engine.scene.geometry import GeometryEdit
from ..hybrid_engine.scene.data import ALL_LINK_SETS, Lights, SceneData, Sky
from ..hybrid_engine.scene.mesh_attributes import MISSING, AttributeRequests
from ..hybrid_engine.scene.node_program import graph_requests
from . import messages
from .export import attributes as export_attributes
from .export import lights as export_lights
from .export import materials as export_materials
from .export import meshes as export_meshes
from .export import world as export_world

# Objects that emit through their materials and so may be emitters of light linking.
LINKABLE_OBJECTS = frozenset({"MESH"}) | export_meshes.CONVERTIBLE_TYPES
# Every light set: the masks of an object that is no emitter of its own (light_linking.py).
EVERY_SET = int(ALL_LINK_SETS)

# Depsgraph update id types (bpy.types names) and what they refresh.
_OBJECT, _MESH, _MATERIAL, _LIGHT, _WORLD, _SCENE = "Object", "Mesh", "Material", "Light", "World", "Scene"


@dataclass
class Changes:
    """What ``depsgraph.updates`` reported since the last sync (original datablock pointers)."""

    geometry: set[int] = field(default_factory=set)  # objects whose evaluated geometry changed
    meshes: set[int] = field(default_factory=set)  # mesh datablocks whose geometry changed
    transforms: set[int] = field(default_factory=set)
    materials: set[int] = field(default_factory=set)
    # Objects and meshes with any update (shading, a material slot, a transform, geometry):
    # only these can have changed their slots' materials.
    touched: set[int] = field(default_factory=set)
    cameras: set[int] = field(default_factory=set)  # camera objects among the updates
    lights: bool = False
    world: bool = False
    scene: bool = False
    # Every update moved or deformed an object or a mesh (or concerned cameras and actions):
    # nothing was added, removed, hidden or re-linked, so a sync may follow the known objects
    # without walking the instances (SceneCache._follow_moves).
    only_moves: bool = True
    # Only cameras changed (or nothing did): no datablock the exported scene is made of, so a
    # sync can skip its walk over the instances (a static scene seen by a moving camera).
    cameras_only: bool = True

    def merge(self, other: "Changes") -> None:
        """Add ``other``'s changes to these (updates that arrive in several batches before
        one sync: a frame change and the edits of a frame_change handler)."""
        self.geometry |= other.geometry
        self.meshes |= other.meshes
        self.transforms |= other.transforms
        self.materials |= other.materials
        self.touched |= other.touched
        self.lights = self.lights or other.lights
        self.world = self.world or other.world
        self.scene = self.scene or other.scene
        self.cameras_only = self.cameras_only and other.cameras_only
        self.cameras |= other.cameras
        self.only_moves = self.only_moves and other.only_moves

    @classmethod
    def from_updates(cls, updates) -> "Changes":
        """Classify ``depsgraph.updates`` (an iterable of ``DepsgraphUpdate``)."""
        changes = cls()
        for update in updates:
            datablock = update.id
            kind = type(datablock).__name__
            original = getattr(datablock, "original", None) or datablock
            key = original.as_pointer()
            if not _about_cameras(kind, datablock):
                changes.cameras_only = False
            elif kind == _OBJECT:
                changes.cameras.add(key)
            if kind in (_OBJECT, _MESH):
                changes.touched.add(key)
                if kind == _OBJECT and not (update.is_updated_transform or update.is_updated_geometry):
                    changes.only_moves = False  # visibility, a parent, a modifier's settings...
            elif kind not in ("Action", "Camera"):
                changes.only_moves = False
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


def _about_cameras(kind: str, datablock) -> bool:
    """Whether an update can only concern cameras: a camera object, camera data, or an action
    (its animated objects arrive as updates of their own)."""
    if kind == _OBJECT:
        return getattr(datablock, "type", None) == "CAMERA"
    return kind in ("Camera", "Action")


@dataclass
class SyncReport:
    """What one sync did: names of instances whose mesh was read again (``extracted``) or
    whose matrix or slot materials changed (``transformed``)."""

    extracted: list[str] = field(default_factory=list)
    transformed: list[str] = field(default_factory=list)
    reused: int = 0
    removed: int = 0
    rebuilt: bool = False  # the instance table was built anew (not edited in place)
    walked: bool = False  # the instances were visited (not skipped: Changes.cameras_only)
    materials_refreshed: int = 0
    sky_refreshed: bool = False
    changed: bool = False
    ms: float = 0.0


@dataclass
class _Entry:
    """One cached object instance."""

    name: str
    data: object  # export.meshes.MeshData (shared by the instances of one mesh within a sync)
    matrix: np.ndarray  # (4, 4) float64 object to world
    slot_ids: np.ndarray
    mesh: ObjectMesh | None  # None when the instance has no triangles
    # The original object of a plain mesh object (not an instance, not converted) and its
    # mesh's original pointer: what a sync that follows moves reads it again through.
    original: object = None
    mesh_original: int = 0
    random_id: int = 0  # Blender's, for Object Info Random (``_random_id``)
    color: tuple = (1.0, 1.0, 1.0, 1.0)  # the object's colour, for Object Info Color
    # Its Object and Instancer attributes that its materials' programs read (export/attributes.py).
    attributes: dict = field(default_factory=dict)


class _PersistentMaterials(export_materials.MaterialTableBuilder):
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
        # Light linking: (row, receiver set, blocker set, emitter light mask, emitter shadow
        # mask) -> the row's copy for objects of that linking
        # (hybrid_engine/scene/light_linking.py); none without linking.
        self._variants: dict[tuple[int, int, int, int, int], int] = {}
        self._requests: dict[bytes, AttributeRequests] = {}

    def linked(self, slot_ids: np.ndarray, light_set: int, shadow_set: int,
               emitter_masks: tuple[int, int] = (EVERY_SET, EVERY_SET)) -> np.ndarray:
        """``slot_ids`` for an object of the given linking sets, and of the given masks as an
        emitter (its emission's receivers and blockers): each row's copy carrying them, made
        once and refreshed with its row; the rows themselves for an unlinked object."""
        if light_set == 0 and shadow_set == 0 and emitter_masks == (EVERY_SET, EVERY_SET):
            return slot_ids
        out = np.empty_like(slot_ids)
        for i, index in enumerate(slot_ids):
            key = (int(index), light_set, shadow_set, *emitter_masks)
            if key not in self._variants:
                self._variants[key] = len(self.rows)
                self.rows.append(_linked_row(self.rows[key[0]], key))
            out[i] = self._variants[key]
        return out

    def requests(self, slot_ids: np.ndarray) -> AttributeRequests:
        """The attributes the programs of the materials ``slot_ids`` read: what a mesh that
        uses them must carry (scene/mesh_attributes.py). Kept per slot list until a
        material's row changes."""
        key = np.asarray(slot_ids, np.int32).tobytes()
        found = self._requests.get(key)
        if found is None:
            graphs = [self.rows[i].get("node_graph") for i in slot_ids if 0 <= i < len(self.rows)]
            found = self._requests[key] = graph_requests(graphs)
        return found

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
            self.rows[self._index[key]] = export_materials.material_params(material)
            self._thickness[key] = _thickness(material)
            self._requests.clear()
        rows = {self._index[key] for key in stale}
        for key, row in self._variants.items():
            if key[0] in rows:
                self.rows[row] = _linked_row(self.rows[key[0]], key)
        return len(stale)


def _linked_row(row: dict, key: tuple) -> dict:
    """A material row's copy for the objects of one linking: ``key`` is (row, receiver set,
    blocker set, emitter light mask, emitter shadow mask)."""
    _, light_set, shadow_set, light_mask, shadow_mask = key
    return {**row, "light_set": light_set, "shadow_set": shadow_set,
            "emitter_light_mask": light_mask, "emitter_shadow_mask": shadow_mask}


def _thickness(material) -> float:
    return float(getattr(getattr(material, "hybrid_rt", None), "thickness", export_materials.DEFAULT_THICKNESS))


def _instance_key(instance, obj) -> tuple:
    if instance.is_instance:
        parent = instance.parent.original.as_pointer() if instance.parent is not None else 0
        return ("instance", parent, tuple(instance.persistent_id), obj.original.as_pointer())
    return ("object", obj.original.as_pointer())


class SceneCache:
    """Cached extraction of one view layer's depsgraph (see module docstring)."""

    def __init__(self) -> None:
        self.reset()

    _sources = itertools.count(1)  # tells caches apart in Geometry.edit

    def reset(self) -> None:
        """Forget everything; the next sync reads the whole scene."""
        self._source = next(SceneCache._sources)
        self._generation = 0
        self._geometry: InstancedGeometry | None = None
        self._rows: dict[tuple, int] = {}  # instance key -> object index in self._geometry
        self._mesh_index: dict[int, int] = {}  # mesh id -> index in the instance table's meshes
        self._producers: set[int] = set()  # originals whose geometry arrives as instances
        self._entries: dict[tuple, _Entry] = {}
        self._order: list[tuple] = []
        self._materials = _PersistentMaterials()
        self._sky: Sky | None = None
        self._world_key: int | None = None
        self._lights = Lights.empty()
        self._linking: export_lights.LampLinking | None = None  # this sync's light linking
        self._link_key: tuple | None = None
        self._relink = False  # the linking changed: every instance's slots are looked up again
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

        # Materials first: their rows must be current before instances look up their ids.
        report.materials_refreshed = self._materials.refresh(changes.materials)
        if not full and changes.cameras_only and not report.materials_refreshed and self._scene is not None:
            report.reused = len(self._order)
            report.ms = (time.perf_counter() - start) * 1e3
            return report
        if not full and changes.only_moves and not report.materials_refreshed and self._scene is not None:
            if self._follow_moves(depsgraph, changes, report):
                report.ms = (time.perf_counter() - start) * 1e3
                return report
        report.walked = True
        # Emitters of the linking: the lamps, and the objects with collections of their own
        # (an emissive mesh's light, as Cycles links it).
        self._linking = export_lights.read_linking(
            o for o in depsgraph.objects
            if o.type == "LIGHT" or (o.type in LINKABLE_OBJECTS and export_lights.links_light(o)))
        if self._linking is not None and self._linking.overflow:
            messages.tell("Light Linking: more than 64 different linkings (Blender's limit of light sets); "
                          "the objects past it are lit and shadowed by every lamp")
        link_key = self._linking.key() if self._linking is not None else None
        self._relink = link_key != self._link_key
        self._link_key = link_key

        mesh_reads: dict[int, object] = {}  # evaluated mesh pointer -> _MeshData (this sync)
        seen: list[tuple] = []
        refreshed: list[tuple] = []  # instances whose mesh, matrix or slots changed
        producers: set[int] = set()  # originals whose geometry arrived as mesh instances
        convertible: list[tuple] = []  # (key, original, matrix, name) of curves/text/metaballs
        light_rows: list[dict] = []
        changed = full or bool(report.materials_refreshed)
        for instance in depsgraph.object_instances:
            if not instance.show_self:
                continue
            obj = instance.object  # valid during this iteration step only
            kind = obj.type
            if kind == "LIGHT" and obj.data.type in export_lights.LIGHT_TYPES:
                name = _instance_name(instance, obj)
                row = export_lights.light_row(name, obj.data, np.array(instance.matrix_world, np.float64))
                if self._linking is not None:
                    row.update(self._linking.masks_of(obj.original.as_pointer()))
                light_rows.append(row)
                continue
            if kind in export_meshes.CONVERTIBLE_TYPES and not instance.is_instance:
                # Curves, text and metaballs usually evaluate to mesh instances (below);
                # those that did not are converted after the walk.
                convertible.append((_instance_key(instance, obj), obj.original,
                                    np.array(instance.matrix_world, np.float64), _instance_name(instance, obj)))
                continue
            if kind != "MESH":
                continue
            if instance.is_instance and instance.parent is not None:
                producers.add(instance.parent.original.as_pointer())
            key = _instance_key(instance, obj)
            seen.append(key)
            owner = instance.parent.original.as_pointer() if instance.is_instance and instance.parent else 0
            changed |= self._visit(key, _instance_name(instance, obj), obj, obj.data,
                                   np.array(instance.matrix_world, np.float64), full, changes, owner,
                                   mesh_reads, report, refreshed)
            entry = self._entries[key]
            entry.random_id = _random_id(instance, obj)
            # An instance shows its instancer's colour, as in Cycles: the depsgraph gives
            # a collection's instances their instancer's, but a particle system's its
            # instanced object's own.
            entry.color = tuple((instance.parent if instance.is_instance and instance.parent else obj).color)
            wanted = self._materials.requests(entry.slot_ids).instance
            if wanted or entry.attributes:
                values = export_attributes.instance_values(
                    wanted, obj, instance.parent if instance.is_instance else None)
                if values != entry.attributes:
                    entry.attributes = values
                    changed = True
                    if key not in refreshed:
                        refreshed.append(key)
            if not instance.is_instance:
                entry = self._entries[key]
                entry.original, entry.mesh_original = obj.original, obj.data.original.as_pointer()

        for key, original, matrix, name in convertible:
            if original.as_pointer() in producers:
                continue
            evaluated = original.evaluated_get(depsgraph)
            entry = self._entries.get(key)
            if not (full or entry is None or original.as_pointer() in dirty_objects):
                seen.append(key)  # unchanged: no conversion needed
                changed |= self._visit(key, name, evaluated, None, matrix, False, changes, 0, mesh_reads,
                                       report, refreshed)
                self._entries[key].random_id = _lookup3_pair(_name_hash(original.name), 0)
                continue
            try:
                mesh = evaluated.to_mesh()
            except RuntimeError as error:
                messages.tell(f"{name}: cannot convert to a mesh ({error}); skipped")
                continue
            try:  # to_mesh() data is temporary: read at once, released at once
                if mesh is not None:
                    seen.append(key)
                    changed |= self._visit(key, name, evaluated, mesh, matrix, True, changes, 0, {},
                                           report, refreshed)
                    self._entries[key].random_id = _lookup3_pair(_name_hash(original.name), 0)
            finally:
                evaluated.to_mesh_clear()

        removed = set(self._entries) - set(seen)
        for key in removed:
            del self._entries[key]
        report.removed = len(removed)
        same_instances = seen == self._order and not removed
        changed = changed or not same_instances
        self._order = seen
        self._producers = producers

        lights = Lights.from_rows(light_rows)
        world = depsgraph.scene.world
        world_key = world.original.as_pointer() if world is not None else 0
        if full or changes.world or world_key != self._world_key or self._sky is None:
            self._sky = export_world.extract_sky(world)
            self._world_key = world_key
            report.sky_refreshed = changed = True
        if changed or self._scene is None or not _same_lights(lights, self._lights):
            edited = same_instances and self._edit_in_place(refreshed)
            if not edited:
                self._rebuild(seen)
                report.rebuilt = True
            self._scene = SceneData(geometry=self._geometry, materials=self._materials.table(),
                                    lights=lights, sky=self._sky)
            changed = True
        self._lights = lights
        self._relink = False
        self.synced = True
        report.changed = changed
        report.ms = (time.perf_counter() - start) * 1e3
        return report


    def instance_matrices(self, depsgraph) -> np.ndarray:
        """The matrices (K, 4, 4) of the kept instance table as ``depsgraph`` has them now: a
        walk that reads matrices only, nothing of a mesh, for motion blur's sub-frame steps
        (export/motion.py). An instance the table does not hold is ignored; one that is gone
        keeps the table's matrix."""
        if self._geometry is None:
            return np.zeros((0, 4, 4))
        matrices = self._geometry.instances.matrices.astype(np.float64)
        for instance in depsgraph.object_instances:
            if not instance.show_self:
                continue
            obj = instance.object
            if obj.type != "MESH" and obj.type not in export_meshes.CONVERTIBLE_TYPES:
                continue
            row = self._rows.get(_instance_key(instance, obj))
            if row is not None:
                matrices[row] = np.array(instance.matrix_world, np.float64)
        return matrices

    def deformed_arrays(self, depsgraph) -> tuple[dict[int, tuple[np.ndarray, np.ndarray]], list[str]]:
        """The vertex positions and normals, as ``depsgraph`` has them now, of the kept meshes
        whose geometry its last evaluation changed (motion blur's sub-frame steps,
        export/motion.py), by their index in the instance table's mesh list; and the names of
        those that cannot be read so (a new topology, an instancer's mesh, non-finite
        vertices)."""
        arrays: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        unread: list[str] = []
        if self._geometry is None:
            return arrays, unread
        instances = self._geometry.instances
        for update in depsgraph.updates:
            obj = update.id
            # An object (a mesh datablock has no ``data``) whose evaluated geometry changed.
            if not update.is_updated_geometry or getattr(obj, "type", None) != "MESH" or not hasattr(obj, "data"):
                continue
            key = ("object", obj.original.as_pointer())
            obj = obj.original.evaluated_get(depsgraph)
            entry, row = self._entries.get(key), self._rows.get(key)
            if entry is None or row is None or entry.mesh is None:
                continue
            index = int(instances.mesh[row])
            data = export_meshes.reread_deformed(obj.data, entry.data)
            base = instances.meshes[index]
            if (data is None or not np.isfinite(data.positions).all() or data.positions.shape != base.positions.shape
                    or data.normals.shape != base.normals.shape):
                unread.append(entry.name)
                continue
            arrays[index] = (np.array(data.positions, np.float32), np.array(data.normals, np.float32))
        return arrays, unread

    def _follow_moves(self, depsgraph, changes: Changes, report: SyncReport) -> bool:
        """Refresh the moved and deformed objects without walking the instances, when every
        one of them is a plain mesh object this cache knows (not a light, not an instancer,
        not converted) and every updated mesh is one of theirs; False (nothing done) when
        the walk is needed. A frame of an animation that moves some objects among many
        instances costs those objects, not the instances."""
        moved = (changes.transforms | changes.geometry) - changes.cameras
        entries = []
        for pointer in moved:
            key = ("object", pointer)
            entry = self._entries.get(key)
            if entry is None or entry.original is None or pointer in self._producers:
                return False
            entries.append((key, entry))
        meshes = {entry.mesh_original for _, entry in entries}
        if (changes.touched - moved - changes.cameras) - meshes:
            return False  # a mesh (or an object) updated on its own: walk
        refreshed: list[tuple] = []
        mesh_reads: dict[int, object] = {}
        changed = False
        for key, entry in entries:
            try:
                evaluated = entry.original.evaluated_get(depsgraph)
            except ReferenceError:
                return False  # deleted since: the walk sees it gone
            if evaluated.type != "MESH":
                return False
            changed |= self._visit(key, entry.name, evaluated, evaluated.data,
                                   np.array(evaluated.matrix_world, np.float64), False, changes, 0,
                                   mesh_reads, report, refreshed)
        report.reused = len(self._order) - len(refreshed)
        if changed:
            if not self._edit_in_place(refreshed):
                self._rebuild(self._order)
                report.rebuilt = True
            self._scene = SceneData(geometry=self._geometry, materials=self._materials.table(),
                                    lights=self._lights, sky=self._sky)
        report.changed = changed
        return True

    def _visit(self, key: tuple, name: str, obj, mesh, matrix: np.ndarray, full: bool, changes: Changes,
               owner: int, mesh_reads: dict, report: SyncReport, refreshed: list[tuple]) -> bool:
        """Bring one instance's entry up to date; True when its mesh, matrix or slots changed.
        ``mesh`` None: the entry's mesh is known unchanged (a converted object)."""
        entry = self._entries.get(key)
        geometry_dirty = mesh is not None and (
            full or entry is None
            or obj.original.as_pointer() in changes.geometry
            or owner in changes.geometry
            or mesh.original.as_pointer() in changes.meshes
        )
        touched = (geometry_dirty or entry is None or obj.original.as_pointer() in changes.touched
                   or owner in changes.touched or self._relink
                   or (mesh is not None and mesh.original.as_pointer() in changes.touched))
        slot_ids = export_materials.slot_lookup(obj, mesh if mesh is not None else obj.data, self._materials) \
            if (mesh is not None or entry is None or self._relink) and touched else entry.slot_ids
        if self._linking is not None and slot_ids is not getattr(entry, "slot_ids", None):
            pointer = obj.original.as_pointer()
            slot_ids = self._materials.linked(slot_ids, *self._linking.sets_of(pointer),
                                              self._linking.emitter_masks_of(pointer))
        # The attributes its materials' programs read (none: nothing read); a new request
        # (a Color Attribute node added) reads the mesh's attributes again.
        names = self._materials.requests(slot_ids).geometry
        if (mesh is not None and entry is not None and entry.data is not None
                and entry.data.attribute_names != names):
            geometry_dirty = True
        if geometry_dirty:
            mesh_key = (mesh.as_pointer(), names)
            if mesh_key not in mesh_reads:
                # A deformed mesh keeps its topology: only positions and normals (and the
                # requested attributes) are read again (never on a full sync, which trusts
                # nothing kept).
                kept = None if full or entry is None else export_meshes.reread_deformed(mesh, entry.data, names)
                data = kept if kept is not None else export_meshes.read_mesh(mesh, names)
                previous = entry.mesh if kept is not None else None
                mesh_reads[mesh_key] = (data, export_meshes.object_mesh(name, data, previous) if data else None)
            data, object_mesh = mesh_reads[mesh_key]
            self._entries[key] = _Entry(name, data, matrix, slot_ids, object_mesh,
                                        *((entry.original, entry.mesh_original) if entry is not None else ()))
            if entry is not None:
                self._entries[key].attributes = entry.attributes
            report.extracted.append(name)
        elif (entry.matrix.tobytes() != matrix.tobytes()
              or (slot_ids is not entry.slot_ids and not np.array_equal(entry.slot_ids, slot_ids))):
            entry.matrix, entry.slot_ids = matrix, slot_ids
            report.transformed.append(entry.name)
        else:
            report.reused += 1
            return False
        refreshed.append(key)
        return True

    def _rebuild(self, order: list[tuple]) -> None:
        """Build the instance table from every instance's entry (a new layout)."""
        keys = [k for k in order if self._entries[k].mesh is not None]
        meshes: dict[int, int] = {}  # mesh id -> index in the list
        mesh_list: list[ObjectMesh] = []
        for key in keys:
            mesh = self._entries[key].mesh
            if mesh.mesh_id not in meshes:
                meshes[mesh.mesh_id] = len(mesh_list)
                mesh_list.append(mesh)
        entries = [self._entries[k] for k in keys]
        instances = Instances(meshes=mesh_list, mesh=np.array([meshes[e.mesh.mesh_id] for e in entries], np.int32),
                              matrices=np.array([e.matrix for e in entries], np.float32).reshape(-1, 4, 4),
                              slot_materials=[e.slot_ids for e in entries],
                              random_ids=np.array([e.random_id for e in entries], np.uint32),
                              colors=np.array([e.color for e in entries], np.float32).reshape(-1, 4),
                              attributes=_instance_attributes(entries))
        self._rows = {k: i for i, k in enumerate(keys)}
        self._mesh_index = meshes
        self._generation += 1
        self._geometry = InstancedGeometry(instances, [e.name for e in entries],
                                           edit=GeometryEdit(self._source, self._generation, None))

    def _edit_in_place(self, refreshed: list[tuple]) -> bool:
        """Write the refreshed instances into the kept table; False (nothing written) when
        one of them no longer fits its rows (another triangle count or topology)."""
        geometry = self._geometry
        if geometry is None:
            return False
        instances = geometry.instances
        updates = []
        for key in refreshed:
            entry, row = self._entries[key], self._rows.get(key)
            if row is None and entry.mesh is None:
                continue  # still without triangles
            if row is None or entry.mesh is None:
                return False
            index = self._mesh_index.get(entry.mesh.mesh_id)
            if index is None or index != instances.mesh[row]:
                return False
            kept = instances.meshes[index]
            if kept is not entry.mesh and (kept.triangle_count != entry.mesh.triangle_count
                                           or (kept.uvs is None) != (entry.mesh.uvs is None)):
                return False
            if set(entry.attributes) - set(instances.attributes or {}):
                return False  # a key no instance had: the table's attributes are laid out anew
            updates.append((row, entry))
        for row, entry in updates:
            instances.meshes[instances.mesh[row]] = entry.mesh  # a deformed version, or itself
            instances.matrices[row] = entry.matrix
            if instances.colors is not None:
                instances.colors[row] = entry.color
            if not np.array_equal(instances.slot_materials[row], entry.slot_ids):
                instances.set_slots(row, entry.slot_ids)
            for attribute_key, values in (instances.attributes or {}).items():
                values[row] = entry.attributes.get(attribute_key, MISSING)
        rows = sorted(r for r, _ in updates)
        geometry.refresh(rows)
        self._generation += 1
        geometry.edit = GeometryEdit(self._source, self._generation, tuple(rows))
        return True


class TrackedScene:
    """A cache kept in sync over the frames of one job (a timing report) from what Blender
    tells its ``depsgraph_update_post`` and ``frame_change_post`` handlers: outside them
    ``depsgraph.updates`` is empty, so the changes are gathered where Blender gives them and
    applied at the next frame. The first frame, or a frame of another depsgraph, reads
    everything."""

    def __init__(self) -> None:
        self.cache = SceneCache()
        self.last_sync: SyncReport | None = None
        self._pending = Changes()
        self._depsgraph: int | None = None
        self._listening = False

    def listen(self) -> None:
        """Start gathering changes (idempotent); ``close`` stops."""
        if self._listening:
            return
        import bpy  # here, not at import: the cache itself needs only the depsgraph it is given

        for handlers in (bpy.app.handlers.depsgraph_update_post, bpy.app.handlers.frame_change_post):
            handlers.append(self._on_update)
        self._listening = True

    def close(self) -> None:
        """Stop gathering changes and let the cached arrays go."""
        if self._listening:
            import bpy

            for handlers in (bpy.app.handlers.depsgraph_update_post, bpy.app.handlers.frame_change_post):
                if self._on_update in handlers:
                    handlers.remove(self._on_update)
            self._listening = False
        self.cache.reset()
        self._depsgraph = None
        self._pending = Changes()

    def _on_update(self, _scene, depsgraph) -> None:
        if self._depsgraph is None or depsgraph.as_pointer() == self._depsgraph:
            self._pending.merge(Changes.from_updates(depsgraph.updates))

    def scene_data(self, depsgraph) -> SceneData:
        """The scene of ``depsgraph`` now, synced with the changes gathered since the last."""
        key = depsgraph.as_pointer()
        changes, self._pending = self._pending, Changes()
        self.last_sync = self.cache.sync(depsgraph, changes, full=key != self._depsgraph)
        self._depsgraph = key
        return self.cache.scene_data


def _instance_attributes(entries: list[_Entry]) -> dict | None:
    """Instances.attributes of the entries: each key any of them carries, MISSING where one
    does not; None when none carries any (no cost for scenes that read none)."""
    keys = sorted({key for e in entries for key in e.attributes})
    if not keys:
        return None
    return {key: np.array([e.attributes.get(key, MISSING) for e in entries], np.float32).reshape(-1, 4)
            for key in keys}


def extract_scene(depsgraph) -> SceneData:
    """Everything visible in the evaluated depsgraph as plain arrays, read from scratch: a
    sync of a new cache, so a one-off read and every kept cache export alike.

    Objects without faces contribute nothing; triangles with non-finite vertices are
    skipped with a warning; empty material slots use material 0 (the grey fallback).
    """
    cache = SceneCache()
    cache.sync(depsgraph, Changes(), full=True)
    return cache.scene_data


def _name_hash(name: str) -> int:
    """Cycles' hash of a string: each byte added to 37 times the running value, modulo 2^32."""
    value = 0
    for byte in name.encode("utf-8"):
        value = (value * 37 + byte) & 0xFFFFFFFF
    return value


def _random_id(instance, obj) -> int:
    """An instance's random id as Cycles takes it for Object Info Random: the depsgraph's for
    an instance (geometry nodes, collections, particles), and for an object itself Blender's
    hash of its name (lookup3 of the name's hash and 0), so an object keeps its Random from
    frame to frame and from render to render."""
    if instance.is_instance:
        return int(instance.random_id) & 0xFFFFFFFF
    return int(_lookup3_pair(_name_hash(obj.name), 0))


def _lookup3_pair(x: int, y: int) -> int:
    """Bob Jenkins' lookup3 of two words (gpu_shaders/include/nodes/hash.glsl hash_uint2)."""
    mask = 0xFFFFFFFF

    def rot(v: int, k: int) -> int:
        return ((v << k) | (v >> (32 - k))) & mask

    a = b = c = (0xDEADBEEF + (2 << 2) + 13) & mask
    b = (b + y) & mask
    a = (a + x) & mask
    c ^= b; c = (c - rot(b, 14)) & mask  # noqa: E702 - lookup3's final mix, step by step
    a ^= c; a = (a - rot(c, 11)) & mask  # noqa: E702
    b ^= a; b = (b - rot(a, 25)) & mask  # noqa: E702
    c ^= b; c = (c - rot(b, 16)) & mask  # noqa: E702
    a ^= c; a = (a - rot(c, 4)) & mask  # noqa: E702
    b ^= a; b = (b - rot(a, 14)) & mask  # noqa: E702
    c ^= b; c = (c - rot(b, 24)) & mask  # noqa: E702
    return c


def _instance_name(instance, obj) -> str:
    if instance.is_instance:
        return f"{instance.parent.name}/{obj.name}" if instance.parent else obj.name
    return obj.name


def _same_lights(a: Lights, b: Lights) -> bool:
    if len(a) != len(b):
        return False
    for name in ("kind", "position", "direction", "color", "radius", "spot_size", "spot_blend", "cast_shadow",
                 "light_mask", "shadow_mask"):
        if not np.array_equal(getattr(a, name, None), getattr(b, name, None)):
            return False
    return True
