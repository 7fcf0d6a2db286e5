# SPDX-License-Identifier: GPL-3.0-or-later
"""Near-cube culling on the GPU (paper §3.3): which triangles go into this frame's LBVH.

Only geometry inside the cube formed by the cube-map cameras' near planes (half-size
``near_size`` around the camera) is traced in the BVH; a ray leaving the cube continues in the
cube map. Culling happens in two stages, as in the paper:

1. per object: its world AABB against the cube (outside: dropped, inside: kept whole,
   straddling: go to stage 2), ``gpu_shaders/near_cube_cull/cull_objects.comp.glsl``;
2. per triangle of straddling objects: the exact separating-axis triangle/box test
   (``gpu_shaders/include/tri_box.glsl``) -- not a centroid test, which would drop large
   triangles crossing the cube -- then stream compaction (per-chunk counts, a prefix sum,
   an ordered scatter) into a list of triangle indices.

Stage 2 walks only candidate triangles: the host lists the triangles of objects whose bounds
touch the cube (a slightly larger one, so that the list holds everything stage 1 keeps) and of
no object, from the object table alone, so the objects near the cube, not the whole
scene's triangles, set stage 2's work before any triangle is read.

The cube is grown by a small overlap margin (paper: "by introducing a small overlap of the BVH
and the cube map the possibility of a gap at the boundary due to precision errors is
removed"): triangles just outside the near planes are in both the BVH and the cube map, and
an intersection in the overlap is found by either.

The compacted index list feeds :meth:`hybrid_engine.passes.lbvh.lbvh.LBVHBuilder.build` directly; hit
indices then refer to the full scene's triangles. Nothing is read back: the kept count stays
where the prefix sum left it (a ``DeviceCount`` whose capacity, the number of candidate
triangles, bounds it exactly), and the objects per class are counted on the GPU for the frame's
statistics, which are read after the frame, if at all.

A scene larger than one storage block (3.7M triangles at llvmpipe's 128 MiB) is read as up to
four blocks of the same buffer (``gpu_shaders/include/triangle_input.glsl``), so scenes of up
to 14.9M triangles are culled in one pass; the per-triangle keep flags and the kept indices
(4 bytes each) stay single blocks up to 33M triangles.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...gpu import gl_context, shader_loader
from ...gpu.bindings import Storage, bind
from ...gpu.device_count import DeviceCount
from ...gpu.dispatch import GrowBuffer, dispatch, max_block_bytes, storage_barrier
from ...gpu.prefix_scan import PrefixScan
from ...gpu.triangle_input import input_defines, input_split, input_storage
from ...scene.settings import RenderSettings
from ..frame_context import FrameContext, PassIO
from ..view_cull.frustum import draw_ranges

LOCAL_SIZE = 64
# Triangles each culling invocation walks serially (see the "cpu" radix sort's chunks in gpu/radix_sort.py).
TRIANGLES_PER_CHUNK = 1024
# Overlap of BVH and cube map: a fraction of the cube's half-size plus a floor for tiny cubes,
# several float32 ulps of the cube's coordinates (their rounding is about 6e-8 of their
# magnitude) yet invisible in the image. Both relative: a floor in scene units would be a
# larger share of a millimetre scene's cube than of a metre one's, and move the boundary
# between traced and marched surfaces (paper §3.3) with the scene's scale.
OVERLAP_RELATIVE = 1e-3
OVERLAP_ULPS = 1e-6

CLASS_OUTSIDE = 0
CLASS_INSIDE = 1
CLASS_STRADDLING = 2

_DEFINES = {"LOCAL_SIZE": LOCAL_SIZE}


def overlap_margin(near_size: float, center=None) -> float:
    """How far the culling cube extends beyond the near planes (scene units), for a cube
    centred on ``center`` (the origin when not given)."""
    reach = float(near_size) + (float(np.max(np.abs(np.asarray(center, np.float64)))) if center is not None else 0.0)
    return float(near_size) * OVERLAP_RELATIVE + OVERLAP_ULPS * reach


# Statistics names of the stage-1 classes, in the order of ClassCounts (CLASS_*).
CLASS_COUNT_NAMES = ("objects_near_outside", "objects_near_inside", "objects_near_straddling")


@dataclass
class CullResult:
    """The compacted triangle list of one frame (valid until the next cull), all on the GPU.

    ``indices``: GL buffer of uint32 triangle indices, ascending; ``kept``: how many, where
    the GPU holds the number, with the number of triangles tested as its capacity.
    ``class_counts``: GL buffer of uint32[3], the stage-1 objects per class (CLASS_*).
    The properties below read them back (synchronisation points: tests and diagnostics;
    the frame copies them into its statistics instead).
    """

    indices: object
    kept: DeviceCount
    class_counts: object

    @property
    def count(self) -> int:
        return self.kept.read()

    def read_class_counts(self) -> dict[str, int]:
        return class_counts_of(np.frombuffer(self.class_counts.read(size=12), np.uint32))

    @property
    def objects_inside(self) -> int:
        return self.read_class_counts()["objects_near_inside"]

    @property
    def objects_straddling(self) -> int:
        return self.read_class_counts()["objects_near_straddling"]

    @property
    def objects_outside(self) -> int:
        return self.read_class_counts()["objects_near_outside"]

    def read_indices(self) -> np.ndarray:
        count = self.count
        if count == 0:
            return np.empty(0, np.int64)
        raw = self.indices.read(size=count * 4)
        return np.frombuffer(raw, dtype=np.uint32).astype(np.int64)


def class_counts_of(words: np.ndarray) -> dict[str, int]:
    """The statistics of a ClassCounts block (uint32[3])."""
    return {name: int(words[index]) for index, name in enumerate(CLASS_COUNT_NAMES)}


class NearCubeCuller:
    """Culls triangles against the near cube every frame with persistent programs and buffers
    (the frame's ``cull`` pass)."""

    name = "cull"

    def __init__(self, ctx=None, triangles_per_chunk: int = TRIANGLES_PER_CHUNK) -> None:
        self.ctx = ctx if ctx is not None else gl_context.get_context()
        self.triangles_per_chunk = int(triangles_per_chunk)
        compute = shader_loader.compute
        self._classify = compute(self.ctx, "near_cube_cull/cull_objects.comp.glsl", _DEFINES)
        self._triangles = compute(self.ctx, "near_cube_cull/cull_triangles.comp.glsl", _DEFINES)
        self._scan = PrefixScan(self.ctx)
        self._compact = compute(self.ctx, "near_cube_cull/cull_compact.comp.glsl", _DEFINES)
        ctx = self.ctx
        self._input = GrowBuffer(ctx, "cull input triangles")
        self._object_bounds = GrowBuffer(ctx, "cull object bounds")
        self._object_ranges = GrowBuffer(ctx, "cull object ranges")
        self._object_class = GrowBuffer(ctx, "cull object classes")
        self._flags = GrowBuffer(ctx, "cull keep flags")
        self._counts = GrowBuffer(ctx, "cull chunk counts")
        self._indices = GrowBuffer(ctx, "cull kept indices")
        self._candidates = GrowBuffer(ctx, "cull candidate triangles")
        self._class_counts = ctx.buffer(reserve=16)

    def io(self, settings: RenderSettings) -> PassIO:
        return PassIO(reads=("scene", "world_triangles"), writes=("near_triangles",))

    def run(self, frame: FrameContext) -> None:
        """The triangles of the frame's world buffer that overlap the near cube around the eye."""
        geometry = frame.read("scene").geometry
        buffers = frame.read("world_triangles")
        culled = self.cull(buffers.positions.buffer, buffers.triangle_count, frame.center,
                           frame.settings.near_size, geometry.object_ranges, geometry.object_bounds)
        frame.statistics.deposit(culled.class_counts, 3, class_counts_of)
        frame.write("near_triangles", culled)

    def cull_array(self, triangles: np.ndarray, center, near_size: float,
                   object_ranges: np.ndarray | None = None,
                   object_bounds: np.ndarray | None = None,
                   margin: float | None = None) -> CullResult:
        """Upload an (N, 3, 3) float32 array and cull it (see :meth:`cull`)."""
        tris = np.asarray(triangles)
        if tris.ndim != 3 or tris.shape[1:] != (3, 3):
            raise ValueError(f"triangles must have shape (N, 3, 3), got {tris.shape}")
        tris = np.ascontiguousarray(tris, dtype=np.float32)
        buf = self._input.upload(tris.tobytes())
        return self.cull(buf, len(tris), center, near_size, object_ranges, object_bounds, margin)

    def cull(self, triangles, count: int, center, near_size: float,
             object_ranges: np.ndarray | None = None, object_bounds: np.ndarray | None = None,
             margin: float | None = None) -> CullResult:
        """Keep the triangles of a GL buffer ((N, 3, 3) float32) that overlap the near cube.

        ``object_ranges`` ((K, 2) first, count) and ``object_bounds`` ((K, 2, 3) world
        min/max) drive the per-object stage; without them every triangle is tested. The cube
        is centred on ``center`` with half-size ``near_size`` + ``margin`` (default
        :func:`overlap_margin`).
        """
        ctx = self.ctx
        count = int(count)
        if count < 0:
            raise ValueError(f"triangle count must be >= 0, got {count}")
        split = input_split(count)
        if max(count, 1) * 4 > max_block_bytes():
            raise ValueError(
                f"culling {count} triangles needs {count * 4}-byte keep flags, over the "
                f"driver's {max_block_bytes()}-byte GL_MAX_SHADER_STORAGE_BLOCK_SIZE"
            )
        if not (math.isfinite(near_size) and near_size > 0):
            raise ValueError(f"near_size must be a positive finite number, got {near_size}")
        center = np.asarray(center, dtype=np.float64).reshape(3)
        if not np.isfinite(center).all():
            raise ValueError(f"the cube centre must be finite, got {center}")
        margin = overlap_margin(near_size, center) if margin is None else float(margin)
        half = float(near_size) + margin
        ranges, bounds = _objects(count, object_ranges, object_bounds)
        num_objects = len(ranges)
        candidates, bound = candidates_and_bound(count, ranges, bounds, center, half)
        elements = count if candidates is None else len(candidates)

        self._object_ranges.upload(ranges.tobytes())
        self._object_bounds.upload(bounds.tobytes())
        object_class = self._object_class.ensure(max(num_objects, 1) * 4)
        num_chunks = max(1, math.ceil(elements / self.triangles_per_chunk))
        chunk_size = max(1, math.ceil(elements / num_chunks))
        flags = self._flags.ensure(max(elements, 1) * 4)
        counts = self._counts.ensure((num_chunks + 1) * 4)
        indices = self._indices.ensure(max(count, 1) * 4)
        # The per-triangle pass compiled for the input's block count (cached after first use).
        self._triangles = shader_loader.compute(
            ctx, "near_cube_cull/cull_triangles.comp.glsl", {**_DEFINES, **input_defines(split)}
        )

        cube = {"u_center": tuple(float(c) for c in center), "u_half_size": (half, half, half),
                "u_num_objects": num_objects}
        chunks = {"u_count": elements, "u_chunk_size": chunk_size, "u_num_chunks": num_chunks,
                  "u_use_indices": int(candidates is not None)}
        class_storage = Storage(object_class, max(num_objects, 1) * 4)
        counts_storage = Storage(counts, (num_chunks + 1) * 4)
        candidate_storage = None
        if candidates is not None and elements:
            self._candidates.upload(candidates.tobytes())
            candidate_storage = Storage(self._candidates.buffer, elements * 4)
        # 1. Objects.
        self._class_counts.write(bytes(12))
        bind(self._classify, storage={"ObjectBounds": Storage(self._object_bounds.buffer, num_objects * 24),
                                      "ObjectClass": class_storage, "ClassCounts": self._class_counts},
             uniforms=cube)
        dispatch(self._classify, num_objects, LOCAL_SIZE)
        storage_barrier(ctx)
        # 2. Triangles: flags and per-chunk counts.
        if elements > 0:
            bind(self._triangles, storage={**input_storage(triangles, split, candidate_storage),
                                           "ObjectRanges": Storage(self._object_ranges.buffer, num_objects * 8),
                                           "ObjectClass": class_storage,
                                           "KeepFlags": Storage(flags, elements * 4), "ChunkCounts": counts_storage},
                 uniforms={**cube, **chunks})
            dispatch(self._triangles, num_chunks, LOCAL_SIZE)
            storage_barrier(ctx)
        else:
            counts.write(np.zeros(1, np.uint32).tobytes())
        # 3. Prefix sum of the chunk counts (total at [num_chunks]).
        self._scan.run(counts_storage, num_chunks if elements > 0 else 0)
        # 4. Compaction.
        if elements > 0:
            bind(self._compact, storage={"KeepFlags": Storage(flags, elements * 4), "ChunkOffsets": counts_storage,
                                         "KeptIndices": Storage(indices, elements * 4),
                                         "Candidates": candidate_storage},
                 uniforms=chunks)
            dispatch(self._compact, num_chunks, LOCAL_SIZE)
            storage_barrier(ctx)
        # The kept count: the scan's total, never more than the candidates (``bound``: the
        # triangles of the objects the host found touching the slightly larger cube, and of
        # no object), whether stage 2 walked only them or every triangle.
        total_offset = (num_chunks if elements > 0 else 0) * 4
        if gl_context.debug_checks_enabled():
            gl_context.check_error("near-cube culling")
        return CullResult(indices=indices, kept=DeviceCount(counts, total_offset, min(bound, elements)),
                          class_counts=self._class_counts)

    def release(self) -> None:
        for grow in (self._input, self._object_bounds, self._object_ranges, self._object_class,
                     self._flags, self._counts, self._indices, self._candidates):
            grow.release()
        self._scan.release()
        self._class_counts.release()


# The host's candidate test uses a cube this much larger (relative, plus absolute) than the
# GPU's stage 1, so float32 rounding there can never class an object the host left out.
CANDIDATE_SLACK_RELATIVE = 1e-4
CANDIDATE_SLACK_ABSOLUTE = 1e-4
# Above this share of the scene a candidate list saves too little to be worth uploading.
CANDIDATE_MAX_SHARE = 0.5


def candidate_triangles(count: int, ranges: np.ndarray, bounds: np.ndarray, center: np.ndarray,
                        half: float) -> np.ndarray | None:
    """The ascending uint32 indices of the triangles stage 2 must look at: those of objects
    whose bounds (K, 6: min, max) touch the cube of half-size ``half`` (grown by the slack
    above; non-finite bounds always do) and those of no object. None when that is more than
    CANDIDATE_MAX_SHARE of the ``count`` triangles: stage 2 then walks them all."""
    return candidates_and_bound(count, ranges, bounds, center, half)[0]


def candidates_and_bound(count: int, ranges: np.ndarray, bounds: np.ndarray, center: np.ndarray,
                         half: float) -> tuple[np.ndarray | None, int]:
    """:func:`candidate_triangles`, and how many triangles they are even when it lists none:
    an exact upper bound of what the cull keeps (nothing outside them can be kept), which
    sizes the LBVH build without reading the kept count back."""
    if count == 0:
        return None, 0
    lo, hi = bounds[:, :3].astype(np.float64), bounds[:, 3:].astype(np.float64)
    reach = half * (1.0 + CANDIDATE_SLACK_RELATIVE) + CANDIDATE_SLACK_ABSOLUTE
    with np.errstate(invalid="ignore"):
        touches = ((lo <= center + reach) & (hi >= center - reach)).all(axis=1)
    touches |= ~(np.isfinite(lo).all(axis=1) & np.isfinite(hi).all(axis=1))
    # Runs of triangles of no object: the complement of all ranges' union.
    union = np.asarray(draw_ranges(np.ones(len(ranges), bool), ranges), np.int64).reshape(-1, 2)
    ends = np.concatenate([[0], union[:, 0] + union[:, 1]])
    starts = np.concatenate([union[:, 0], [count]])
    gaps = np.stack([ends, starts - ends], axis=1)
    runs = np.concatenate([ranges[touches].astype(np.int64), gaps[gaps[:, 1] > 0]])
    runs = np.asarray(draw_ranges(np.ones(len(runs), bool), runs), np.int64).reshape(-1, 2)
    total = int(runs[:, 1].sum()) if len(runs) else 0
    if total > CANDIDATE_MAX_SHARE * count:
        return None, total
    if total == 0:
        return np.empty(0, np.uint32), 0
    # Concatenated aranges: element e of run r is runs[r, 0] + (e - start of run r).
    run_start = np.concatenate([[0], np.cumsum(runs[:, 1])[:-1]])
    listed = (np.arange(total, dtype=np.int64) + np.repeat(runs[:, 0] - run_start, runs[:, 1])).astype(np.uint32)
    return listed, total


def _objects(count: int, object_ranges, object_bounds) -> tuple[np.ndarray, np.ndarray]:
    """Validated (K, 2) int32 ranges sorted by first triangle and matching (K, 6) float32 bounds.

    Without objects, one pseudo-object with non-finite bounds covers everything, so every
    triangle takes the exact per-triangle test.
    """
    if object_ranges is None:
        ranges = np.array([[0, count]], dtype=np.int32)
        bounds = np.full((1, 6), np.nan, dtype=np.float32)
        return ranges, bounds
    ranges = np.asarray(object_ranges, dtype=np.int64).reshape(-1, 2)
    if object_bounds is None:
        raise ValueError("object_bounds are required with object_ranges")
    bounds = np.asarray(object_bounds, dtype=np.float64).reshape(len(ranges), 6)
    if (ranges < 0).any() or (ranges[:, 0] + ranges[:, 1] > count).any():
        raise ValueError(f"object_ranges must lie within the {count} triangles")
    order = np.argsort(ranges[:, 0], kind="stable")
    return (np.ascontiguousarray(ranges[order], dtype=np.int32),
            np.ascontiguousarray(bounds[order], dtype=np.float32))
