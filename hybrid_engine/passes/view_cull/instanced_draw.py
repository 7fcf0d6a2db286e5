# SPDX-License-Identifier: GPL-3.0-or-later
"""Instanced, indexed drawing of the scene for a raster view: the ``vertices`` kernel's
"gpu" variant (gpu/variants.py).

A GPU's vertex pipeline is built for object-space meshes drawn once per instance: an index
buffer lets its post-transform cache shade a vertex shared by several triangles once, where
the world-space rows (one vertex per triangle corner) shade it once per corner. Here each
view draws the instances whose bounds touch its frustum, one DrawElementsIndirectCommand per
instance {3 N indices, 1, the mesh's first index (its mirrored list for a mirroring
instance), the mesh's first vertex, the instance} written by the host (a few hundred bytes
for a scene of hundreds of objects), the vertex stage fetching the instance's matrices at
gl_BaseInstance (gbuffer.vert.glsl with INSTANCED). The buffers are
scene_upload/raster_meshes.py's.

The draws take draw.py's ``draw_world`` choices, so that the images equal those of the
rows bit for bit: the same objects, GL back-face culling for the closed objects wholly
beyond the near plane; and they keep the order of the per-triangle culled lists
(view_cull.py) -- object by object, each mesh's triangles in order -- so that depth ties
between objects resolve alike. Consecutive objects drawn the same way (indexed or from the rows, with or without
face culling) form one run: one multi-draw, or the rows' direct draws. Instances the raster
buffers cannot draw (raster_meshes.py: meshes without shared vertices, as flat geometry
becomes, or non-finite ones) are drawn from the rows in their place.

The per-triangle culling of view_cull.py is not applied to these draws: it compacts
triangles, and an indexed draw of a mesh's triangles is what lets the material be found
from gl_PrimitiveID. On a GPU, the pixel-sized triangles it drops cost the rasterizer
little next to the vertices saved.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ...gpu.bindings import set_uniforms
from ...gpu.dispatch import GrowBuffer
from ...scene.data import SceneData
from ...scene.raster_view import gl_matrix
from ..scene_upload.raster_meshes import VERTEX_ATTRIBUTES, VERTEX_DTYPE, RasterMeshes
from .frustum import candidate_masks, draw_ranges

COMMAND_DTYPE = np.dtype([("count", "<u4"), ("instances", "<u4"), ("first_index", "<u4"),
                          ("base_vertex", "<i4"), ("base_instance", "<u4")])
assert COMMAND_DTYPE.itemsize == 20  # DrawElementsIndirectCommand


@dataclass
class InstancedStats:
    """What the last view drew: triangles submitted (after per-object culling), the vertices
    the vertex stage shaded for them (distinct corners of the indexed draws, three per
    triangle of the rest), and how many instances were drawn each way."""

    triangles: int = 0
    vertices: int = 0
    instanced: int = 0
    from_rows: int = 0


def vertex_content(program, buffer) -> list[tuple]:
    """moderngl vertex-array content of ``program`` over the interleaved raster vertices:
    the inputs it reads, the others skipped as padding (the compiler drops unused inputs)."""
    formats, names = [], []
    for name, fmt, size in VERTEX_ATTRIBUTES:
        if name in program:
            formats.append(fmt)
            names.append(name)
        else:
            formats.append(f"{size}x")
    assert sum(size for *_, size in VERTEX_ATTRIBUTES) == VERTEX_DTYPE.itemsize
    return [(buffer, " ".join(formats), *names)]


class InstancedDrawer:
    """Draws views of the scene from the raster meshes (module doc); one per layer of draws,
    so that a command buffer is not rewritten while an earlier draw may read it."""

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.commands = GrowBuffer(ctx, "instanced draw commands", 20 * 64)
        self._vaos: dict[int, tuple[tuple, object]] = {}
        self.stats = InstancedStats()

    def vertex_array(self, program, meshes: RasterMeshes):
        """``program``'s indexed vertex array over ``meshes``' buffers, rebuilt when they are."""
        key = (id(meshes), meshes.generation)
        entry = self._vaos.get(id(program))
        if entry is not None and entry[0] == key:
            return entry[1]
        if entry is not None:
            entry[1].release()
        vao = self.ctx.vertex_array(program, vertex_content(program, meshes.vertices.buffer),
                                    index_buffer=meshes.indices.buffer, index_element_size=4)
        self._vaos[id(program)] = (key, vao)
        return vao

    def draw(self, program, bind_program: Callable[[object], None], rows_program, rows_vao,
             meshes: RasterMeshes, scene: SceneData, fbo, views: list[tuple[np.ndarray, tuple[int, int, int, int]]],
             face_culling, include: np.ndarray | None = None) -> InstancedStats:
        """Draw ``scene``'s objects (those ``include`` selects, all when None) into ``fbo``
        once per (view_proj, viewport rectangle) of ``views``: indexed with ``program``
        where the raster meshes allow it, else from the rows with ``rows_program`` (its
        vertex array ``rows_vao``); both take the view's matrix as ``u_view_proj``.
        ``bind_program(p)`` binds p's buffers and sets the pass's GL state (before each run,
        as the two programs' binding points differ); ``face_culling`` is draw.py's
        SceneDrawer.face_culling. ``meshes`` must be updated to the scene's geometry. The
        commands of all views are written at once, before the first draw."""
        geo = scene.geometry
        ranges = geo.object_ranges
        draws = meshes.draws(geo)
        stats = self.stats = InstancedStats()
        plans, commands = [], []
        drawn = ranges[:, 1] > 0
        if include is not None:
            drawn &= include
        all_visible, all_beyond = candidate_masks([view_proj for view_proj, _ in views], geo.object_bounds, drawn)
        for index, (view_proj, rect) in enumerate(views):
            mask = all_visible[index] & drawn
            culled = np.zeros_like(mask)
            if geo.object_closed is not None and mask.any():
                culled = mask & geo.object_closed & all_beyond[index]
            visible = np.flatnonzero(mask)
            indexed = draws.instanced[visible]
            stats.triangles += int(ranges[visible, 1].astype(np.int64).sum())
            stats.vertices += int(draws.vertices[visible].sum())
            stats.instanced += int(indexed.sum())
            stats.from_rows += int((~indexed).sum())
            picked = visible[indexed]
            rows = np.zeros(len(picked), COMMAND_DTYPE)
            rows["count"] = draws.count[picked]
            rows["instances"] = 1
            rows["first_index"] = draws.first_index[picked]
            rows["base_vertex"] = draws.base_vertex[picked]
            rows["base_instance"] = picked
            # Each visible object's command (if indexed), counted over all views' commands.
            first_command = sum(len(c) for c in commands)
            commands.append(rows)
            plans.append((view_proj, rect, visible, indexed, culled[visible], first_command + np.cumsum(indexed) - indexed))
        if sum(len(c) for c in commands):
            self.commands.upload(np.concatenate(commands).tobytes())
            vao = self.vertex_array(program, meshes)
        for view_proj, rect, visible, indexed, culled, command_of in plans:
            if not len(visible):
                continue
            fbo.viewport = rect
            matrix = gl_matrix(view_proj)
            set_uniforms(program, {"u_view_proj": matrix})
            set_uniforms(rows_program, {"u_view_proj": matrix})
            # Runs of consecutive visible objects drawn the same way (module doc).
            way = indexed.astype(np.int8) * 2 + culled
            starts = np.flatnonzero(np.r_[True, way[1:] != way[:-1]])
            ends = np.r_[starts[1:], len(visible)]
            for start, end in zip(starts, ends):
                # Bound outside the face culling: binding sets the pass's GL state afresh.
                bind_program(program if indexed[start] else rows_program)
                with face_culling(view_proj, "back" if culled[start] else None):
                    if indexed[start]:
                        vao.render_indirect(self.commands.buffer, count=int(end - start),
                                            first=int(command_of[start]))
                    else:
                        run = np.zeros(len(ranges), bool)
                        run[visible[start:end]] = True
                        for first, count in draw_ranges(run, ranges):
                            rows_vao.render(self.ctx.TRIANGLES, vertices=count * 3, first=first * 3)
        return stats

    def release(self) -> None:
        for _, vao in self._vaos.values():
            vao.release()
        self._vaos.clear()
        self.commands.release()
