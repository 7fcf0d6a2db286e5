# SPDX-License-Identifier: GPL-3.0-or-later
"""An exclusive prefix sum of a few thousand counts, in place, on the GPU
(gpu_shaders/gpu/scan.comp.glsl).

Stream compaction in the near-cube cull and the per-view raster cull turns per-chunk kept
counts into output offsets with it; both passes bind their counts and call ``run``.
"""
from __future__ import annotations

from . import shader_loader
from .bindings import bind
from .dispatch import storage_barrier

# One workgroup scans the whole array: the counts are per chunk of hundreds of items, a few
# thousand at most.
SCAN_LOCAL_SIZE = 256


class PrefixScan:
    """The scan program of one context (compiled once, cached by the loader)."""

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.program = shader_loader.compute(ctx, "gpu/scan.comp.glsl", {"LOCAL_SIZE": SCAN_LOCAL_SIZE})

    def run(self, data, count: int) -> None:
        """Replace ``data[0:count]`` (a buffer or Storage range of uint) by its exclusive
        prefix sum and write the total to ``data[count]``; a barrier makes them visible."""
        bind(self.program, storage={"Data": data}, uniforms={"u_count": int(count)})
        self.program.run(1, 1, 1)
        storage_barrier(self.ctx)
