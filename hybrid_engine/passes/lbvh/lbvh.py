# SPDX-License-Identifier: GPL-3.0-or-later
"""Per-frame LBVH on the GPU: Morton codes, radix sort, Karras hierarchy, refit, traversal.

The paper (§3.3) rebuilds a linear BVH (Lauterbach et al. 2009) over the triangles inside the
near cube every frame, so that any deformation is handled without refitting logic on the
CPU. Tree construction is reduced to sorting 30-bit Morton codes; the hierarchy follows Karras
2012 (every inner node built independently from the sorted codes), and boxes are computed
bottom-up with atomic flags. Everything runs in compute shaders under ``gpu_shaders/lbvh/``:

====================  ================================================================
build_count           the element count where an earlier pass left it on the GPU, and
                      the indirect dispatch arguments of hierarchy and refit
centroid_bounds       bounds of the centroids (atomic min/max on order-preserving uints)
morton                one 30-bit code per triangle, bit-identical to the numpy reference
(radix sort)          stable LSD radix sort of the codes (hybrid_engine/gpu/radix_sort.py,
                      in the shape :mod:`hybrid_engine.gpu.variants` picks for the device)
hierarchy             Karras 2012 Algorithm 1 with the index tie-break for equal codes
refit                 triangles reordered into leaf order; boxes bottom-up, atomic flags
trace                 closest hit per ray via gpu_shaders/include/bvh_traverse.glsl
====================  ================================================================

:class:`LBVHBuilder` keeps its programs and grow-only buffers across frames and exposes the
built buffers (:class:`BuiltLBVH`) for the hybrid tracer to bind. :func:`trace_closest` is
the public numpy-in, numpy-out entry point used by tests, benchmarks and the embreex oracle.

The node layout is documented byte for byte in ``gpu_shaders/include/bvh_layout.glsl``;
:data:`NODE_DTYPE` and :data:`TRIANGLE_DTYPE` mirror it.

Arrays past the driver's storage-block limit (128 MiB on llvmpipe: 2^21 nodes, i.e. a BVH of
2.1M triangles, or an input of 3.7M triangles) are bound as up to four ranges of one buffer
(:func:`hybrid_engine.gpu.dispatch.split_blocks`, ``gpu_shaders/include/storage_blocks.glsl``):
one build then holds up to 8.4M triangles and reads a scene of up to 14.9M. The passes are
compiled once per block count; a build that fits single blocks uses the plain programs.

The element count need not be known to the host. The near-cube cull leaves the number of
triangles it kept in a GPU buffer (:class:`DeviceCount`); reading it back would drain the GPU
between the cull and the build, mid-frame. The build is then recorded for a host-side upper
bound, its *capacity* (the number of triangles the cull tested), which sizes every buffer and
the bounds, Morton and sort dispatches, and every kernel reads the real count from the GPU
(``gpu_shaders/include/build_count.glsl``): the Morton pass gives the elements past the count
a padding key above every code, so the stable sort of all capacity keys leaves the real ones
first, and the hierarchy and refit passes run indirectly over exactly the count (the
arguments written on the GPU by ``build_count``; on llvmpipe as fast as a dispatch over the
capacity when the bound is tight, and a third faster when it is loose, and what a GPU wants
too). The capacity is an exact upper bound (the cull cannot keep more than its candidates),
so no build overflows.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import moderngl

from ...gpu import gl_context, shader_loader
from ...gpu.bindings import Storage, bind, split_storage
from ...gpu.device_count import DeviceCount
from ...gpu.radix_sort import KEYS_PER_CHUNK, RadixSort
from ...gpu.triangle_input import input_defines, input_split, input_storage
from ...gpu.dispatch import (
    BlockSplit, GrowBuffer, dispatch, grid_for, max_block_bytes, max_split_items, max_workgroups_x,
    split_blocks, storage_barrier,
)

# Mirror of struct BVHNode in bvh_layout.glsl (64 bytes). Child refs: >= 0 inner node,
# < 0 leaf ~ref (index into the reordered triangles).
NODE_DTYPE = np.dtype(
    [
        ("left_min", "<f4", (3,)),
        ("left_child", "<i4"),
        ("left_max", "<f4", (3,)),
        ("right_child", "<i4"),
        ("right_min", "<f4", (3,)),
        ("parent", "<i4"),
        ("right_max", "<f4", (3,)),
        ("leaf_count", "<i4"),
    ]
)
assert NODE_DTYPE.itemsize == 64, "NODE_DTYPE must match BVHNode (64 bytes) in bvh_layout.glsl"

# Mirror of struct BVHTriangle in bvh_layout.glsl (48 bytes).
TRIANGLE_DTYPE = np.dtype(
    [
        ("v0", "<f4", (3,)),
        ("prim", "<i4"),
        ("v1", "<f4", (3,)),
        ("flags", "<i4"),
        ("v2", "<f4", (3,)),
        ("pad", "<i4"),
    ]
)
assert TRIANGLE_DTYPE.itemsize == 48, "TRIANGLE_DTYPE must match BVHTriangle (48 bytes)"

# Workgroup size of the element-wise passes: llvmpipe runs 8 lanes per SIMD op (256-bit), a
# 64-lane group is 8 ops per step and keeps enough groups for both CPU threads.
LOCAL_SIZE = 64
MORTON_BITS = 30
# Triangles each invocation of the bounds pass folds before its six atomics.
BOUNDS_ITEMS_PER_INVOCATION = 16
# Ray sorting before tracing (ray_keys.comp.glsl): from this many rays on, trace_buffers
# orders the rays by a Morton code of their origins (a radix sort of 24-bit keys) so
# that the 8 lanes of a SIMD vector trace neighbouring rays. The sort's ten dispatches have a
# fixed cost each, which a few thousand rays' coherence does not pay back.
RAY_SORT_MIN_RAYS = 4096
RAY_KEY_BITS = 24

# The storage blocks of a built LBVH (bvh_storage.glsl, bvh_traverse.glsl), each followed
# by its blocks 1..3 when split: the node array seen as nodes and as dvec4 halves, and the
# triangles in leaf order.
BVH_BLOCKS = ("BVHNodes", "BVHNodeHalves", "BVHTriangles")

_INPUT_DEFINES = {"LOCAL_SIZE": LOCAL_SIZE}

_ORDERED_MIN_RESET = 0xFFFFFFFF
_ORDERED_MAX_RESET = 0
# The BuildCount block (build_count.glsl): the count, then (x, y, z) groups of the hierarchy
# and of the refit, as uint32 words; the indirect dispatches read them at these byte offsets.
BUILD_COUNT_WORDS = 7
HIERARCHY_ARGS_OFFSET = 4
REFIT_ARGS_OFFSET = 16


@dataclass
class BuiltLBVH:
    """GPU buffers of one build, valid until the next build on the same builder.

    ``nodes``: BVHNode[max(leaf_count - 1, 1)], root at 0. ``triangles``: BVHTriangle[leaf_count]
    in leaf (Morton) order. ``leaf_primitives``: uint[leaf_count], original triangle index of
    each leaf (the index map; also stored in BVHTriangle.prim). ``sorted_keys``: the sorted
    Morton codes. ``node_split`` / ``triangle_split``: how the node and triangle arrays are
    bound (one block each below 2.1M leaves at 128 MiB blocks); a shader that traverses the
    build compiles with :meth:`traversal_defines` and binds :meth:`storage`.

    The leaf count lives on the GPU: ``count`` is a :class:`DeviceCount` (word 0 of the
    builder's BuildCount buffer) and ``capacity`` the host's upper bound the arrays are sized
    for. ``leaf_count`` is the count on the host: known when the build was given it, else read
    back (a synchronisation point; the frame never asks, its statistics copy the count).
    """

    nodes: object
    triangles: object
    leaf_primitives: object
    sorted_keys: object
    count: DeviceCount
    capacity: int
    node_split: BlockSplit
    triangle_split: BlockSplit
    known_count: int | None = None

    @property
    def leaf_count(self) -> int:
        return self.known_count if self.known_count is not None else self.count.read()

    @property
    def node_count(self) -> int:
        return max(self.leaf_count - 1, 1)

    def traversal_defines(self) -> dict[str, int]:
        """Defines a shader including bvh_traverse.glsl needs for this build: none unless an
        array spans several storage blocks (programs are cached per define set)."""
        return {
            **self.node_split.defines("BVH_NODE_BLOCKS", "BVH_NODE_BLOCK_SIZE"),
            **self.triangle_split.defines("BVH_TRIANGLE_BLOCKS", "BVH_TRIANGLE_BLOCK_SIZE"),
        }

    def storage(self) -> dict[str, object]:
        """The node and triangle arrays by the names of bvh_storage.glsl and
        bvh_traverse.glsl (:data:`BVH_BLOCKS`), split as built."""
        return {**split_storage("BVHNodes", self.nodes, self.node_split),
                **split_storage("BVHNodeHalves", self.nodes, self.node_split),
                **split_storage("BVHTriangles", self.triangles, self.triangle_split)}

    def read_nodes(self) -> np.ndarray:
        raw = _read(self.nodes, self.node_count * NODE_DTYPE.itemsize)
        return np.frombuffer(raw, dtype=NODE_DTYPE).copy()

    def read_triangles(self) -> np.ndarray:
        raw = _read(self.triangles, self.leaf_count * TRIANGLE_DTYPE.itemsize)
        return np.frombuffer(raw, dtype=TRIANGLE_DTYPE).copy()

    def read_leaf_primitives(self) -> np.ndarray:
        raw = _read(self.leaf_primitives, self.leaf_count * 4)
        return np.frombuffer(raw, dtype=np.uint32).astype(np.int64)

    def read_sorted_keys(self) -> np.ndarray:
        raw = _read(self.sorted_keys, self.leaf_count * 4)
        return np.frombuffer(raw, dtype=np.uint32).copy()


def _read(buffer, nbytes: int) -> bytes:
    """Read the first ``nbytes`` of a GL buffer (mapping zero bytes is an error in GL)."""
    return buffer.read(size=nbytes) if nbytes > 0 else b""


class LBVHBuilder:
    """Builds the LBVH of a triangle buffer every frame, reusing programs and buffers.

    ``sort_family`` / ``scan_family`` force the radix sort's shape and its histogram scan's
    (default: :mod:`hybrid_engine.gpu.variants`); ``keys_per_chunk`` is the ``"cpu"`` sort's
    chunk."""

    def __init__(self, ctx=None, keys_per_chunk: int = KEYS_PER_CHUNK, sort_family: str | None = None,
                 scan_family: str | None = None) -> None:
        self.ctx = ctx if ctx is not None else gl_context.get_context()
        self.sorter = RadixSort(self.ctx, sort_family, scan_family, keys_per_chunk)
        # Passes that touch split arrays: compiled now for single blocks; variants for split
        # arrays come from the loader's cache (compiled on their first use).
        single = BlockSplit(1, 1, 1, 1)
        self._select_programs(single, single, single)

        ctx = self.ctx
        self._input = GrowBuffer(ctx, "lbvh input triangles")
        self._dummy_index = ctx.buffer(reserve=16)
        # The build's count and its dispatch arguments (build_count.glsl), rewritten per build.
        self._count = ctx.buffer(reserve=BUILD_COUNT_WORDS * 4)
        self._bounds_buffer = ctx.buffer(reserve=24)
        self._keys = (GrowBuffer(ctx, "lbvh keys A"), GrowBuffer(ctx, "lbvh keys B"))
        self._values = (GrowBuffer(ctx, "lbvh values A"), GrowBuffer(ctx, "lbvh values B"))
        self._nodes = GrowBuffer(ctx, "lbvh nodes")
        self._leaf_parent = GrowBuffer(ctx, "lbvh leaf parents")
        self._flags = GrowBuffer(ctx, "lbvh refit flags")
        self._triangles = GrowBuffer(ctx, "lbvh triangles")
        self._rays = (GrowBuffer(ctx, "trace origins"), GrowBuffer(ctx, "trace directions"))
        self._hits = (GrowBuffer(ctx, "trace hit t"), GrowBuffer(ctx, "trace hit triangle"))
        self._ray_keys = (GrowBuffer(ctx, "trace ray keys A"), GrowBuffer(ctx, "trace ray keys B"))
        self._ray_order = (GrowBuffer(ctx, "trace ray order A"),
                           GrowBuffer(ctx, "trace ray order B"))
        self.built: BuiltLBVH | None = None

    # -- building ---------------------------------------------------------------------------

    def build_from_array(self, triangles: np.ndarray) -> BuiltLBVH:
        """Upload an (N, 3, 3) float32 triangle array and build over all of it."""
        tris = _as_triangles(triangles)
        buf = self._input.upload(tris.tobytes())
        return self.build(buf, len(tris))

    def build(self, triangles, count: "int | DeviceCount", indices=None, input_count: int | None = None) -> BuiltLBVH:
        """Build over ``count`` triangles of a GL buffer of packed (N, 3, 3) float32.

        ``count``: an int, or a :class:`DeviceCount` that an earlier pass left on the GPU (the
        near-cube cull's kept count); the build is then sized for its capacity and the count
        is never read back (module docstring). With ``indices`` (a GL buffer of uint32),
        element i is triangle ``indices[i]`` (the near-cube culler's compacted list); the
        reported hits are then indices into ``triangles``. ``input_count`` is the number of
        triangles stored in ``triangles`` (default: ``count`` without indices, else what the
        buffer can hold); only that range is bound.
        """
        ctx = self.ctx
        on_device = isinstance(count, DeviceCount)
        capacity = count.capacity if on_device else int(count)
        if capacity < 0:
            raise ValueError(f"triangle count must be >= 0, got {capacity}")
        use_indices = 1 if indices is not None else 0
        index_buffer = indices if indices is not None else self._dummy_index
        n4 = max(capacity, 1) * 4
        node_count = max(capacity - 1, 1)
        node_bytes = node_count * NODE_DTYPE.itemsize
        tri_bytes = max(capacity, 1) * TRIANGLE_DTYPE.itemsize
        if input_count is None:
            input_count = capacity if indices is None else triangles.size // 36
        in_split, node_split, tri_split = _plan_blocks(capacity, int(input_count))
        self._select_programs(in_split, node_split, tri_split)
        keys = [b.ensure(n4) for b in self._keys]
        values = [b.ensure(n4) for b in self._values]
        nodes = self._nodes.ensure(node_bytes)
        leaf_parent = self._leaf_parent.ensure(n4)
        flags = self._flags.ensure(node_count * 4)
        bvh_tris = self._triangles.ensure(tri_bytes)

        # 0. The count and the dispatch arguments, on the GPU when the GPU holds the count.
        if on_device:
            bind(self._count_program, storage={"SourceCount": count.buffer, "BuildCountOut": self._count},
                 uniforms={"u_source_at": count.offset // 4, "u_capacity": capacity,
                           "u_max_groups_x": max_workgroups_x()})
            self._count_program.run(1, 1, 1)
            ctx.memory_barrier(moderngl.SHADER_STORAGE_BARRIER_BIT | moderngl.COMMAND_BARRIER_BIT)
        else:
            self._count.write(_count_words(capacity).tobytes())
        build_count = {"BuildCount": self._count}

        if capacity > 0:
            # 1. Centroid bounds.
            self._bounds_buffer.write(
                np.array([_ORDERED_MIN_RESET] * 3 + [_ORDERED_MAX_RESET] * 3, np.uint32).tobytes()
            )
            inputs = input_storage(triangles, in_split, Storage(index_buffer, n4 if use_indices else None))
            step = {"u_capacity": capacity, "u_use_indices": use_indices}
            bind(self._bounds, storage={**inputs, **build_count, "Bounds": self._bounds_buffer}, uniforms=step)
            dispatch(self._bounds, capacity, LOCAL_SIZE, BOUNDS_ITEMS_PER_INVOCATION)
            storage_barrier(ctx)

            # 2. Morton codes (padding keys past the count); values carry the original
            # triangle index through the sort.
            bind(self._morton, storage={**inputs, **build_count, "Bounds": self._bounds_buffer,
                                        "Keys": Storage(keys[0], n4), "Values": Storage(values[0], n4)},
                 uniforms=step)
            dispatch(self._morton, capacity, LOCAL_SIZE)
            storage_barrier(ctx)

            # 3. Radix sort of all capacity keys (ping-pong A -> B -> A ...).
            current = self._sort(keys, values, capacity)
        else:
            current = 0

        # 4. Karras hierarchy (also the special roots for N < 2 and the refit flag reset).
        node_blocks = split_storage("BVHNodes", nodes, node_split)
        bind(self._hierarchy, storage={**build_count, "Keys": Storage(keys[current], n4), **node_blocks,
                                       "LeafParent": Storage(leaf_parent, n4),
                                       "RefitFlags": Storage(flags, node_count * 4)})
        self._hierarchy.run_indirect(self._count, HIERARCHY_ARGS_OFFSET)
        storage_barrier(ctx)

        # 5. Reorder triangles and refit boxes bottom-up.
        if capacity > 0:
            bind(self._refit, storage={**input_storage(triangles, in_split), **build_count,
                                       "Values": Storage(values[current], n4),
                                       **node_blocks, "LeafParent": Storage(leaf_parent, n4),
                                       "RefitFlags": Storage(flags, node_count * 4),
                                       **split_storage("BVHTriangles", bvh_tris, tri_split)},
                 uniforms={"u_use_indices": 0})
            self._refit.run_indirect(self._count, REFIT_ARGS_OFFSET)
            storage_barrier(ctx)

        if gl_context.debug_checks_enabled():
            gl_context.check_error("LBVH build")
        self.built = BuiltLBVH(
            nodes=nodes, triangles=bvh_tris, leaf_primitives=values[current],
            sorted_keys=keys[current], count=DeviceCount(self._count, 0, capacity), capacity=capacity,
            node_split=node_split, triangle_split=tri_split, known_count=None if on_device else capacity,
        )
        return self.built

    def _select_programs(self, in_split: BlockSplit, node_split: BlockSplit,
                         tri_split: BlockSplit) -> None:
        """The passes compiled for these block counts (a cache lookup after the first use)."""
        compute = shader_loader.compute
        ctx = self.ctx
        inputs = {**_INPUT_DEFINES, **input_defines(in_split)}
        nodes = node_split.defines("BVH_NODE_BLOCKS", "BVH_NODE_BLOCK_SIZE")
        tris = tri_split.defines("BVH_TRIANGLE_BLOCKS", "BVH_TRIANGLE_BLOCK_SIZE")
        self._bounds = compute(
            ctx, "lbvh/centroid_bounds.comp.glsl",
            {**inputs, "ITEMS_PER_INVOCATION": BOUNDS_ITEMS_PER_INVOCATION},
        )
        self._morton = compute(ctx, "lbvh/morton.comp.glsl", inputs)
        self._hierarchy = compute(ctx, "lbvh/hierarchy.comp.glsl", {"LOCAL_SIZE": LOCAL_SIZE, **nodes})
        self._refit = compute(ctx, "lbvh/refit.comp.glsl", {**inputs, **nodes, **tris})
        self._trace = compute(ctx, "lbvh/trace.comp.glsl", {"LOCAL_SIZE": LOCAL_SIZE, **nodes, **tris})
        self._count_program = compute(ctx, "lbvh/build_count.comp.glsl", {"LOCAL_SIZE": LOCAL_SIZE})

    def _sort(self, keys, values, count: int, bits: int = MORTON_BITS) -> int:
        """Stable radix sort of keys[0]/values[0] on their low ``bits`` bits (whole 8-bit
        digits); returns the index of the sorted pair."""
        return self.sorter.sort(keys, values, count, bits)

    # -- tracing ----------------------------------------------------------------------------

    def trace(
        self, origins: np.ndarray, directions: np.ndarray, tmin: float = 0.0,
        tmax: float = float(np.finfo(np.float32).max), sort_rays: bool | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Closest hits of rays against the last build: (t with inf on miss, tri with -1).

        ``sort_rays`` as in :meth:`trace_buffers` (the results do not depend on it).
        """
        if self.built is None:
            raise RuntimeError("LBVHBuilder.trace() needs a build first")
        org = _as_rays(origins, "origins")
        dirs = _as_rays(directions, "directions")
        if org.shape != dirs.shape:
            raise ValueError(f"origins {org.shape} and directions {dirs.shape} differ in shape")
        count = len(org)
        if count == 0:
            return np.empty(0, np.float32), np.empty(0, np.int32)
        org_buf = self._rays[0].upload(org.tobytes())
        dir_buf = self._rays[1].upload(dirs.tobytes())
        t_buf = self._hits[0].ensure(count * 4)
        tri_buf = self._hits[1].ensure(count * 4)
        self.trace_buffers(org_buf, dir_buf, t_buf, tri_buf, count, tmin, tmax, sort_rays)
        t = np.frombuffer(t_buf.read(size=count * 4), dtype=np.float32).copy()
        tri = np.frombuffer(tri_buf.read(size=count * 4), dtype=np.int32).copy()
        return t, tri

    def trace_buffers(self, origins, directions, hit_t, hit_tri, count: int,
                      tmin: float = 0.0, tmax: float = float(np.finfo(np.float32).max),
                      sort_rays: bool | None = None) -> None:
        """GPU-side trace of ``count`` rays held in GL buffers (float[3M] each).

        ``sort_rays``: trace the rays in the order of their origins' Morton codes
        (ray_keys.comp.glsl; the hits are still stored by ray index). ``None`` sorts from
        :data:`RAY_SORT_MIN_RAYS` rays on.
        """
        built = self.built
        count = int(count)
        if sort_rays is None:
            sort_rays = count >= RAY_SORT_MIN_RAYS
        defines = {"LOCAL_SIZE": LOCAL_SIZE, **built.traversal_defines()}
        order = None
        if sort_rays and count > 0:
            order = Storage(self._order_rays(origins, count), count * 4)
            defines["RAY_ORDER"] = 1
        self._trace = shader_loader.compute(self.ctx, "lbvh/trace.comp.glsl", defines)
        rays = max(count, 1)
        bind(self._trace, storage={**built.storage(), "Origins": Storage(origins, rays * 12),
                                   "Directions": Storage(directions, rays * 12), "HitT": Storage(hit_t, rays * 4),
                                   "HitTri": Storage(hit_tri, rays * 4), "RayOrder": order},
             uniforms={"u_count": count, "u_tmin": float(tmin), "u_tmax": float(tmax)})
        dispatch(self._trace, int(count), LOCAL_SIZE)
        storage_barrier(self.ctx)
        if gl_context.debug_checks_enabled():
            gl_context.check_error("LBVH trace")

    def _order_rays(self, origins, count: int):
        """Sort ``count`` rays by their origins' Morton codes; returns the buffer holding
        the ray indices in traversal order (uint[count])."""
        ctx = self.ctx
        n4 = count * 4
        keys = [b.ensure(n4) for b in self._ray_keys]
        order = [b.ensure(n4) for b in self._ray_order]
        program = shader_loader.compute(ctx, "lbvh/ray_keys.comp.glsl", {"LOCAL_SIZE": LOCAL_SIZE})
        bind(program, storage={**self.built.storage(), "Origins": Storage(origins, count * 12),
                               "Keys": Storage(keys[0], n4), "Values": Storage(order[0], n4)},
             uniforms={"u_count": count})
        dispatch(program, count, LOCAL_SIZE)
        storage_barrier(ctx)
        return order[self._sort(keys, order, count, RAY_KEY_BITS)]

    def release(self) -> None:
        """Free the GL buffers (programs stay in the loader's per-context cache)."""
        self.sorter.release()
        for grow in (self._input, *self._keys, *self._values, self._nodes,
                     self._leaf_parent, self._flags, self._triangles, *self._rays, *self._hits,
                     *self._ray_keys, *self._ray_order):
            grow.release()
        self._dummy_index.release()
        self._count.release()
        self._bounds_buffer.release()
        self.built = None


def max_build_triangles() -> int:
    """Most triangles one build can hold: its node array (N - 1 nodes of 64 bytes) and its
    triangle array (N of 48 bytes) split over at most four storage blocks each, and its
    per-leaf uint arrays (keys, values, parents) within one block."""
    return min(max_split_items(NODE_DTYPE.itemsize) + 1, max_split_items(TRIANGLE_DTYPE.itemsize),
               max_block_bytes() // 4)


def _plan_blocks(count: int, input_count: int) -> tuple[BlockSplit, BlockSplit, BlockSplit]:
    """Block splits of the input, node and triangle arrays of a build over ``count`` triangles
    read from ``input_count``; refuses, with the numbers, what four blocks cannot cover.

    The traversal indexes nodes and triangles randomly, so they cannot be processed in
    windows: they are bound whole, as several blocks (bvh_storage.glsl).
    """
    inputs = input_split(input_count)  # its error names the input buffer and the numbers
    try:
        if max(count, 1) * 4 > max_block_bytes():
            raise ValueError(f"its per-leaf uint arrays exceed the driver's {max_block_bytes()}-byte "
                             "GL_MAX_SHADER_STORAGE_BLOCK_SIZE")
        return (inputs,
                split_blocks(max(count - 1, 1), NODE_DTYPE.itemsize, "node array"),
                split_blocks(count, TRIANGLE_DTYPE.itemsize, "triangle array"))
    except ValueError as err:
        raise ValueError(
            f"an LBVH over {count} triangles cannot be bound: {err}; build at most "
            f"{max_build_triangles()} triangles at once (cull to a smaller near cube)"
        ) from err


def _count_words(count: int) -> np.ndarray:
    """The BuildCount block (build_count.glsl) for a count the host knows: what
    build_count.comp.glsl writes for one it does not."""
    words = np.zeros(BUILD_COUNT_WORDS, np.uint32)
    words[0] = count
    words[1:3] = grid_for(-(-max(count - 1, 1) // LOCAL_SIZE))
    words[3] = 1
    words[4:6] = grid_for(-(-count // LOCAL_SIZE)) if count else (0, 1)
    words[6] = 1
    return words


def _as_triangles(triangles: np.ndarray) -> np.ndarray:
    tris = np.asarray(triangles)
    if tris.ndim != 3 or tris.shape[1:] != (3, 3):
        raise ValueError(f"triangles must have shape (N, 3, 3), got {tris.shape}")
    return np.ascontiguousarray(tris, dtype=np.float32)


def _as_rays(rays: np.ndarray, name: str) -> np.ndarray:
    arr = np.asarray(rays)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"{name} must have shape (M, 3), got {arr.shape}")
    return np.ascontiguousarray(arr, dtype=np.float32)


_builders: dict[int, LBVHBuilder] = {}


def default_builder() -> LBVHBuilder:
    """The builder of the shared context (its buffers persist between calls)."""
    ctx = gl_context.get_context()
    builder = _builders.get(id(ctx))
    if builder is None:
        builder = _builders[id(ctx)] = LBVHBuilder(ctx)
    return builder


def trace_closest(
    triangles: np.ndarray, origins: np.ndarray, directions: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Closest hits of rays against a triangle soup, on the GPU.

    Builds the LBVH over all ``triangles`` ((N, 3, 3) float32; no culling) and traces the rays
    ((M, 3) origins and directions; directions need not be normalised, t is in their units).
    Returns ``t`` ((M,) float32, inf on a miss) and ``tri`` ((M,) int32, original triangle
    index, -1 on a miss). Triangles with NaN/inf coordinates are never hit.
    """
    tris = _as_triangles(triangles)
    org = _as_rays(origins, "origins")
    dirs = _as_rays(directions, "directions")
    if org.shape != dirs.shape:
        raise ValueError(f"origins {org.shape} and directions {dirs.shape} differ in shape")
    builder = default_builder()
    builder.build_from_array(tris)
    return builder.trace(org, dirs)
