# SPDX-License-Identifier: GPL-3.0-or-later
"""The attributes the node programs read, on the GPU (gpu_shaders/include/node_attributes.glsl,
block ``NodeAttributes``).

Only the scene's requested attributes travel (scene/mesh_attributes.py ``AttributeRequests``,
from the compiled programs): a scene whose programs read none binds nothing and compiles
nothing of this (``NODE_ATTRIBUTES`` is off).

Where the values live, and why there. One storage block, because the shaders that run the
interpreter are near the driver's limit of blocks per stage (the waves' traversal kernel binds
sixteen, llvmpipe's and many GPUs' limit, with it); in it:
- a header (the slot counts, the instances, where their table starts);
- per mesh, once, in object space: per triangle its three corners' positions, then each
  corner's RGBA of each requested name, shared by all its instances like the mesh itself (one
  geometry path, docs/ARCHITECTURE.md). An attribute edit (a painted vertex colour) or a
  deformation is a new version of that mesh, and only that mesh's block is written again;
- per instance: where its mesh's block starts and its Object/Instancer attributes, aligned
  with ``NodeObjects``' instance rows.

Every place the interpreter runs (G-buffer, cube-map faces, BVH and cube-map hits) knows the
surface's world row and position; the lookup finds the instance and the triangle from the
row, takes the position to object space (``NodeObjects``' world-to-object map) and the
barycentrics there from the corners kept here, and interpolates. One lookup for every pass,
so no vertex stream, BVH leaf or cube-map target grows for scenes that use no attribute.
"""
from __future__ import annotations

import numpy as np

from ...gpu.dispatch import GrowBuffer
from ...scene.geometry import InstancedGeometry
from ...scene.mesh_attributes import MISSING, AttributeRequests


def mesh_block(mesh, names: tuple[str, ...]) -> np.ndarray:
    """(N, 3 + 3 len(names), 4) float32: per triangle its corners' object-space positions,
    then each corner's RGBA of each name (MISSING where the mesh lacks it)."""
    n, slots = mesh.triangle_count, len(names)
    out = np.empty((n, 3 + 3 * slots, 4), np.float32)
    out[:, :3, :3] = mesh.positions[mesh.corner_vertices].reshape(n, 3, 3)
    out[:, :3, 3] = 0.0
    values = out[:, 3:].reshape(n, 3, slots, 4)
    values[:] = MISSING
    carried = mesh.attributes or {}
    for slot, name in enumerate(names):
        found = carried.get(name)
        if found is not None:
            values[:, :, slot] = found.reshape(n, 3, 4)
    return out


class NodeAttributes:
    """The block: header, the meshes' values, the instance table; written where it changed."""

    def __init__(self, ctx) -> None:
        self.buffer = GrowBuffer(ctx, "node attributes")
        self.requests = AttributeRequests()
        self._placed: dict[int, tuple[int, int]] = {}  # mesh id -> (first vec4, version sent)
        self._layout: tuple | None = None  # (names, meshes) the values were laid out for
        self._table_at = 1  # the vec4 where the instance table starts
        self._sent_table: bytes | None = None
        self.meshes_written = 0  # meshes whose values the last update wrote (tests)
        self.bytes_written = 0

    @property
    def active(self) -> bool:
        return bool(self.requests)

    def update(self, requests: AttributeRequests, geometry: InstancedGeometry) -> None:
        """Bring the block up to ``requests`` over ``geometry``'s meshes and instances."""
        self.requests = requests
        self.meshes_written = self.bytes_written = 0
        if not requests:
            self._layout, self._placed, self._sent_table = None, {}, None
            return
        names = requests.geometry
        meshes = list({m.mesh_id: m for m in geometry.instances.meshes}.values())
        layout = (names, tuple((m.mesh_id, m.triangle_count) for m in meshes))
        if layout != self._layout:
            self._rebuild(meshes, names, geometry, requests)
            self._layout = layout
            return
        for mesh in meshes:
            first, version = self._placed[mesh.mesh_id]
            if version != mesh.version and first >= 0:
                data = mesh_block(mesh, names).tobytes()
                self.buffer.write_at(data, first * 16)
                self._placed[mesh.mesh_id] = (first, mesh.version)
                self.meshes_written += 1
                self.bytes_written += len(data)
        table = self._instance_table(geometry, requests)
        if table.tobytes() != self._sent_table:
            if (self._table_at + len(table)) * 16 > self.buffer.capacity:
                self._rebuild(meshes, names, geometry, requests)
                return
            self.buffer.write_at(self._header(requests, geometry).tobytes(), 0)
            self.buffer.write_at(table.tobytes(), self._table_at * 16)
            self._sent_table = table.tobytes()
            self.bytes_written += 16 + len(self._sent_table)

    def _header(self, requests: AttributeRequests, geometry: InstancedGeometry) -> np.ndarray:
        """x = geometry slots, y = instance slots, z = instances, w = the table's first vec4."""
        return np.array([len(requests.geometry), len(requests.instance), len(geometry.instances), self._table_at],
                        np.int32)

    def _rebuild(self, meshes: list, names: tuple[str, ...], geometry: InstancedGeometry,
                 requests: AttributeRequests) -> None:
        self._placed = {}
        chunks, at = [], 1
        for mesh in meshes:
            self._placed[mesh.mesh_id] = (at if names else -1, mesh.version)
            if names:
                block = mesh_block(mesh, names).reshape(-1, 4)
                chunks.append(block)
                at += len(block)
        self._table_at = at
        table = self._instance_table(geometry, requests)
        header = self._header(requests, geometry).view(np.float32).reshape(1, 4)
        data = np.concatenate([header, *chunks, table]).tobytes()
        self.buffer.upload(data)
        self._sent_table = table.tobytes()
        self.meshes_written = len(chunks)
        self.bytes_written += len(data)

    def _instance_table(self, geometry: InstancedGeometry, requests: AttributeRequests) -> np.ndarray:
        """Per instance one row (x = its mesh's first vec4 or -1, int bits) and one row per
        instance slot (its RGBA)."""
        instances = geometry.instances
        k, slots = len(instances), len(requests.instance)
        out = np.zeros((max(k, 1), 1 + slots, 4), np.float32)
        if k == 0:
            return out.reshape(-1, 4)
        firsts = np.array([self._placed[m.mesh_id][0] for m in instances.meshes], np.int32)
        out[:k, 0].view(np.int32)[:, 0] = firsts[instances.mesh]
        carried = instances.attributes or {}
        for slot, key in enumerate(requests.instance):
            values = carried.get(key)
            out[:k, 1 + slot] = MISSING if values is None else values
        return out.reshape(-1, 4)

    def bindings(self) -> dict:
        return {"NodeAttributes": self.buffer.buffer}

    def release(self) -> None:
        self.buffer.release()
