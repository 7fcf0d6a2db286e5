# SPDX-License-Identifier: GPL-3.0-or-later
"""The scene on the GPU: world-space vertex attributes, the material buffer, image textures.

Every triangle reaches the GPU one way (paper §3.3: the meshes live on the GPU and are
transformed there every frame): the geometry as instances of object-space meshes
(scene/geometry.py converts a flat world-space geometry at this boundary), the meshes and
the instance table uploaded by ``instance_transform.py``, which writes the world-space rows
below on the GPU. One row per triangle, one buffer per attribute: ``positions`` (N, 3, 3)
float32 is both the rasterizer's position attribute and the LBVH's input, ``normals`` both
the shading-normal attribute and the normals the tracer interpolates at BVH hits, the
per-triangle material ids are read by the G-buffer vertex stage (``gl_VertexID / 3``) and
the tracer alike, and ``uv_rows`` hold each triangle's UVs and texture level for the
tracer's textured hits.

Buffers are persistent and grow-only: a frame whose data fits reuses last frame's buffer
objects. Which instances the transform rewrote is this frame's ``GeometryDelta``: what the
shadow layers and the frame's reuse decide on.
"""
from __future__ import annotations

import time

import numpy as np

from ...gpu.bindings import Bindings
from ...gpu.dispatch import GrowBuffer, bytes_of
from ...scene.changes import GeometryDelta
from ...scene.data import MATERIAL_DTYPE, SceneData
from ...scene.geometry import InstancedGeometry
from ...scene.mesh_attributes import AttributeRequests
from .instance_transform import OUTPUT_ROW_BYTES, InstanceTransformer
from .node_attributes import NodeAttributes
from .node_programs import NodePrograms
from .raster_meshes import RasterMeshes
from .textures import GPUTextures

# Per-vertex attributes: (GLSL input, moderngl format, GPUScene buffer attribute).
VERTEX_ATTRIBUTES = (("in_pos", "3f", "positions"), ("in_normal", "3f", "normals"), ("in_uv", "2f", "uvs"))


class GPUScene:
    """The scene's buffers on the shared context, reused from frame to frame."""

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.positions = GrowBuffer(ctx, "scene positions", 36)
        self.normals = GrowBuffer(ctx, "scene normals", 36)
        self.uvs = GrowBuffer(ctx, "scene uvs", 24)
        self.triangle_materials = GrowBuffer(ctx, "scene triangle materials", 4)
        # The tracer's per-triangle UV rows (the corners' UVs and the texture level).
        self.uv_rows = GrowBuffer(ctx, "scene triangle uv rows", 32)
        self.materials = GrowBuffer(ctx, "scene materials", MATERIAL_DTYPE.itemsize)
        self._world_buffers = {"positions": self.positions, "normals": self.normals, "uvs": self.uvs,
                               "triangle_materials": self.triangle_materials, "uv_rows": self.uv_rows}
        for buf in (*self._world_buffers.values(), self.materials):
            buf.ensure(0)  # passes bind these before the first upload
        self.instance_transform = InstanceTransformer(ctx)
        # The meshes' object-space vertex and index buffers for indexed raster draws (the
        # ``vertices`` kernel's "gpu" variant); allocated when first updated.
        self.raster_meshes = RasterMeshes(ctx)
        self.generation = 0  # bumps when a vertex attribute's buffer object changes
        # Each program's vertex array over these buffers and the generation it was made for.
        self._vertex_arrays: dict[int, tuple[int, object]] = {}
        self.host_ms = 0.0  # host time of the last upload
        self.triangle_count = 0
        self.sequence = 0  # counts uploads: a GeometryDelta's sequence
        self.geometry: InstancedGeometry | None = None  # what the last upload placed
        self.textures = GPUTextures(ctx)  # re-uploaded only when the scene's images change
        self.node_programs = NodePrograms(ctx)  # the materials' node graphs, as program words
        self.node_attributes = NodeAttributes(ctx)  # the attributes the programs read, if any
        # Counts the uploads whose materials differ from the last one's (the packed rows, the
        # node programs' words and values, the images): light that a pass keeps across frames
        # (the radiance cache's cells) was gathered off the old ones.
        self.materials_version = 0
        self._sent_rows, self._sent_word_uploads = b"", -1

    @property
    def defines(self) -> dict:
        """What every shader that shades a material needs defined for this scene:
        ``NODE_PROGRAMS`` when some material has a node graph (the interpreter,
        include/node_program.glsl), nothing otherwise, so scenes without graphs run the
        shaders as they were. With it, the family defines its programs' nodes need
        (node_codes.FAMILY_*): each family's cases compile in only where a graph uses it;
        the programs' generated GLSL where it runs (NodePrograms.defines); and
        ``NODE_CLOSURE_ALPHA`` where some material's coverage is an alpha program, so that
        the alpha tests call into the programs only then (the call weighs on every shader
        it is compiled into, the traversal's inner loop above all)."""
        if not self.node_programs.active:
            return {}
        alpha = {"NODE_CLOSURE_ALPHA": 1} if self.node_programs.closure_alpha else {}
        return {"NODE_PROGRAMS": 1, **{family: 1 for family in sorted(self.node_programs.table.families)},
                **alpha, **self.node_programs.defines}

    @property
    def previous_rows(self):
        """Last frame's world rows of the instances this frame's upload found deformed
        (previous_rows.PreviousRows): valid in the frame whose transform captured them."""
        return self.instance_transform.previous

    def vertex_content(self, program) -> list[tuple]:
        """moderngl vertex-array content of ``program``: one binding per attribute it reads
        (the GLSL compiler drops unused inputs)."""
        return [(getattr(self, buffer).buffer, fmt, name)
                for name, fmt, buffer in VERTEX_ATTRIBUTES if name in program]

    def vertex_array(self, program):
        """``program``'s vertex array over these buffers (``vertex_content``), made again only
        when a buffer object is replaced (``generation``): every raster pass that draws the
        world rows shares it."""
        entry = self._vertex_arrays.get(id(program))
        if entry is not None and entry[0] == self.generation:
            return entry[1]
        if entry is not None:
            entry[1].release()
        vao = self.ctx.vertex_array(program, self.vertex_content(program))
        self._vertex_arrays[id(program)] = (self.generation, vao)
        return vao

    def bindings(self) -> Bindings:
        """The materials, the per-triangle material ids and the textures, by the names every
        pass that reads a material declares (scene_layout.glsl, textures.glsl)."""
        programs = self.node_programs.bindings() if self.node_programs.active else {}
        if self.node_programs.active and self.node_attributes.active:
            programs.update(self.node_attributes.bindings())
        return Bindings(storage={"MaterialBuffer": self.materials.buffer,
                                 "TriangleMaterials": self.triangle_materials.buffer, **programs},
                        textures={"u_textures": self.textures.array})

    def upload(self, scene: SceneData) -> tuple[SceneData, GeometryDelta]:
        """The host's part of bringing ``scene`` to the GPU: the geometry as instances, the
        object-space store and the instance table, materials and textures. Returns the
        scene as the passes read it (its geometry as instances) and the frame's delta; the
        world rows of the changed instances are written by ``transform``."""
        start = time.perf_counter()
        geometry = scene.geometry.as_instances(self.geometry)
        n = geometry.triangle_count
        allocations = [buf.allocations for buf in self._world_buffers.values()]
        for name, buf in self._world_buffers.items():
            buf.ensure(n * OUTPUT_ROW_BYTES[name])
        grown = [buf.allocations for buf in self._world_buffers.values()] != allocations
        if grown or n != self.triangle_count:
            self.instance_transform.forget()  # every row must be written again
        if grown:
            self.generation += 1  # a new buffer object: dependent VAOs must be rebuilt
        stats = self.instance_transform.update(geometry, self._world_buffers)
        self.sequence += 1
        delta = self._delta(geometry, stats.changed, whole=stats.store_rebuilt or self.geometry is None)
        self.geometry = geometry
        self.triangle_count = n
        rows = scene.materials.packed()
        self.node_programs.update(scene.materials, rows, geometry)
        table = self.node_programs.table
        self.node_attributes.update(table.attributes if table is not None else AttributeRequests(), geometry)
        row_bytes = bytes(bytes_of(rows))
        rows_changed = row_bytes != self._sent_rows
        if rows_changed:
            self.materials.upload(row_bytes)
        images_changed = self.textures.upload(scene.materials.textures)
        word_uploads = self.node_programs.word_uploads
        if rows_changed or word_uploads != self._sent_word_uploads or images_changed:
            self.materials_version += 1
            self._sent_rows, self._sent_word_uploads = row_bytes, word_uploads
        self.host_ms = (time.perf_counter() - start) * 1e3
        return (scene if geometry is scene.geometry else SceneData(geometry=geometry, materials=scene.materials,
                                                                   lights=scene.lights, sky=scene.sky)), delta

    def transform(self, keep_previous: bool = True) -> None:
        """The GPU's part: the world rows of the instances the last upload found changed;
        ``keep_previous``: first copy the deformed ones' rows of last frame
        (``previous_rows``)."""
        self.instance_transform.transform(keep_previous)

    def _delta(self, geometry: InstancedGeometry, changed: np.ndarray, whole: bool) -> GeometryDelta:
        """The frame's delta: everything on a first upload or a rebuilt store, else the
        triangle ranges of the instances whose rows are rewritten."""
        if whole:
            return GeometryDelta.everything(geometry.triangle_count, self.sequence)
        ranges = geometry.object_ranges[changed].astype(np.int64)
        ranges = ranges[ranges[:, 1] > 0]
        if len(ranges) == 0:
            return GeometryDelta(full=False, sequence=self.sequence)
        # Objects' ranges follow one another without overlapping: adjacent changed objects are
        # one range, and the work is per changed object, not per triangle of the scene.
        ranges = ranges[np.argsort(ranges[:, 0], kind="stable")]
        starts, ends = ranges[:, 0], ranges[:, 0] + ranges[:, 1]
        breaks = np.flatnonzero(starts[1:] != ends[:-1])
        firsts, lasts = np.r_[starts[0], starts[breaks + 1]], np.r_[ends[breaks], ends[-1]]
        merged = tuple((int(a), int(b - a)) for a, b in zip(firsts, lasts))
        return GeometryDelta(full=False, ranges=merged, changed_triangles=int(ranges[:, 1].sum()),
                             sequence=self.sequence)

    def release(self) -> None:
        for _generation, vao in self._vertex_arrays.values():
            vao.release()
        self._vertex_arrays.clear()
        for buf in (*self._world_buffers.values(), self.materials):
            buf.release()
        self.instance_transform.release()
        self.raster_meshes.release()
        self.textures.release()
        self.node_programs.release()
        self.node_attributes.release()
