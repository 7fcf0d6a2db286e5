# SPDX-License-Identifier: GPL-3.0-or-later
"""Lamps as Blender defines them: position, direction, colour times power (Exposure,
Temperature, Normalize), size and spot cone, as rows of ``hybrid_engine.scene.data.Lights``;
and their light and shadow linking (receiver and blocker collections, Blender 4.0+)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...hybrid_engine.scene.blackbody import blackbody_rgb
from ...hybrid_engine.scene.data import ALL_LINK_SETS
from ...hybrid_engine.scene.light_linking import resolve  # its INCLUDE, EXCLUDE: Blender's link_state names

LIGHT_TYPES = frozenset({"POINT", "SUN", "SPOT", "AREA"})


def _light_size(light) -> float:
    """Light.size of scene_data: point/spot radius, sun angular diameter (area lamps:
    ``_area_shape``)."""
    if light.type == "SUN":
        return float(getattr(light, "angle", 0.0))
    return float(getattr(light, "shadow_soft_size", 0.0))


def _area_shape(light, matrix: np.ndarray) -> dict:
    """An area lamp's shape in world space: half-sizes along its x and y axes (Size, and
    Size Y for a rectangle or ellipse, scaled with the object as Blender scales the lamp),
    its unit x axis and whether it is a disk or ellipse."""
    width = float(light.size)
    height = float(light.size_y) if light.shape in ("RECTANGLE", "ELLIPSE") else width
    x_axis, y_axis = matrix[:3, 0].astype(np.float64), matrix[:3, 1].astype(np.float64)
    x_scale, y_scale = float(np.linalg.norm(x_axis)), float(np.linalg.norm(y_axis))
    return dict(
        radius=0.5 * width * x_scale,
        area_size_y=0.5 * height * y_scale,
        area_axis=x_axis / x_scale if x_scale > 0 else np.array([1.0, 0.0, 0.0]),
        area_elliptic=light.shape in ("DISK", "ELLIPSE"),
    )


def _unnormalized_area(light) -> float:
    """What Blender multiplies a lamp's power by when Normalize is off: the emitting area
    (the disc of a point or spot radius, the sun's disc in the sky), 1 without one."""
    if light.type == "AREA":
        width = float(light.size)
        height = float(light.size_y) if light.shape in ("RECTANGLE", "ELLIPSE") else width
        area = width * height * (np.pi / 4.0 if light.shape in ("DISK", "ELLIPSE") else 1.0)
    elif light.type == "SUN":
        area = np.pi * np.tan(0.5 * float(getattr(light, "angle", 0.0))) ** 2
    else:
        area = np.pi * float(getattr(light, "shadow_soft_size", 0.0)) ** 2
    return area if area > 0.0 else 1.0


def light_color(light) -> np.ndarray:
    """The lamp's colour times its power as Blender defines it: Power or Strength, times
    2^Exposure, times the black-body colour of its Temperature when that is in use, times
    the emitting area when Normalize is off."""
    color = np.asarray(light.color, np.float64) * float(light.energy) * 2.0 ** float(getattr(light, "exposure", 0.0))
    if getattr(light, "use_temperature", False):
        color = color * np.asarray(blackbody_rgb(float(light.temperature)))
    if not getattr(light, "normalize", True):
        color = color * _unnormalized_area(light)
    return color.astype(np.float32)


def light_row(name: str, light, matrix: np.ndarray) -> dict:
    forward = -matrix[:3, 2]
    length = float(np.linalg.norm(forward))
    direction = forward / length if length > 0 else np.array([0.0, 0.0, -1.0])
    row = dict(
        kind=light.type,
        position=matrix[:3, 3],
        direction=direction,
        color=light_color(light),
        radius=_light_size(light),
        spot_size=float(getattr(light, "spot_size", np.pi / 4)),
        spot_blend=float(getattr(light, "spot_blend", 0.15)),
        cast_shadow=bool(getattr(light, "use_shadow", True)),
        name=name,
    )
    if light.type == "AREA":
        row.update(_area_shape(light, matrix))
    return row


@dataclass
class LampLinking:
    """The light and shadow linking of a depsgraph's emitters, by original pointers: each
    linked object's receiver and blocker set, each linked emitter's masks
    (scene/light_linking.py). Emitters are the lamps and, as in Cycles, the objects (an
    emissive mesh) with a receiver or blocker collection of their own: Blender builds the
    light sets over both together."""

    light_sets: dict[int, int] = field(default_factory=dict)
    shadow_sets: dict[int, int] = field(default_factory=dict)
    light_masks: dict[int, int] = field(default_factory=dict)
    shadow_masks: dict[int, int] = field(default_factory=dict)
    overflow: bool = False  # more than 64 sets: some objects stay in the default set

    def sets_of(self, pointer: int) -> tuple[int, int]:
        """An object's (receiver set, blocker set); (0, 0) unlinked."""
        return self.light_sets.get(pointer, 0), self.shadow_sets.get(pointer, 0)

    def masks_of(self, pointer: int) -> dict:
        """A lamp's masks as ``light_row`` keys (every set when it is not linked)."""
        everything = int(ALL_LINK_SETS)
        return dict(light_mask=self.light_masks.get(pointer, everything),
                    shadow_mask=self.shadow_masks.get(pointer, everything))

    def emitter_masks_of(self, pointer: int) -> tuple[int, int]:
        """An object's (light mask, shadow mask) as an emitter: what its emission lights and
        what shadows it (every set when it has no collection of its own)."""
        masks = self.masks_of(pointer)
        return masks["light_mask"], masks["shadow_mask"]

    def key(self) -> tuple:
        """Equal for equal linking: a sync whose key changed reads every instance again."""
        return tuple(tuple(sorted(d.items())) for d in (self.light_sets, self.shadow_sets, self.light_masks,
                                                        self.shadow_masks))


def _members(collection, state: str | None, out: list) -> None:
    """Collection's objects with their effective link state, in Blender's order (the
    depsgraph's light-linking cache): child collections first, each with the state of its
    entry in the linking collection (``state`` None: that top level), then the objects."""
    for entry, child in zip(collection.collection_children, collection.children):
        _members(child, state or entry.light_linking.link_state, out)
    for entry, obj in zip(collection.collection_objects, collection.objects):
        out.append((obj.original.as_pointer(), state or entry.light_linking.link_state))


def links_light(obj) -> bool:
    """Whether ``obj`` has a receiver or blocker collection of its own: a lamp that does is
    linked, and so is an object that does (as an emitter: its emission)."""
    links = getattr(obj, "light_linking", None)
    return links is not None and (getattr(links, "receiver_collection", None) is not None
                                  or getattr(links, "blocker_collection", None) is not None)


def read_linking(emitters) -> LampLinking | None:
    """The linking of ``emitters`` (evaluated lamp objects, and the objects with a collection
    of their own, ``links_light``), None when none has a receiver or blocker collection: the
    common scene pays one attribute read per lamp."""
    receivers, blockers, pointers = [], [], []
    for obj in emitters:
        links = getattr(obj, "light_linking", None)
        receivers.append(getattr(links, "receiver_collection", None))
        blockers.append(getattr(links, "blocker_collection", None))
        pointers.append(obj.original.as_pointer())
    if not any(receivers) and not any(blockers):
        return None
    linking = LampLinking()
    for collections, sets, masks in ((receivers, linking.light_sets, linking.light_masks),
                                     (blockers, linking.shadow_sets, linking.shadow_masks)):
        keys = [c.original.as_pointer() if c is not None else None for c in collections]
        members: dict[int, list] = {}
        for key, collection in zip(keys, collections):
            if collection is not None and key not in members:
                members[key] = []
                _members(collection.original, None, members[key])
        resolved = resolve(keys, members)
        linking.overflow |= resolved.overflow
        sets.update(resolved.object_sets)
        masks.update({p: m for p, m, k in zip(pointers, resolved.emitter_masks, keys) if k is not None})
    return linking
