# SPDX-License-Identifier: GPL-3.0-or-later
"""Per-pass frame timing.

GL timer queries return meaningless values on llvmpipe, so passes are timed as wall-clock
intervals bracketed with ``ctx.finish()``. The brackets force a CPU/GPU sync, which is why
timing is opt-in: a disabled timer records nothing and adds no synchronisation at all.
"""
from __future__ import annotations

import time
from contextlib import contextmanager
from typing import Iterator

TIMING_SOURCE_WALL = "wall clock between ctx.finish() calls"


class PassTimer:
    """Accumulates milliseconds per named pass for one frame."""

    def __init__(self, ctx, enabled: bool = True) -> None:
        self.ctx = ctx
        self.enabled = enabled
        self.passes: dict[str, float] = {}
        self.source = TIMING_SOURCE_WALL if enabled else "off"

    @contextmanager
    def measure(self, name: str) -> Iterator[None]:
        if not self.enabled:
            yield
            return
        self.ctx.finish()
        start = time.perf_counter()
        try:
            yield
        finally:
            self.ctx.finish()
            self.passes[name] = self.passes.get(name, 0.0) + (time.perf_counter() - start) * 1e3

    def add(self, name: str, milliseconds: float) -> None:
        """Record a host-side pass measured elsewhere (e.g. depsgraph extraction)."""
        if self.enabled:
            self.passes[name] = self.passes.get(name, 0.0) + float(milliseconds)
