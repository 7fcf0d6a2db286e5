# SPDX-License-Identifier: GPL-3.0-or-later
"""Stable LSD radix sort of uint keys with uint values on the GPU, in two shapes.

The LBVH reduces tree construction to sorting 30-bit Morton codes (paper §3.3) and orders
rays by 24-bit codes of their origins before tracing; both call :meth:`RadixSort.sort` on a
pair of ping-pong buffers. 8-bit digits, one pass per digit, lowest first; every pass is
stable, so equal keys keep their input order (Karras' index tie-break relies on it).

* ``"cpu"`` (gpu_shaders/gpu/radix_count, radix_scan, radix_scatter): the keys are cut into
  chunks of ``keys_per_chunk`` (2,048) and one invocation walks a chunk serially: a private
  histogram, a one-workgroup column scan of the chunk-major histograms, a serial scatter.
  No shared memory and no barriers: llvmpipe runs a workgroup's lanes as SIMD vectors on one
  core and pays for every barrier with a coroutine switch, while a serial loop costs nothing
  extra. On a GPU it keeps a few percent of the machine busy.
* ``"gpu"`` (radix_tile_count, radix_tile_scatter, and :class:`PrefixScan`): reduce-then-scan
  (Satish, Harris & Garland 2009). Each workgroup of 256 lanes takes a tile of 2,048 keys and
  counts its digits in shared memory, written digit-major; one multi-workgroup exclusive scan
  of that array gives every (digit, tile) its global offset; each workgroup re-reads its
  tile, sorts it by the digit in shared memory with stable 2-bit splits and writes each key to
  its offset plus its rank. Tens of thousands of lanes, coalesced loads and stores.

:mod:`hybrid_engine.gpu.variants` picks the shape (kernel ``"sort"``; the histogram scan of
the ``"gpu"`` shape follows kernel ``"scan"``); the constructor's arguments override both.
``count`` is a host integer: callers that sort a padded range fill its unused keys with
0xFFFFFFFF so that they sort last.
"""
from __future__ import annotations

import math
from typing import Sequence

from . import shader_loader
from .bindings import Storage, bind
from .dispatch import GrowBuffer, dispatch, grid_for, storage_barrier
from .prefix_scan import PrefixScan, resolve_family

# 8-bit digits: 256 counters per chunk or tile fit in L1 / shared memory; 4 passes cover 32 bits.
RADIX_BITS = 8
RADIX = 1 << RADIX_BITS
# "cpu": invocations per workgroup (8 SIMD lanes of llvmpipe, 8 ops per step) and keys each
# invocation walks serially; long chunks amortise the 256-counter histogram of each chunk.
CHUNK_LOCAL_SIZE = 64
KEYS_PER_CHUNK = 2048
# "gpu": a tile is 256 lanes of 8 keys. Larger tiles mean fewer histogram rows to scan but
# more registers and shared memory per workgroup (keys and values of the tile: 16 KiB).
TILE_LOCAL_SIZE = 256
KEYS_PER_INVOCATION = 8
TILE_KEYS = TILE_LOCAL_SIZE * KEYS_PER_INVOCATION


def sort_passes(bits: int) -> int:
    """Digit passes that cover the low ``bits`` bits (whole digits: 30 bits take 4 passes,
    which also order bits 30 and 31)."""
    if not 1 <= bits <= 32:
        raise ValueError(f"a radix sort covers 1 to 32 key bits, got {bits}")
    return math.ceil(bits / RADIX_BITS)


class RadixSort:
    """The programs and the histogram buffer of one context's sort, in one shape.

    ``family``: ``"cpu"`` or ``"gpu"`` (default: :func:`variants.choose` for ``"sort"``);
    ``scan_family`` the same for the ``"gpu"`` shape's histogram scan (kernel ``"scan"``).
    ``keys_per_chunk`` sets the ``"cpu"`` shape's chunk (tests cross chunk boundaries with it).
    """

    def __init__(self, ctx, family: str | None = None, scan_family: str | None = None,
                 keys_per_chunk: int = KEYS_PER_CHUNK) -> None:
        self.ctx = ctx
        self.family = resolve_family("sort", ctx, family)
        self.keys_per_chunk = int(keys_per_chunk)
        if self.keys_per_chunk < 1:
            raise ValueError(f"keys_per_chunk must be >= 1, got {keys_per_chunk}")
        compute = shader_loader.compute
        if self.family == "cpu":
            chunk = {"LOCAL_SIZE": CHUNK_LOCAL_SIZE, "RADIX_BITS": RADIX_BITS}
            self._count = compute(ctx, "gpu/radix_count.comp.glsl", chunk)
            self._column_scan = compute(ctx, "gpu/radix_scan.comp.glsl", {"RADIX_BITS": RADIX_BITS, "RADIX": RADIX})
            self._scatter = compute(ctx, "gpu/radix_scatter.comp.glsl", chunk)
            self.scan = None
        else:
            tile = {"LOCAL_SIZE": TILE_LOCAL_SIZE, "KEYS_PER_INVOCATION": KEYS_PER_INVOCATION,
                    "RADIX_BITS": RADIX_BITS}
            self._count = compute(ctx, "gpu/radix_tile_count.comp.glsl", tile)
            self._scatter = compute(ctx, "gpu/radix_tile_scatter.comp.glsl", tile)
            self.scan = PrefixScan(ctx, scan_family)
        self._histograms = GrowBuffer(ctx, "radix sort histograms")

    def sort_plan(self, count: int) -> tuple[int, int]:
        """(keys per chunk or tile, number of them) for ``count`` keys."""
        if self.family == "gpu":
            return TILE_KEYS, max(1, math.ceil(count / TILE_KEYS))
        num_chunks = max(1, math.ceil(count / self.keys_per_chunk))
        chunk_size = max(1, math.ceil(count / num_chunks))
        return chunk_size, math.ceil(count / chunk_size) if count else 1

    def sort(self, keys: Sequence[object], values: Sequence[object], count: int, bits: int) -> int:
        """Sort ``keys[0][0:count]`` (uint) with ``values[0]`` alongside, stably, on their low
        ``bits`` bits (rounded up to whole digits), ping-ponging through ``keys[1]`` and
        ``values[1]``; returns the index of the pair that holds the result. Each buffer holds
        at least ``count`` uints; both pairs' contents past the result are undefined."""
        count = int(count)
        passes = sort_passes(bits)
        if count == 0:
            return 0
        n4 = count * 4
        pairs = [(Storage(keys[i], n4), Storage(values[i], n4)) for i in (0, 1)]
        pass_run = self._cpu_pass if self.family == "cpu" else self._gpu_pass
        src = 0
        for digit in range(passes):
            pass_run(pairs[src], pairs[1 - src], count, digit * RADIX_BITS)
            src = 1 - src
        return src

    def _cpu_pass(self, source, target, count: int, shift: int) -> None:
        """One digit, chunk-shaped: count, column scan, serial scatter."""
        ctx = self.ctx
        chunk_size, num_chunks = self.sort_plan(count)
        nbytes = num_chunks * RADIX * 4
        histograms = Storage(self._histograms.ensure(nbytes), nbytes)
        plan = {"u_count": count, "u_chunk_size": chunk_size, "u_num_chunks": num_chunks, "u_shift": shift}
        bind(self._count, storage={"Keys": source[0], "Histograms": histograms}, uniforms=plan)
        dispatch(self._count, num_chunks, CHUNK_LOCAL_SIZE)
        storage_barrier(ctx)
        bind(self._column_scan, storage={"Histograms": histograms}, uniforms={"u_num_chunks": num_chunks})
        self._column_scan.run(1, 1, 1)
        storage_barrier(ctx)
        bind(self._scatter, storage={"KeysIn": source[0], "ValuesIn": source[1], "Histograms": histograms,
                                     "KeysOut": target[0], "ValuesOut": target[1]}, uniforms=plan)
        dispatch(self._scatter, num_chunks, CHUNK_LOCAL_SIZE)
        storage_barrier(ctx)

    def _gpu_pass(self, source, target, count: int, shift: int) -> None:
        """One digit, tile-shaped: shared-memory tile histograms, a multi-workgroup scan,
        a stable tile-local rank and scatter."""
        ctx = self.ctx
        _, num_tiles = self.sort_plan(count)
        entries = num_tiles * RADIX
        histograms = Storage(self._histograms.ensure((entries + 1) * 4), (entries + 1) * 4)
        plan = {"u_count": count, "u_num_tiles": num_tiles, "u_shift": shift}
        groups = grid_for(num_tiles)
        bind(self._count, storage={"Keys": source[0], "Histograms": histograms}, uniforms=plan)
        self._count.run(*groups, 1)
        storage_barrier(ctx)
        self.scan.run(histograms, entries)
        bind(self._scatter, storage={"KeysIn": source[0], "ValuesIn": source[1], "Histograms": histograms,
                                     "KeysOut": target[0], "ValuesOut": target[1]}, uniforms=plan)
        self._scatter.run(*groups, 1)
        storage_barrier(ctx)

    def release(self) -> None:
        """Free the histogram and scan buffers (programs stay in the loader's cache)."""
        self._histograms.release()
        if self.scan is not None:
            self.scan.release()
