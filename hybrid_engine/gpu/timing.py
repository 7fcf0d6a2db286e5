# SPDX-License-Identifier: GPL-3.0-or-later
"""Per-pass frame timing.

GL timer queries return meaningless values on llvmpipe, so passes are timed as wall-clock
intervals bracketed with ``ctx.finish()``. The brackets force a CPU/GPU sync, which is why
timing is opt-in: a disabled timer records nothing and adds no synchronisation at all.

Two more figures per pass say where a frame's time goes:

* ``host_passes``: the main thread's CPU time inside the pass, between the brackets. It is
  the host's share (Python, numpy, the driver's submission), without the wait for the GPU
  that the closing ``finish`` adds: on llvmpipe the GPU work runs on llvmpipe's own threads,
  on a GPU on the GPU. A pass whose host time is close to its wall time is host-bound.
* ``gpu_passes``: on a hardware renderer, the GPU's own time for the pass from a timer query
  (GL_TIME_ELAPSED); empty on a software renderer, where such queries mean nothing.
"""
from __future__ import annotations

import time
from contextlib import contextmanager
from typing import Iterator

from . import gl_context

TIMING_SOURCE_WALL = "wall clock between ctx.finish() calls"

# One timer query per context, reused by every frame's timer (moderngl's queries are not
# released one by one, and a frame allocates nothing).
_queries: dict[int, object] = {}


def _timer_query(ctx):
    query = _queries.get(id(ctx))
    if query is None:
        query = _queries[id(ctx)] = ctx.query(time=True)
    return query


class PassTimer:
    """Accumulates milliseconds per named pass for one frame."""

    def __init__(self, ctx, enabled: bool = True, gpu_queries: bool | None = None) -> None:
        self.ctx = ctx
        self.enabled = enabled
        self.passes: dict[str, float] = {}
        self.host_passes: dict[str, float] = {}
        self.gpu_passes: dict[str, float] = {}
        self.source = TIMING_SOURCE_WALL if enabled else "off"
        if gpu_queries is None:
            gpu_queries = enabled and not gl_context.is_software_renderer()
        self.gpu_queries = bool(enabled and gpu_queries)
        self._query = _timer_query(ctx) if self.gpu_queries else None

    @contextmanager
    def measure(self, name: str) -> Iterator[None]:
        if not self.enabled:
            yield
            return
        self.ctx.finish()
        start, host_start = time.perf_counter(), time.thread_time()
        query = self._query
        try:
            if query is not None:
                with query:
                    yield
            else:
                yield
        finally:
            host = time.thread_time() - host_start
            self.ctx.finish()
            self.passes[name] = self.passes.get(name, 0.0) + (time.perf_counter() - start) * 1e3
            self.host_passes[name] = self.host_passes.get(name, 0.0) + host * 1e3
            if query is not None:
                self.gpu_passes[name] = self.gpu_passes.get(name, 0.0) + query.elapsed * 1e-6

    def add(self, name: str, milliseconds: float) -> None:
        """Record a host-side pass measured elsewhere (e.g. depsgraph extraction)."""
        if self.enabled:
            self.passes[name] = self.passes.get(name, 0.0) + float(milliseconds)
            self.host_passes[name] = self.host_passes.get(name, 0.0) + float(milliseconds)
