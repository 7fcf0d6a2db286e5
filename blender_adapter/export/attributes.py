# SPDX-License-Identifier: GPL-3.0-or-later
"""Attribute nodes' Object and Instancer values: one RGBA per instance, looked up as Blender
looks them up for Cycles and EEVEE (``BKE_object_dupli_find_rgba_attribute``).

The name is a custom property (``obj["name"]``) or a property path (``color``,
``location``) of an ID: for Object, the object and then its data (the mesh); for Instancer,
the instancer first (the object whose collection, particles or geometry nodes made the
instance), then the object and its data. A number is (v, v, v, 1), an array of up to four
numbers fills RGBA over (0, 0, 0, 1); a name found nowhere is missing (0, 0, 0, 0), as in
hybrid_engine/scene/mesh_attributes.py. Only the keys some program asks for are looked up.
"""
from __future__ import annotations

from numbers import Number

from ...hybrid_engine.scene.mesh_attributes import MISSING


def _rgba(value) -> tuple[float, ...] | None:
    if isinstance(value, bool) or isinstance(value, Number):
        v = float(value)
        return (v, v, v, 1.0)
    try:
        items = [float(x) for x in value]
    except (TypeError, ValueError):
        return None
    if not 1 <= len(items) <= 4:
        return None
    if len(items) == 1:
        return (items[0],) * 3 + (1.0,)
    return tuple(items + [0.0, 0.0, 0.0, 1.0][len(items):])


def _property(id_block, name: str) -> tuple[float, ...] | None:
    """``name`` of ``id_block`` as RGBA: its custom property, else its property path."""
    if id_block is None or not name:
        return None
    try:
        if name in id_block.keys():
            return _rgba(id_block[name])
    except (TypeError, AttributeError):
        pass
    try:
        return _rgba(id_block.path_resolve(name))
    except (ValueError, AttributeError, TypeError):
        return None


def instance_value(source: str, name: str, obj, instancer) -> tuple[float, ...]:
    """The RGBA of attribute ``name`` of ``source`` ("OBJECT" or "INSTANCER") for an instance
    of ``obj`` made by ``instancer`` (None for an object of its own)."""
    chain = [obj, getattr(obj, "data", None)]
    if source == "INSTANCER":
        chain = [instancer, *chain]
    for id_block in chain:
        found = _property(id_block, name)
        if found is not None:
            return found
    return MISSING


def instance_values(keys: tuple[tuple[str, str], ...], obj, instancer) -> dict[tuple[str, str], tuple]:
    """Each requested key's RGBA for one instance (``instance_value``)."""
    return {key: instance_value(key[0], key[1], obj, instancer) for key in keys}
