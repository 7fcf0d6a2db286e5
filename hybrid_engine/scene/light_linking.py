# SPDX-License-Identifier: GPL-3.0-or-later
"""Light and shadow linking as Blender 4.0+ defines it, in the form Cycles renders it.

A lamp's receiver collection limits which objects it lights, its blocker collection which
objects cast its shadow. Blender (the depsgraph's light-linking cache) turns the collections
into *light sets*: each object gets the set of its linking (which emitter collections
include it, which exclude it; an object in none is in set 0, the default), and each emitter
a 64-bit mask of the sets it reaches. A lamp with INCLUDE entries reaches only the sets that
include it (never the default set: an object in no entry is left out); EXCLUDE entries take
their sets away; a lamp without a collection reaches every set.

Hybrid RT carries the sets in the material rows (``MaterialTable.light_set`` and
``shadow_set``: the adapter gives each linked object its own copies of its materials), so
that every place a surface is shaded (the G-buffer's pixels, the BVH's and the cube map's
hits, the lit cube map's texels) knows its set from the material id it already has, and the
lamp loop (gpu_shaders/include/lighting.glsl, ``LIGHT_LINKING``) skips the lamps whose
``Lights.light_mask`` lacks it. A lamp's shadow map draws only the objects whose blocker
set is in its ``Lights.shadow_mask`` (passes/shadow_maps/shadow_depth.py). A scene without
linking has every set 0 and every mask full, and compiles and runs as before.

Emissive objects are emitters too, as Cycles links its mesh lights: the sets are resolved
over the lamps and the objects with a collection of their own together, and an emissive
object's masks ride on its material rows (``MaterialTable.emitter_light_mask`` and
``emitter_shadow_mask``), which the emitter table's next-event estimate reads
(passes/emitters/emitter_links.py, ``EMITTER_LINKING``).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Hashable, Mapping, Sequence

import numpy as np

from .data import ALL_LINK_SETS, MAX_LINK_SETS, Lights, MaterialTable, SceneData

INCLUDE, EXCLUDE = "INCLUDE", "EXCLUDE"


@dataclass
class LinkSets:
    """One kind of linking (receivers or blockers) resolved: each linked object's set (an
    object absent here is in set 0) and each emitter's mask of the sets it reaches."""

    object_sets: dict[Hashable, int] = field(default_factory=dict)
    emitter_masks: list[int] = field(default_factory=list)
    overflow: bool = False  # more sets than MAX_LINK_SETS: the extra objects stay in set 0

    @property
    def linked(self) -> bool:
        return bool(self.object_sets) or any(m != int(ALL_LINK_SETS) for m in self.emitter_masks)


def resolve(emitter_collections: Sequence[Hashable | None],
            members: Mapping[Hashable, Sequence[tuple[Hashable, str]]]) -> LinkSets:
    """The sets of one kind of linking, as Blender's depsgraph builds them.

    ``emitter_collections[i]`` is emitter i's collection (its receiver or blocker
    collection; None: not linked). ``members[c]`` lists collection c's objects with their
    effective link state (INCLUDE or EXCLUDE) in Blender's order: its child collections'
    objects (each with the state of the child entry that reaches it) before its own, so a
    later entry of the same object wins. Emitters sharing a collection share its bit."""
    bits: dict[Hashable, int] = {}
    for collection in emitter_collections:
        if collection is not None and collection not in bits and len(bits) < MAX_LINK_SETS:
            bits[collection] = 1 << len(bits)
    # Per object: which emitter collections include it and which exclude it.
    include: dict[Hashable, int] = {}
    exclude: dict[Hashable, int] = {}
    for collection, bit in bits.items():
        for obj, state in members.get(collection, ()):
            inc, exc = include.get(obj, 0), exclude.get(obj, 0)
            if state == INCLUDE:
                inc, exc = inc | bit, exc & ~bit
            else:
                inc, exc = inc & ~bit, exc | bit
            include[obj], exclude[obj] = inc, exc
    result = LinkSets()
    set_ids: dict[tuple[int, int], int] = {}
    included_sets = dict.fromkeys(bits.values(), 0)
    excluded_sets = dict.fromkeys(bits.values(), 0)
    for obj in include:
        signature = (include[obj], exclude[obj])
        if signature not in set_ids:
            if len(set_ids) + 1 >= MAX_LINK_SETS:
                result.overflow = True
                continue
            set_ids[signature] = len(set_ids) + 1  # 0 is the default set
            set_bit = 1 << set_ids[signature]
            for bit in bits.values():
                if signature[0] & bit:
                    included_sets[bit] |= set_bit
                if signature[1] & bit:
                    excluded_sets[bit] |= set_bit
        result.object_sets[obj] = set_ids[signature]
    everything = int(ALL_LINK_SETS)
    for collection in emitter_collections:
        bit = bits.get(collection) if collection is not None else None
        if bit is None:
            result.emitter_masks.append(everything)
            continue
        reached = included_sets[bit] or everything
        result.emitter_masks.append(reached & ~excluded_sets[bit] & everything)
    return result


def is_linked(materials: MaterialTable, lights: Lights) -> bool:
    """Whether some lamp lights or shadows less than everything: only then do the shading
    passes compile the linking test (``LIGHT_LINKING``)."""
    return bool(materials.light_set.any() or (lights.light_mask != ALL_LINK_SETS).any())


def emission_linked(materials: MaterialTable) -> bool:
    """Whether some emissive row lights or is shadowed by less than every set: only then do
    the passes that gather the emitters' light compile their linking (``EMITTER_LINKING``)."""
    full = ALL_LINK_SETS
    masked = (materials.emitter_light_mask != full) | (materials.emitter_shadow_mask != full)
    if not masked.any():
        return False
    emission = np.nan_to_num(np.asarray(materials.emission, np.float64), nan=0.0)
    return bool((masked & (emission.max(axis=1) > 0.0)).any())


def shadow_linked(lights: Lights) -> bool:
    """Whether some lamp's shadow leaves some blocker set out."""
    return bool((lights.shadow_mask != ALL_LINK_SETS).any())


def object_shadow_sets(scene: SceneData) -> np.ndarray:
    """(K,) int32: the blocker set of each object of ``scene``'s geometry, read from the
    material of its first triangle (the adapter gives all of an object's slots its sets).
    Only for scenes whose shadows are linked: a loop over the instances."""
    materials = scene.materials
    geometry = scene.geometry
    instances = getattr(geometry, "instances", None)
    if instances is not None:
        first = np.zeros(len(instances), np.int64)
        for k, (mesh, slots) in enumerate(zip(instances.mesh, instances.slot_materials)):
            triangle_slots = instances.meshes[mesh].slots
            slot = int(triangle_slots[0]) if len(triangle_slots) else 0
            first[k] = slots[slot] if 0 <= slot < len(slots) else 0
    else:
        ranges = geometry.object_ranges
        first = np.zeros(len(ranges), np.int64)
        filled = ranges[:, 1] > 0
        first[filled] = geometry.material_ids[ranges[filled, 0]]
    first = np.where((first >= 0) & (first < len(materials)), first, 0)
    return materials.shadow_set[first]


def blockers(object_sets: np.ndarray, shadow_mask: int) -> np.ndarray:
    """Bool per object: its blocker set is among those ``shadow_mask`` holds."""
    bit = np.left_shift(np.uint64(1), object_sets.astype(np.uint64))
    return (np.bitwise_and(bit, np.uint64(shadow_mask)) != 0)


def mask_words(masks: np.ndarray) -> np.ndarray:
    """(L, 2) uint32: each 64-bit mask as its low and high words, as GLSL reads it."""
    masks = np.asarray(masks, np.uint64)
    return np.stack([(masks & np.uint64(0xFFFF_FFFF)).astype(np.uint32),
                     (masks >> np.uint64(32)).astype(np.uint32)], axis=1)
