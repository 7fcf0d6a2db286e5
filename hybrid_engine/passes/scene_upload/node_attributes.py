# SPDX-License-Identifier: GPL-3.0-or-later
"""The attributes the node programs read, on the GPU (gpu_shaders/include/node_attributes.glsl,
blocks ``NodeAttributeValues`` and ``NodeAttributeInstances``).

Only the scene's requested attributes travel (scene/mesh_attributes.py ``AttributeRequests``,
from the compiled programs): a scene whose programs read none binds nothing and compiles
nothing of this (``NODE_ATTRIBUTES`` is off).

Where the values live, and why there:
- per mesh, once, in object space: RGBA per triangle corner for each requested name
  (``NodeAttributeValues``), shared by all its instances like the mesh itself (one geometry
  path, docs/ARCHITECTURE.md). An attribute edit (a painted vertex colour) is a new version
  of that mesh, and only that mesh's values are written again, into place;
- per instance: where its mesh's values start, whether its matrix mirrors (the world rows'
  corners 1 and 2 are swapped then), and its Object/Instancer attributes
  (``NodeAttributeInstances``, aligned with ``NodeObjects``' instance rows).

Every place the interpreter runs (G-buffer, cube-map faces, BVH and cube-map hits) knows the
surface's world row and position; the lookup finds the instance and the triangle from the
row, the barycentrics from the position and the row's world corners (``scene positions``,
bound as ``NodeAttributePositions``), and interpolates. One lookup for every pass, so no
vertex stream, BVH leaf or cube-map target grows for scenes that use no attribute.
"""
from __future__ import annotations

import numpy as np

from ...gpu.dispatch import GrowBuffer
from ...scene.geometry import InstancedGeometry
from ...scene.mesh_attributes import MISSING, AttributeRequests


def mesh_values(mesh, names: tuple[str, ...]) -> np.ndarray:
    """(3 N, len(names), 4) float32: each corner's RGBA of each name (MISSING where the mesh
    lacks it), in the store's order (corner-major, then slot)."""
    n = 3 * mesh.triangle_count
    out = np.empty((n, len(names), 4), np.float32)
    out[:] = MISSING
    carried = mesh.attributes or {}
    for slot, name in enumerate(names):
        values = carried.get(name)
        if values is not None:
            out[:, slot] = values
    return out


class NodeAttributes:
    """The attribute store and the per-instance table, written when they change."""

    def __init__(self, ctx) -> None:
        self.values = GrowBuffer(ctx, "node attribute values")
        self.instances = GrowBuffer(ctx, "node attribute instances")
        self.requests = AttributeRequests()
        self._placed: dict[int, tuple[int, int]] = {}  # mesh id -> (first vec4, version sent)
        self._layout: tuple | None = None  # (names, mesh ids in order) the store was built for
        self._sent_instances: bytes | None = None
        self.meshes_written = 0  # meshes whose values the last update wrote (tests)
        self.bytes_written = 0

    @property
    def active(self) -> bool:
        return bool(self.requests)

    def update(self, requests: AttributeRequests, geometry: InstancedGeometry) -> None:
        """Bring the store and the table up to ``requests`` over ``geometry``'s meshes."""
        self.requests = requests
        self.meshes_written = self.bytes_written = 0
        if not requests:
            self._layout, self._placed, self._sent_instances = None, {}, None
            return
        instances = geometry.instances
        names = requests.geometry
        meshes = list({m.mesh_id: m for m in instances.meshes}.values())
        layout = (names, tuple((m.mesh_id, m.triangle_count) for m in meshes))
        if layout != self._layout:
            self._rebuild(meshes, names)
            self._layout = layout
        elif names:
            for mesh in meshes:
                first, version = self._placed[mesh.mesh_id]
                if version != mesh.version:
                    data = mesh_values(mesh, names).tobytes()
                    self.values.write_at(data, first * 16)
                    self._placed[mesh.mesh_id] = (first, mesh.version)
                    self.meshes_written += 1
                    self.bytes_written += len(data)
        table = self._instance_table(geometry, requests).tobytes()
        if table != self._sent_instances:
            self.instances.upload(table)
            self._sent_instances = table
            self.bytes_written += len(table)

    def _rebuild(self, meshes: list, names: tuple[str, ...]) -> None:
        self._placed = {}
        chunks, at = [], 0
        for mesh in meshes:
            self._placed[mesh.mesh_id] = (at, mesh.version)
            if names:
                chunks.append(mesh_values(mesh, names).reshape(-1, 4))
                at += 3 * mesh.triangle_count * len(names)
        data = np.concatenate(chunks).tobytes() if chunks else bytes(16)
        self.values.upload(data or bytes(16))
        self.meshes_written = len(chunks)
        self.bytes_written += len(data)

    def _instance_table(self, geometry: InstancedGeometry, requests: AttributeRequests) -> np.ndarray:
        """Row 0: x = geometry slots, y = instance slots, z = instances (int bits); then per
        instance one row (x = its mesh's first value or -1, y = mirrored) and one row per
        instance slot (its RGBA)."""
        instances = geometry.instances
        k, slots = len(instances), len(requests.instance)
        stride = 1 + slots
        out = np.zeros((1 + k * stride, 4), np.float32)
        header = out[0].view(np.int32)
        header[:3] = (len(requests.geometry), slots, k)
        if k == 0:
            return out
        body = out[1:].reshape(k, stride, 4)
        firsts = np.array([self._placed[m.mesh_id][0] if requests.geometry else -1 for m in instances.meshes],
                          np.int32)
        ints = body[:, 0].view(np.int32)
        ints[:, 0] = firsts[instances.mesh]
        ints[:, 1] = instances.mirrored()
        carried = instances.attributes or {}
        for slot, key in enumerate(requests.instance):
            values = carried.get(key)
            body[:, 1 + slot] = MISSING if values is None else values
        return out

    def bindings(self, positions) -> dict:
        return {"NodeAttributeValues": self.values.buffer, "NodeAttributeInstances": self.instances.buffer,
                "NodeAttributePositions": positions}

    def release(self) -> None:
        self.values.release()
        self.instances.release()
