# SPDX-License-Identifier: GPL-3.0-or-later
"""Emissive triangles as lights: the table next-event estimation samples them by.

A diffuse gather that only finds emitters by hitting them with its cosine paths turns a
small bright emitter into fireflies and converges slowly; sampling a point on the emitters
and tracing one shadow ray to it (``gpu_shaders/include/emitter_light.glsl``) makes each
sample see them. The emitters are picked by power (area x luminance of the emission), so a
large lamp panel is sampled more than a dim indicator light.

The work is split by how often its inputs change:

* the host lists the world rows of the emissive triangles (those whose material's emission
  colour x strength is above 0) when the materials or the triangle set change, and keeps
  the list otherwise (``emissive_rows``, cached on what it depends on);
* every frame whose triangles or emission changed, the GPU reads those rows from the instance transform's world-space output,
  writes each emitter's corner, edges, area and power (``emitters/emitter_power.comp.glsl``),
  quantises the powers to integer weights against the frame's largest
  (``emitters/emitter_weights.comp.glsl``) and turns them into a CDF by the prefix scan
  (``gpu/prefix_scan.py``, in the shape ``gpu/variants.py`` picks for kernel ``scan``). A
  moving lamp therefore costs no host work. Emission textures count at their constant factor
  in the power; the sampled point reads the texture itself. A frame in which no triangle
  moved and no emission changed keeps the table as it is.

With no emissive material the table is empty: no host list, no dispatch, and
``emitter_irradiance`` returns 0 without tracing.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...gpu import shader_loader
from ...gpu.bindings import Bindings, Storage, bind
from ...gpu.dispatch import GrowBuffer, dispatch, storage_barrier
from ...gpu.prefix_scan import PrefixScan
from ...gpu.triangle_input import input_defines, input_split, input_storage
from ...scene.data import MaterialTable, SceneData
from ...scene.geometry import InstancedGeometry

LOCAL_SIZE = 64

# struct Emitter of emitter_layout.glsl (std430).
EMITTER_DTYPE = np.dtype([("corner", np.float32, 4), ("edge1", np.float32, 4), ("edge2", np.float32, 4)])
assert EMITTER_DTYPE.itemsize == 48

# The CDF's total is kept near this: the picking number has 24 bits (random.glsl), and each
# unit of weight should own many of its values, so that the probability a pick has equals
# the weight's share it is divided by to within a small fraction.
PICK_TOTAL = 1 << 20
# Weights are converted from floats on the GPU: at most 2^24 levels stay exact integers.
MAX_LEVELS = 1 << 24


def levels_for(count: int) -> int:
    """The integer weight of the most powerful of ``count`` emitters: the total stays near
    PICK_TOTAL (at most count x levels, below 2^32), and at least 1 (a scene of more
    emitters than PICK_TOTAL picks them uniformly, still without bias)."""
    return max(1, min(MAX_LEVELS, PICK_TOTAL // max(int(count), 1)))


def emissive_materials(materials: MaterialTable) -> np.ndarray:
    """Bool per material: its emission colour x strength is above 0 (a finite luminance)."""
    emission = np.asarray(materials.emission, np.float64)
    with np.errstate(invalid="ignore", over="ignore"):
        luminance = np.maximum(emission, 0.0) @ np.array([0.2126, 0.7152, 0.0722])
    return np.isfinite(luminance) & (luminance > 0.0)


def emissive_rows(geometry: InstancedGeometry, emissive: np.ndarray) -> np.ndarray:
    """The world rows (uint32, ascending) of the triangles whose material is emissive, as the
    instance transform assigns materials: an instance's slot material, material 0 for a
    missing slot (instance_transform.comp.glsl). Only instances with an emissive slot (or
    with missing slots, when material 0 emits) look at their triangles."""
    instances = geometry.instances
    if not emissive.any() or not len(instances):
        return np.zeros(0, np.uint32)
    flat, firsts, counts = instances.slot_table()
    known = (flat >= 0) & (flat < len(emissive))
    slot_emits = np.zeros(len(flat), bool)
    slot_emits[known] = emissive[flat[known]]
    fallback = bool(emissive[0])
    rows = []
    for k, (first, count) in enumerate(np.asarray(geometry.object_ranges, np.int64)):
        if count == 0:
            continue
        own = slot_emits[firsts[k]:firsts[k] + counts[k]]
        if not fallback and not own.any():
            continue
        slots = instances.meshes[instances.mesh[k]].slots[:count]
        valid = (slots >= 0) & (slots < counts[k])
        emits = np.full(len(slots), fallback)
        emits[valid] = own[slots[valid]]
        rows.append(first + np.flatnonzero(emits))
    return np.concatenate(rows).astype(np.uint32) if rows else np.zeros(0, np.uint32)


def _list_key(geometry: InstancedGeometry, emissive: np.ndarray) -> tuple:
    """What ``emissive_rows`` depends on: the emissive materials, the instances' meshes,
    slots and rows. Meshes are named by id and by their slot array's identity (a producer
    that edits a mesh's slots hands a new array; a deformation keeps it)."""
    instances = geometry.instances
    flat, firsts, counts = instances.slot_table()
    meshes = tuple((m.mesh_id, id(m.slots)) for m in instances.meshes)
    return (np.flatnonzero(emissive).tobytes(), meshes, instances.mesh.tobytes(),
            np.asarray(geometry.object_ranges).tobytes(), flat.tobytes(), np.asarray(firsts).tobytes(),
            np.asarray(counts).tobytes())


@dataclass
class EmitterStats:
    """What the last update did (tests, timing)."""

    listed: bool = False  # the host rebuilt the list of emissive rows
    gpu_steps: int = 0  # the table, the weights and the scan: 3 when rebuilt, else 0


class EmitterTable:
    """The emitters of the scene on the GPU and their CDF, kept from frame to frame.

    ``update(scene, world)`` once per frame after the instance transform; then
    ``bindings()`` is what a kernel compiled with ``EMITTER_LIGHT`` binds (storage blocks
    ``EmitterTriangles`` and ``EmitterCdf``, uniform ``u_emitter_count``), and ``count`` how
    many emitters it holds (0: none, and nothing to trace)."""

    def __init__(self, ctx, scan_family: str | None = None) -> None:
        self.ctx = ctx
        defines = {"LOCAL_SIZE": LOCAL_SIZE}
        self._weights = shader_loader.compute(ctx, "emitters/emitter_weights.comp.glsl", defines)
        self._scan = PrefixScan(ctx, scan_family)
        self._rows = GrowBuffer(ctx, "emitter rows")  # the emissive world rows (uint)
        self._table = GrowBuffer(ctx, "emitter table")  # Emitter per emissive row
        self._cdf = GrowBuffer(ctx, "emitter cdf")  # uint per emitter, and the total
        self._max = GrowBuffer(ctx, "emitter largest power")
        for buf in (self._table, self._cdf, self._max):
            buf.ensure(0)  # bound (unused) while the table is empty
        self._zero = np.zeros(1, np.uint32).tobytes()
        self._key: tuple | None = None
        self._key_refs: tuple = ()  # keeps the keyed slot arrays alive, so their ids stay theirs
        self._built_for: tuple | None = None  # the world and the emission the table was built from
        self.count = 0
        self.stats = EmitterStats()

    @property
    def scan_family(self) -> str:
        """The prefix scan's shape ("cpu" or "gpu")."""
        return self._scan.family

    def update(self, scene: SceneData, world, rows_unchanged: bool = False) -> None:
        """Bring the table up to this frame: the list of emissive rows when the materials or
        the triangle set changed (host), every emitter's power and the CDF (GPU). ``scene``
        holds the geometry as instances (the frame's ``scene``); ``world`` is the ``GPUScene``
        whose world-space rows the instance transform wrote. ``rows_unchanged``: the
        transform rewrote no row since the last update (the frame's ``GeometryDelta``), so
        with the same emission the table stands as it is and the GPU does nothing."""
        self.stats = EmitterStats()
        geometry = scene.geometry
        emissive = emissive_materials(scene.materials)
        if not emissive.any() or not isinstance(geometry, InstancedGeometry):
            self._key, self._key_refs, self.count, self._built_for = None, (), 0, None
            return
        key = _list_key(geometry, emissive)
        if key != self._key:
            rows = emissive_rows(geometry, emissive)
            self._rows.upload(rows.tobytes())
            self.count = len(rows)
            self._key, self._key_refs = key, tuple(m.slots for m in geometry.instances.meshes)
            self.stats.listed = True
        built_for = (id(world), np.ascontiguousarray(scene.materials.emission).tobytes())
        if self.count and not (rows_unchanged and not self.stats.listed and built_for == self._built_for):
            self._build(world)
            self._built_for = built_for

    def _build(self, world) -> None:
        """The GPU's part: rows, powers, weights and their scan."""
        count = self.count
        split = input_split(world.triangle_count)
        power = shader_loader.compute(self.ctx, "emitters/emitter_power.comp.glsl",
                                      {"LOCAL_SIZE": LOCAL_SIZE, **input_defines(split)})
        table = Storage(self._table.ensure(count * EMITTER_DTYPE.itemsize), count * EMITTER_DTYPE.itemsize)
        cdf = Storage(self._cdf.ensure((count + 1) * 4), (count + 1) * 4)
        self._max.write_at(self._zero, 0)
        bind(power, world.bindings(),
             storage={**input_storage(world.positions.buffer, split, self._rows.buffer),
                      "EmitterTriangles": table, "EmitterMax": self._max.buffer},
             uniforms={"u_count": count, "u_use_indices": 1})
        dispatch(power, count, LOCAL_SIZE)
        storage_barrier(self.ctx)
        bind(self._weights, storage={"EmitterTriangles": table, "EmitterMax": self._max.buffer, "EmitterCdf": cdf},
             uniforms={"u_count": count, "u_levels": levels_for(count)})
        dispatch(self._weights, count, LOCAL_SIZE)
        storage_barrier(self.ctx)
        self._scan.run(cdf, count)
        self.stats.gpu_steps = 3

    def bindings(self) -> Bindings:
        """What emitter_light.glsl binds, by name (the emitters' linking is the frame's
        lighting's: emitter_links.py)."""
        return Bindings(storage={"EmitterTriangles": self._table.buffer, "EmitterCdf": self._cdf.buffer},
                        uniforms={"u_emitter_count": int(self.count)})

    @property
    def defines(self) -> dict:
        """What a kernel that samples the table defines: ``EMITTER_LIGHT``, nothing when the
        table is empty."""
        return {"EMITTER_LIGHT": 1} if self.count else {}

    def read_table(self) -> np.ndarray:
        """The emitters' rows (EMITTER_DTYPE), read back now (tests)."""
        if not self.count:
            return np.zeros(0, EMITTER_DTYPE)
        raw = self._table.buffer.read(size=self.count * EMITTER_DTYPE.itemsize)
        return np.frombuffer(raw, EMITTER_DTYPE).copy()

    def read_cdf(self) -> np.ndarray:
        """The CDF (uint32[count + 1]: the exclusive prefix of the weights, the total last),
        read back now (tests)."""
        if not self.count:
            return np.zeros(1, np.uint32)
        return np.frombuffer(self._cdf.buffer.read(size=(self.count + 1) * 4), np.uint32).copy()

    def release(self) -> None:
        for buf in (self._rows, self._table, self._cdf, self._max):
            buf.release()
        self._scan.release()
        self.count = 0
        self._key, self._key_refs = None, ()
