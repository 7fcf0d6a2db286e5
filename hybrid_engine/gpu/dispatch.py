# SPDX-License-Identifier: GPL-3.0-or-later
"""Compute-dispatch plumbing shared by the LBVH and near-cube passes.

Three driver limits shape every pass, and this module keeps them out of the algorithms:

* A dispatch may have at most ``GL_MAX_COMPUTE_WORK_GROUP_COUNT`` (65,535 here) groups per
  dimension. :func:`dispatch` splits a 1D job into an x-by-y grid; the kernels rebuild the
  flat index with ``gpu_shaders/include/dispatch.glsl`` and guard it with a count uniform.
* A storage block may cover at most ``GL_MAX_SHADER_STORAGE_BLOCK_SIZE`` bytes (128 MiB on
  llvmpipe). bindings.bind binds exactly the range a pass uses (grow-only buffers are
  often larger) and refuses a range past the limit with a specific error instead of leaving
  the result to the driver. An array larger than one block is split by :func:`split_blocks`
  into at most :data:`MAX_SPLIT_BLOCKS` consecutive ranges of one buffer, each bound as a
  storage block of its own (bindings.split_storage); the shaders pick the block with the index
  arithmetic of ``gpu_shaders/include/storage_blocks.glsl``. A split array costs a compare
  and a branch per access, so an array that fits one block is never split and its shaders
  are compiled without the split code.
* Allocating GL buffers every frame costs driver time and fragments memory, so
  :class:`GrowBuffer` only ever grows: once a scene's size has been seen, later frames of the
  same or smaller size allocate nothing.
"""
from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass
from typing import Iterator

import numpy as np

from . import gl_context

# Most storage blocks one array is split into. The LBVH refit binds the most blocks: seven
# single ones plus three split arrays (input triangles, nodes, BVH triangles), 7 + 3 * 3 = 16,
# which is llvmpipe's GL_MAX_COMPUTE_SHADER_STORAGE_BLOCKS. Four 128 MiB blocks hold 8.4M
# nodes, 11.2M BVH triangles or 14.9M input triangles.
MAX_SPLIT_BLOCKS = 4
# Items per block are a multiple of this, so that with items of a multiple of 4 bytes every
# block starts at a multiple of 256 bytes: the largest GL_SHADER_STORAGE_BUFFER_OFFSET_ALIGNMENT
# of common drivers (llvmpipe needs 16).
BLOCK_ITEM_GRANULE = 64

_forced_max_groups: int | None = None
_forced_max_block_bytes: int | None = None


def max_workgroups_x() -> int:
    """Groups allowed in one dimension of a dispatch (overridable for tests)."""
    if _forced_max_groups is not None:
        return _forced_max_groups
    return int(gl_context.limits().max_compute_workgroup_count[0])


def max_block_bytes() -> int:
    """Bytes one storage-buffer binding may cover (overridable for tests)."""
    if _forced_max_block_bytes is not None:
        return _forced_max_block_bytes
    return int(gl_context.limits().max_ssbo_block_bytes)


@contextlib.contextmanager
def forced_limits(max_groups: int | None = None, max_block: int | None = None) -> Iterator[None]:
    """Pretend the driver had smaller limits, so tests can cross them with small inputs."""
    global _forced_max_groups, _forced_max_block_bytes
    saved = (_forced_max_groups, _forced_max_block_bytes)
    try:
        if max_groups is not None:
            if max_groups < 1:
                raise ValueError(f"max_groups must be >= 1, got {max_groups}")
            _forced_max_groups = int(max_groups)
        if max_block is not None:
            if max_block < 16:
                raise ValueError(f"max_block must be >= 16 bytes, got {max_block}")
            _forced_max_block_bytes = int(max_block)
        yield
    finally:
        _forced_max_groups, _forced_max_block_bytes = saved


def grid_for(groups: int) -> tuple[int, int]:
    """Split ``groups`` workgroups into (x, y) with x, y <= the per-dimension limit.

    The grid may overshoot by less than one row of x groups; kernels guard with their count.
    """
    if groups <= 0:
        return 0, 0
    limit = max_workgroups_x()
    groups_x = min(groups, limit)
    groups_y = math.ceil(groups / groups_x)
    if groups_y > limit:
        raise ValueError(
            f"a dispatch of {groups} workgroups exceeds {limit} x {limit}; "
            "split the input into several batches"
        )
    return groups_x, groups_y


def dispatch(program, items: int, local_size: int, items_per_invocation: int = 1) -> tuple[int, int]:
    """Run ``program`` over ``items`` elements, one invocation per ``items_per_invocation``.

    Returns the (x, y) grid used; nothing runs when ``items`` is 0.
    """
    invocations = math.ceil(items / items_per_invocation) if items > 0 else 0
    groups_x, groups_y = grid_for(math.ceil(invocations / local_size))
    if groups_x:
        program.run(groups_x, groups_y, 1)
    return groups_x, groups_y


def storage_barrier(ctx) -> None:
    """Make storage-buffer writes of earlier dispatches visible to later ones."""
    import moderngl

    ctx.memory_barrier(moderngl.SHADER_STORAGE_BARRIER_BIT)


def pass_barrier(ctx) -> None:
    """Make every write of a pass visible to every way the next passes may read it.

    Passes hand their results over as images, storage buffers, textures, index and indirect
    buffers and read-backs, and which way a later pass reads a resource is that pass's own
    business (frame_context.py). GL orders draws and dispatches, but not the incoherent image
    and storage writes of shaders: on a GPU a later pass may read them from stale caches
    (llvmpipe's storage is coherent, which hid a missing barrier there). One full barrier
    where a pass ends costs a cache flush the pass boundary needs anyway; the barriers inside
    a pass stay as narrow as its own dispatches need."""
    import moderngl

    ctx.memory_barrier(moderngl.ALL_BARRIER_BITS)


@dataclass(frozen=True)
class BlockSplit:
    """An array of ``count`` items of ``item_bytes`` bytes spread over ``blocks`` bindings.

    Block b covers items [b * items_per_block, (b + 1) * items_per_block) of ONE buffer; only
    the last block may be shorter. ``blocks == 1`` means the array fits one binding (then
    ``items_per_block`` is ``count``).
    """

    count: int
    item_bytes: int
    items_per_block: int
    blocks: int

    def defines(self, blocks_name: str, size_name: str) -> dict[str, int]:
        """Shader defines of a split array; none for a single block, so that small arrays
        share one compiled program whatever the driver's limit."""
        if self.blocks == 1:
            return {}
        return {blocks_name: self.blocks, size_name: self.items_per_block}

    def ranges(self) -> list[tuple[int, int]]:
        """(byte offset, byte size) of each block; at least one item's bytes."""
        out = []
        total = max(self.count, 1)
        for block in range(self.blocks):
            first = block * self.items_per_block
            items = min(self.items_per_block, total - first)
            out.append((first * self.item_bytes, items * self.item_bytes))
        return out


def max_split_items(item_bytes: int, max_blocks: int = MAX_SPLIT_BLOCKS) -> int:
    """Most items of ``item_bytes`` bytes that ``max_blocks`` storage blocks can hold."""
    single = max_block_bytes() // item_bytes
    per_block = single // BLOCK_ITEM_GRANULE * BLOCK_ITEM_GRANULE
    return max(single, per_block * max_blocks)


def split_blocks(count: int, item_bytes: int, what: str,
                 max_blocks: int = MAX_SPLIT_BLOCKS) -> BlockSplit:
    """How ``count`` items of ``item_bytes`` bytes are bound: one block if they fit the
    driver's storage-block limit, else consecutive blocks of equal size (a multiple of
    :data:`BLOCK_ITEM_GRANULE` items). Raises ``ValueError`` naming ``what`` and the numbers
    when even ``max_blocks`` blocks are too few."""
    count = int(count)
    limit = max_block_bytes()
    if max(count, 1) * item_bytes <= limit:
        return BlockSplit(count, item_bytes, max(count, 1), 1)
    per_block = limit // item_bytes // BLOCK_ITEM_GRANULE * BLOCK_ITEM_GRANULE
    blocks = math.ceil(count / per_block) if per_block else max_blocks + 1
    if blocks > max_blocks:
        raise ValueError(
            f"the {what} ({count} items of {item_bytes} bytes) needs {blocks} storage blocks "
            f"of the driver's {limit}-byte GL_MAX_SHADER_STORAGE_BLOCK_SIZE; at most "
            f"{max_blocks} are supported ({max_blocks * per_block} items)"
        )
    return BlockSplit(count, item_bytes, per_block, blocks)


class GPUMemoryError(RuntimeError):
    """The GPU could not hold a buffer the scene needs; the message names it and its size."""


class SceneLimitError(ValueError):
    """The scene needs more rows than a fixed-size GPU table holds (lamps, shadow maps); the
    message says how many it has, the limit, and what the artist can do."""


class GrowBuffer:
    """A GL buffer that is re-allocated only when a request exceeds its capacity.

    ``allocations`` counts the GL allocations made, so tests can prove that repeated frames
    of the same size allocate nothing.
    """

    def __init__(self, ctx, label: str, min_bytes: int = 256) -> None:
        self._ctx = ctx
        self.label = label
        self._min_bytes = min_bytes
        self.buffer = None
        self.allocations = 0

    @property
    def capacity(self) -> int:
        return 0 if self.buffer is None else self.buffer.size

    def ensure(self, nbytes: int):
        """Return a buffer of at least ``nbytes`` bytes (contents undefined after a grow)."""
        nbytes = max(int(nbytes), self._min_bytes)
        if self.buffer is None or self.buffer.size < nbytes:
            # Grow by 1.25x beyond the request so that slowly growing scenes settle quickly.
            capacity = max(nbytes, self.capacity + self.capacity // 4)
            capacity = (capacity + 255) // 256 * 256
            if self.buffer is not None:
                self.buffer.release()
                self.buffer = None
            self.buffer = self._allocate(capacity, nbytes)
            self.allocations += 1
        return self.buffer

    def _allocate(self, capacity: int, needed: int):
        """A new buffer of ``capacity`` bytes, or a GPUMemoryError naming what did not fit when
        the driver refuses it (a scene past the GPU's memory)."""
        try:
            return self._ctx.buffer(reserve=capacity)
        except Exception as exc:  # noqa: BLE001 - the driver's own words go into the message
            raise GPUMemoryError(self._too_large(needed, str(exc))) from exc

    def _too_large(self, needed: int, reason: str) -> str:
        return (f"the GPU cannot hold the {self.label} ({needed / 2**20:,.1f} MiB): {reason}. The scene "
                "is too large for this GPU's memory: hide or decimate objects, or lower resolutions")

    def upload(self, data: bytes | memoryview) -> object:
        """Copy ``data`` to the start of the buffer, growing it if needed."""
        view = memoryview(data).cast("B")
        buf = self.ensure(len(view))
        if len(view):
            buf.write(view)
        return buf

    def write_at(self, data: bytes | memoryview, offset: int) -> None:
        """Overwrite bytes [offset, offset + len(data)) of the current buffer (no growth:
        the caller re-uploads in full when the data outgrew it)."""
        view = memoryview(data).cast("B")
        if offset < 0 or offset + len(view) > self.capacity:
            raise ValueError(f"{self.label}: write of {len(view)} bytes at {offset} exceeds "
                             f"the buffer's {self.capacity} bytes")
        if len(view):
            self.buffer.write(view, offset=int(offset))

    def release(self) -> None:
        if self.buffer is not None:
            self.buffer.release()
            self.buffer = None


def bytes_of(array: np.ndarray) -> np.ndarray:
    """A flat uint8 view of a contiguous array (no copy)."""
    return np.ascontiguousarray(array).reshape(-1).view(np.uint8)
