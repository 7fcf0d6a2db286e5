# SPDX-License-Identifier: GPL-3.0-or-later
"""Compute-dispatch plumbing shared by the LBVH and near-cube passes.

Three driver limits shape every pass, and this module keeps them out of the algorithms:

* A dispatch may have at most ``GL_MAX_COMPUTE_WORK_GROUP_COUNT`` (65,535 here) groups per
  dimension. :func:`dispatch` splits a 1D job into an x-by-y grid; the kernels rebuild the
  flat index with ``gpu_shaders/include/dispatch.glsl`` and guard it with a count uniform.
* A storage block may cover at most ``GL_MAX_SHADER_STORAGE_BLOCK_SIZE`` bytes (128 MiB on
  llvmpipe). :func:`bind_storage` binds exactly the range a pass uses (grow-only buffers are
  often larger) and refuses a range past the limit with a specific error instead of leaving
  the result to the driver.
* Allocating GL buffers every frame costs driver time and fragments memory, so
  :class:`GrowBuffer` only ever grows: once a scene's size has been seen, later frames of the
  same or smaller size allocate nothing.
"""
from __future__ import annotations

import contextlib
import math
from typing import Iterator

from . import gl_context

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


def bind_storage(buffer, binding: int, offset: int = 0, size: int | None = None) -> None:
    """Bind ``buffer[offset:offset+size]`` to a storage binding, within the block-size limit."""
    if size is None:
        size = buffer.size - offset
    if size > max_block_bytes():
        raise ValueError(
            f"binding {binding}: a {size}-byte storage range exceeds the driver's "
            f"{max_block_bytes()}-byte block limit"
        )
    buffer.bind_to_storage_buffer(binding, offset=offset, size=max(size, 4))


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
            self.buffer = self._ctx.buffer(reserve=capacity)
            self.allocations += 1
        return self.buffer

    def upload(self, data: bytes | memoryview) -> object:
        """Copy ``data`` to the start of the buffer, growing it if needed."""
        view = memoryview(data).cast("B")
        buf = self.ensure(len(view))
        if len(view):
            buf.write(view)
        return buf

    def release(self) -> None:
        if self.buffer is not None:
            self.buffer.release()
            self.buffer = None
