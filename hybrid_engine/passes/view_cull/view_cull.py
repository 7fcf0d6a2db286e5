# SPDX-License-Identifier: GPL-3.0-or-later
"""Per-triangle culling of raster draws on the GPU, for views drawn many triangles at a time.

Per-object frustum culling (:func:`.frustum.visible_objects`) leaves the G-buffer cube map
(paper §3.2) with the whole far scene over the six faces, and most of a dense far scene's
triangles produce no fragment -- they fall between the texel centres of a face, face away,
or lie outside the face. A rasterizer sets each of them up before finding that out (on a
software GL that set-up is most of the pass). Here a compute pass tests every
triangle of every view's draw list once (``gpu_shaders/view_cull/view_cull.comp.glsl``: clip
outcodes, pixel centres inside the projected bounding box, back faces of closed objects)
and compacts the survivors into an index buffer with one indirect draw command per view
(``view_cull_compact.comp.glsl``), so only they reach the rasterizer. The test drops a
triangle only where the GL would rasterize nothing of it and the survivors keep their
order, so the G-buffers are bit-identical to drawing the lists directly (tested).

For the cube map's back layer (cube_map.py) one test per triangle fills two lists
(:meth:`ViewTriangleCuller.cull_with_back`): the faces' own, and the back layer's, which holds
the back faces of the closed objects.

Everything stays on the GPU: the host builds the per-view segment lists from object bounds
(no per-triangle work) and never reads the result back. A draw list whose index buffer
would exceed one storage block returns None, and the caller draws directly (the documented
fallback).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import moderngl
import numpy as np

from ...gpu import shader_loader
from ...gpu.bindings import Storage, bind
from ...gpu.dispatch import GrowBuffer, dispatch, max_block_bytes, storage_barrier
from ...gpu.prefix_scan import PrefixScan
from ...gpu.triangle_input import input_defines, input_split, input_storage
from .frustum import candidate_masks, front_face_winding

LOCAL_SIZE = 64
MAX_VIEWS = 6
CHUNK_ITEMS = 32  # one mask word per invocation
COMMAND_BYTES = 20  # DrawElementsIndirectCommand
SEGMENT_DTYPE = np.dtype([("first", "<u4"), ("count", "<u4"), ("work", "<u4"), ("tag", "<u4")])


@dataclass(frozen=True)
class CullView:
    """One view to cull for: its world-to-clip matrix and size in pixels. ``back_faces``:
    the view draws back faces where others draw front faces (the cube map's back layer,
    cube_map.py: the caller draws only closed objects there, GL culling their front
    faces), so the facing test keeps the other side."""

    view_proj: np.ndarray
    width: int
    height: int
    back_faces: bool = False


def view_segments(views: list[CullView], object_ranges: np.ndarray, object_bounds: np.ndarray,
                  object_closed: np.ndarray | None,
                  include: np.ndarray | None = None,
                  tag_closed: bool = False) -> tuple[np.ndarray, list[int]]:
    """The work list of :mod:`view_cull.comp.glsl`: per view, the triangle runs of the
    objects whose bounds touch it (and, given ``include``, that it selects; a shadow
    layer draws some objects only), adjacent objects of the same back-face class merged,
    each tagged with the view and whether its back faces may be culled (bit 8), and with
    ``tag_closed`` whether the object is closed (bit 9: it belongs in the back layer's
    list); each view's work starts at a multiple of CHUNK_ITEMS. Returns the segments and
    the first chunk of each view plus the total chunk count (V + 1 entries)."""
    ranges = np.asarray(object_ranges, np.int64).reshape(-1, 2)
    closed_objects = (np.zeros(len(ranges), bool) if object_closed is None
                      else np.asarray(object_closed, bool).reshape(-1))
    order = np.argsort(ranges[:, 0], kind="stable")
    rows = []
    view_chunks = [0]
    work = 0
    drawn = ranges[:, 1] > 0
    if include is not None:
        drawn &= include
    all_visible, all_beyond = candidate_masks([view.view_proj for view in views], object_bounds, drawn)
    for index, view in enumerate(views):
        visible = all_visible[index] & drawn
        cullable = visible & closed_objects & all_beyond[index]
        picked = order[visible[order]]
        flags = cullable.astype(np.uint32) << 8
        if tag_closed:
            flags |= closed_objects.astype(np.uint32) << 9
        first, count, flag = ranges[picked, 0], ranges[picked, 1], flags[picked]
        if len(picked):
            # Merge runs: same flag and contiguous triangles.
            starts = np.ones(len(picked), bool)
            starts[1:] = (first[1:] != first[:-1] + count[:-1]) | (flag[1:] != flag[:-1])
            run = np.cumsum(starts) - 1
            run_first = first[starts]
            run_count = np.bincount(run, weights=count).astype(np.int64)
            run_flag = flag[starts]
            run_work = work + np.concatenate([[0], np.cumsum(run_count)[:-1]])
            block = np.empty(len(run_first), SEGMENT_DTYPE)
            block["first"] = run_first
            block["count"] = run_count
            block["work"] = run_work
            block["tag"] = index | run_flag
            rows.append(block)
            work += int(run_count.sum())
        work = math.ceil(work / CHUNK_ITEMS) * CHUNK_ITEMS
        view_chunks.append(work // CHUNK_ITEMS)
    segments = np.concatenate(rows) if rows else np.empty(0, SEGMENT_DTYPE)
    return segments, view_chunks


class CulledDraws:
    """The result of :meth:`ViewTriangleCuller.cull`: an index buffer and the indirect
    command of each view. ``submitted[v]`` is the number of triangles tested for view v
    (its per-object draw list); the survivors are known only to the GPU."""

    def __init__(self, culler: "ViewTriangleCuller", submitted: list[int]) -> None:
        self._culler = culler
        self.submitted = submitted

    def draw(self, program, gpu, view: int) -> int:
        """Draw view ``view``'s survivors with ``program`` (its vertex inputs bound from the
        GPUScene ``gpu``); returns the triangles submitted to the culler for it."""
        if self.submitted[view] == 0:
            return 0
        vao = self._culler.vertex_array(program, gpu)
        vao.render_indirect(self._culler.commands.buffer, count=1, first=view)
        return self.submitted[view]

    def draw_all(self, program, gpu) -> int:
        """Draw every view's survivors with one multi-draw of the views' commands in order
        (the draw index is the view: ``program`` is a FACE_VIEWPORTS variant, draw.py
        SceneDrawer.draw_faces); returns the triangles submitted to the culler."""
        if not any(self.submitted):
            return 0
        vao = self._culler.vertex_array(program, gpu)
        vao.render_indirect(self._culler.commands.buffer, count=len(self.submitted), first=0)
        return sum(self.submitted)

    def drawn(self) -> list[int]:
        """Triangles each view drew (reads the commands back: a synchronisation point)."""
        data = np.frombuffer(self._culler.commands.buffer.read(size=COMMAND_BYTES * len(self.submitted)),
                             np.uint32).reshape(-1, 5)
        return [int(data[v, 0]) // 3 if self.submitted[v] else 0 for v in range(len(self.submitted))]


class ViewTriangleCuller:
    """Culls the triangles of up to MAX_VIEWS views' draw lists on the GPU (module doc)."""

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        defines = {"LOCAL_SIZE": LOCAL_SIZE, "MAX_VIEWS": MAX_VIEWS}
        self._compact = shader_loader.compute(ctx, "view_cull/view_cull_compact.comp.glsl", defines)
        self._scan = PrefixScan(ctx)
        self._segments = GrowBuffer(ctx, "view cull segments")
        self._masks = GrowBuffer(ctx, "view cull masks")
        self._counts = GrowBuffer(ctx, "view cull counts")
        self.indices = GrowBuffer(ctx, "view cull indices")
        self.commands = GrowBuffer(ctx, "view cull commands")
        self._vaos: dict[tuple[int, int, int], object] = {}
        self._compact_uniforms: dict = {}  # set by each cull for its compactions
        self._segment_storage = None

    def vertex_array(self, program, gpu):
        """An indexed vertex array of ``program`` over the GPUScene ``gpu``'s attributes and
        the index buffer, cached while neither is re-allocated."""
        key = (id(program), id(gpu), int(gpu.generation), self.indices.allocations)
        vao = self._vaos.get(key)
        if vao is None:
            self._release_vaos()
            vao = self.ctx.vertex_array(program, gpu.vertex_content(program),
                                        index_buffer=self.indices.buffer, index_element_size=4)
            self._vaos[key] = vao
        return vao

    def cull(self, triangles, triangle_count: int, views: list[CullView], object_ranges: np.ndarray,
             object_bounds: np.ndarray, object_closed: np.ndarray | None = None,
             include: np.ndarray | None = None) -> CulledDraws | None:
        """Cull ``views``' draw lists of the scene whose world triangles ((N, 3, 3) float32)
        are in the GL buffer ``triangles`` (of the objects ``include`` selects, all when
        None). None when the index buffer would exceed one storage block (draw directly
        then)."""
        return self._cull(triangles, triangle_count, views, object_ranges, object_bounds, object_closed,
                          include, None)[0]

    def cull_with_back(self, back: "ViewTriangleCuller", triangles, triangle_count: int,
                       views: list[CullView], object_ranges: np.ndarray, object_bounds: np.ndarray,
                       object_closed: np.ndarray) -> tuple[CulledDraws | None, CulledDraws | None]:
        """:meth:`cull` of ``views``, and with the same test of each triangle the back
        layer's lists into ``back``'s buffers: what ``back.cull`` would keep of the same
        views as ``CullView(..., back_faces=True)`` with ``include=object_closed`` (the
        closed objects' back faces; all their triangles where an object is cut by a near
        plane and the GL culls front faces). Both None when either index buffer would
        exceed one storage block (draw directly then)."""
        return self._cull(triangles, triangle_count, views, object_ranges, object_bounds, object_closed,
                          None, back)

    def _cull(self, triangles, triangle_count: int, views: list[CullView], object_ranges: np.ndarray,
              object_bounds: np.ndarray, object_closed: np.ndarray | None, include: np.ndarray | None,
              back: "ViewTriangleCuller | None") -> tuple[CulledDraws | None, CulledDraws | None]:
        if not 1 <= len(views) <= MAX_VIEWS:
            raise ValueError(f"between 1 and {MAX_VIEWS} views can be culled at once, got {len(views)}")
        paired = back is not None
        segments, view_chunks = view_segments(views, object_ranges, object_bounds, object_closed, include,
                                              tag_closed=paired)
        view_of = segments["tag"] & 0xFF

        def per_view(weights: np.ndarray) -> list[int]:
            return np.bincount(view_of, weights=weights, minlength=len(views)).astype(np.int64).tolist()

        submitted = per_view(segments["count"])
        pairs = [(self, submitted)]
        if paired:  # the back list tests the closed objects' triangles (tag bit 9)
            pairs.append((back, per_view(segments["count"] * ((segments["tag"] >> 9) & 1))))
        num_chunks = view_chunks[-1]
        total = sum(submitted)
        if 3 * 4 * total > max_block_bytes() or (num_chunks + 1) * 4 > max_block_bytes():
            return None, None
        ctx = self.ctx
        for culler, counts in pairs:
            commands = culler.commands.ensure(COMMAND_BYTES * MAX_VIEWS)
            # The compaction writes the command of each view with work; an empty view's
            # command is zeroed here, so that a multi-draw over all views draws nothing for it.
            for v in (v for v, count in enumerate(counts) if count == 0):
                commands.write(bytes(COMMAND_BYTES), offset=COMMAND_BYTES * v)
        results = tuple(CulledDraws(culler, counts) for culler, counts in pairs)
        if not paired:
            results += (None,)
        if num_chunks == 0:
            return results
        split = input_split(int(triangle_count))
        cull = shader_loader.compute(ctx, "view_cull/view_cull.comp.glsl", {
            "LOCAL_SIZE": LOCAL_SIZE, "MAX_VIEWS": MAX_VIEWS, "PAIRED": int(paired), **input_defines(split)})
        self._segments.upload(segments.tobytes())

        view_proj = np.zeros((MAX_VIEWS, 4, 4), np.float32)
        sizes = np.ones((MAX_VIEWS, 2), np.float32)
        signs = np.ones(MAX_VIEWS, np.float32)
        for v, view in enumerate(views):
            view_proj[v] = np.asarray(view.view_proj, np.float64).T  # column-major for GL
            sizes[v] = (view.width, view.height)
            signs[v] = 1.0 if front_face_winding(view.view_proj) == "ccw" else -1.0
            if view.back_faces:
                signs[v] = -signs[v]
        chunks = np.full(MAX_VIEWS + 1, num_chunks, np.uint32)
        chunks[: len(view_chunks)] = view_chunks
        common = {"u_num_chunks": num_chunks, "u_num_segments": len(segments)}
        self._compact_uniforms = {**common, "u_view_chunks": chunks.tobytes(), "u_num_views": len(views)}
        self._segment_storage = Storage(self._segments.buffer, len(segments) * SEGMENT_DTYPE.itemsize)

        # 1. One bit per item (per list), a count per chunk.
        lists = {}
        for culler, (masks, counts) in zip((self, back), (("ChunkMasks", "ChunkCounts"),
                                                          ("BackChunkMasks", "BackChunkCounts"))):
            if culler is not None:
                lists[masks] = Storage(culler._masks.ensure(num_chunks * 4), num_chunks * 4)
                lists[counts] = Storage(culler._counts.ensure((num_chunks + 1) * 4), (num_chunks + 1) * 4)
        bind(cull, storage={**input_storage(triangles, split), "Segments": self._segment_storage, **lists},
             uniforms={**common, "u_view_proj": view_proj.tobytes(), "u_view_size": sizes.tobytes(),
                       "u_front_sign": signs.tobytes()})
        dispatch(cull, num_chunks, LOCAL_SIZE)
        storage_barrier(ctx)
        for culler, counts in pairs:
            self._compact_into(culler, num_chunks, max(sum(counts), 1))
        ctx.memory_barrier(moderngl.ELEMENT_ARRAY_BARRIER_BIT | moderngl.COMMAND_BARRIER_BIT)
        return results

    def _compact_into(self, culler: "ViewTriangleCuller", num_chunks: int, capacity: int) -> None:
        """Steps 2 and 3 for the masks and counts in ``culler``'s buffers (this culler's
        programs, whose uniforms _cull set): offsets by a scan, then indices and commands."""
        counts = Storage(culler._counts.buffer, (num_chunks + 1) * 4)
        self._scan.run(counts, num_chunks)
        bind(self._compact, storage={"Segments": self._segment_storage,
                                     "ChunkMasks": Storage(culler._masks.buffer, num_chunks * 4),
                                     "ChunkOffsets": counts,
                                     "Indices": Storage(culler.indices.ensure(3 * 4 * capacity), 3 * 4 * capacity),
                                     "Commands": Storage(culler.commands.buffer, COMMAND_BYTES * MAX_VIEWS)},
             uniforms=self._compact_uniforms)
        dispatch(self._compact, num_chunks, LOCAL_SIZE)

    def _release_vaos(self) -> None:
        for vao in self._vaos.values():
            vao.release()
        self._vaos.clear()

    def release(self) -> None:
        self._release_vaos()
        for grow in (self._segments, self._masks, self._counts, self.indices, self.commands):
            grow.release()
        self._scan.release()
