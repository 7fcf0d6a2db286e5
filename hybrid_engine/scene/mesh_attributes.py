# SPDX-License-Identifier: GPL-3.0-or-later
"""The attributes a scene's node programs read (Color Attribute and Attribute nodes), and
their values as the renderer keeps them.

Why requests: a mesh can carry dozens of attributes (UV maps, masks, geometry nodes'
outputs), and every one carried costs host reads, memory and uploads. Only the names some
program of the scene asks for are read from Blender and sent (``AttributeRequests``), so a
scene without attribute nodes pays nothing, and a scene that reads one colour pays for
one colour.

Values are RGBA per triangle corner (``ObjectMesh.attributes``), whatever Blender's domain
and type: a point or face value is repeated at the corners that share it, which keeps one
layout for the store and one interpolation at the shading point (the corners' values
weighted by the point's barycentrics, as Cycles' ``primitive_surface_attribute`` does for a
corner attribute, and which gives a point or face attribute's value unchanged). How each
type becomes RGBA follows Cycles' Attribute node (``svm_node_attr``): a float f is (f, f, f,
1), a vector (x, y, z, 1), a 2D vector (x, y, 0, 1), a colour its RGBA (a byte colour
converted from sRGB to linear, a float colour as stored). Fac is the mean of RGB, Alpha is A.

Object and Instancer attributes are one value per instance (``Instances.attributes``): a
custom property or property path of the object (or of its instancer), as Blender's
``BKE_object_dupli_find_rgba_attribute`` looks them up.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

import numpy as np

from . import node_codes as nc

# The name a Color Attribute node with no layer asks for: the mesh's default (render) colour
# attribute, whichever it is on each mesh.
DEFAULT_COLOR = ""
# What a mesh without the attribute reads (Cycles' value of a missing attribute).
MISSING = (0.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class AttributeRequests:
    """The attributes a scene's programs read: ``geometry`` names (per-corner values of the
    meshes, ``DEFAULT_COLOR`` for a Color Attribute node without a layer) and ``instance``
    keys, ``(source, name)`` with source "OBJECT" or "INSTANCER" (one value per instance).
    A node's slot is its key's index in its tuple."""

    geometry: tuple[str, ...] = ()
    instance: tuple[tuple[str, str], ...] = ()

    def __bool__(self) -> bool:
        return bool(self.geometry or self.instance)

    def slot(self, key: tuple[str, str]) -> tuple[int, int]:
        """(source code, slot) of ``key`` (node_codes.ATTRIBUTE_SOURCES); slot -1 when the
        key was not requested."""
        source, name = key
        if source == "GEOMETRY":
            return nc.ATTRIBUTE_SOURCES["GEOMETRY"], (self.geometry.index(name) if name in self.geometry else -1)
        return nc.ATTRIBUTE_SOURCES[source], (self.instance.index(key) if key in self.instance else -1)


def node_key(kind: str, settings: dict) -> tuple[str, str] | None:
    """The attribute a node of ``kind`` reads, as (source, name); None for other kinds. The
    Attribute node's View Layer source has no per-object value: it reads as missing."""
    if kind == "VERTEX_COLOR":
        return "GEOMETRY", str(settings.get("layer_name") or DEFAULT_COLOR)
    if kind == "ATTRIBUTE":
        source = str(settings.get("attribute_type") or "GEOMETRY")
        if source not in nc.ATTRIBUTE_SOURCES:
            return None
        return source, str(settings.get("attribute_name") or "")
    return None


def requests_of(keys: Iterable[tuple[str, str] | None]) -> AttributeRequests:
    """The requests of a scene's nodes' keys, each slot once, in a fixed order (sorted), so
    the same set of nodes gives the same slots and the same program words."""
    found = {k for k in keys if k is not None}
    return AttributeRequests(tuple(sorted(name for source, name in found if source == "GEOMETRY")),
                             tuple(sorted(k for k in found if k[0] != "GEOMETRY")))


def as_rgba(values: np.ndarray) -> np.ndarray:
    """Blender attribute values (n,) or (n, w), w in 1..4, as (n, 4) float32 RGBA by Cycles'
    rules (module docstring)."""
    v = np.asarray(values, np.float32)
    v = v.reshape(len(v), -1) if v.ndim != 1 else v[:, None]
    out = np.empty((len(v), 4), np.float32)
    width = v.shape[1]
    if width == 1:
        out[:, :3] = v
        out[:, 3] = 1.0
    elif width == 2:
        out[:, :2] = v
        out[:, 2] = 0.0
        out[:, 3] = 1.0
    elif width == 3:
        out[:, :3] = v
        out[:, 3] = 1.0
    else:
        out[:] = v[:, :4]
    return out


def interpolate(corners: np.ndarray, barycentrics: np.ndarray) -> np.ndarray:
    """The host's value of a corner attribute at points of triangles: ``corners`` (n, 3, 4),
    ``barycentrics`` (n, 3) weights of corners 0, 1, 2. The oracle the GPU's lookup is held to."""
    return np.einsum("nc,nck->nk", np.asarray(barycentrics, np.float64),
                     np.asarray(corners, np.float64)).astype(np.float32)
