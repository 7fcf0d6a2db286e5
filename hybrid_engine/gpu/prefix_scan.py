# SPDX-License-Identifier: GPL-3.0-or-later
"""An exclusive prefix sum of uint counts, in place, on the GPU, in two shapes.

Stream compaction in the near-cube cull and the per-view raster cull turns per-chunk kept
counts into output offsets with it; the GPU-shaped radix sort turns its digit-major tile
histograms into scatter offsets. Callers bind their counts and call ``run``.

* ``"cpu"`` (gpu_shaders/gpu/scan.comp.glsl): ONE workgroup; each lane sums a contiguous
  run serially, one lane scans the lanes' sums. One dispatch and two barriers: what llvmpipe,
  which runs a workgroup as a loop on one core and pays for each barrier, does fastest.
* ``"gpu"`` (scan_reduce / scan_blocks.comp.glsl): reduce-then-scan over many workgroups
  (Merrill & Grimshaw 2009): block sums, a scan of the block sums (this same scan, down to
  one block), each block scanned in shared memory with its offset added. A GPU would leave all
  but one of its multiprocessors idle on the one-workgroup shape.

:mod:`hybrid_engine.gpu.variants` picks the shape (kernel ``"scan"``); the constructor's
``family`` overrides it for tests and benchmarks.
"""
from __future__ import annotations

import math

from . import shader_loader, variants
from .bindings import Storage, bind
from .dispatch import GrowBuffer, grid_for, storage_barrier

# "cpu": the one workgroup's size.
SCAN_LOCAL_SIZE = 256
# "gpu": 256 lanes of 8 values: a block of 2,048 values per workgroup, so that 2^22 counts
# need one level of block sums and 2^22 more than that only a second.
BLOCK_LOCAL_SIZE = 256
ITEMS_PER_INVOCATION = 8
BLOCK_ITEMS = BLOCK_LOCAL_SIZE * ITEMS_PER_INVOCATION


def resolve_family(kernel: str, ctx, family: str | None) -> str:
    """``family`` if given (validated), else the variant :mod:`variants` picks for ``ctx``'s
    renderer."""
    if family is None:
        return variants.choose(kernel, renderer=str(ctx.info.get("GL_RENDERER", "unknown")))
    if family not in variants.FAMILIES:
        raise variants.VariantError(f"unknown kernel family {family!r}; use one of {variants.FAMILIES}")
    return family


class PrefixScan:
    """The scan programs of one context (compiled once, cached by the loader) and, for the
    ``"gpu"`` shape, its grow-only buffers of block sums (one per level)."""

    def __init__(self, ctx, family: str | None = None) -> None:
        self.ctx = ctx
        self.family = resolve_family("scan", ctx, family)
        if self.family == "cpu":
            self.program = shader_loader.compute(ctx, "gpu/scan.comp.glsl", {"LOCAL_SIZE": SCAN_LOCAL_SIZE})
        else:
            defines = {"LOCAL_SIZE": BLOCK_LOCAL_SIZE, "ITEMS_PER_INVOCATION": ITEMS_PER_INVOCATION}
            self._reduce = shader_loader.compute(ctx, "gpu/scan_reduce.comp.glsl", defines)
            self._blocks = shader_loader.compute(ctx, "gpu/scan_blocks.comp.glsl", defines)
        self._block_sums: list[GrowBuffer] = []

    def run(self, data, count: int) -> None:
        """Replace ``data[0:count]`` (a buffer or Storage range of uint) by its exclusive
        prefix sum and write the total to ``data[count]``; a barrier makes them visible."""
        count = int(count)
        if self.family == "cpu":
            bind(self.program, storage={"Data": data}, uniforms={"u_count": count})
            self.program.run(1, 1, 1)
            storage_barrier(self.ctx)
        else:
            self._run_blocks(data, count, 0)

    def _run_blocks(self, data, count: int, level: int) -> None:
        """Reduce-then-scan of ``data[0:count]``; ``level`` names the block-sum buffer."""
        num_blocks = max(1, math.ceil(count / BLOCK_ITEMS))
        uniforms = {"u_count": count, "u_num_blocks": num_blocks}
        if num_blocks == 1:
            bind(self._blocks, storage={"Data": data, "BlockSums": None},
                 uniforms={**uniforms, "u_use_block_sums": 0})
            self._blocks.run(1, 1, 1)
            storage_barrier(self.ctx)
            return
        if level == len(self._block_sums):
            self._block_sums.append(GrowBuffer(self.ctx, f"prefix scan block sums {level}"))
        nbytes = (num_blocks + 1) * 4
        sums = Storage(self._block_sums[level].ensure(nbytes), nbytes)
        groups = grid_for(num_blocks)
        bind(self._reduce, storage={"Data": data, "BlockSums": sums}, uniforms=uniforms)
        self._reduce.run(*groups, 1)
        storage_barrier(self.ctx)
        self._run_blocks(sums, num_blocks, level + 1)
        bind(self._blocks, storage={"Data": data, "BlockSums": sums}, uniforms={**uniforms, "u_use_block_sums": 1})
        self._blocks.run(*groups, 1)
        storage_barrier(self.ctx)

    def release(self) -> None:
        """Free the block-sum buffers (programs stay in the loader's per-context cache)."""
        for grow in self._block_sums:
            grow.release()
        self._block_sums.clear()
