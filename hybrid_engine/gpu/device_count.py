# SPDX-License-Identifier: GPL-3.0-or-later
"""A count that stays on the GPU: where one pass left it, and the host's bound of it.

A pass that compacts (the near-cube cull, paper §3.3) knows how many elements it kept only
on the GPU. Reading the number back would make the host wait for the GPU to finish
everything recorded so far, in the middle of the frame; instead the next pass is recorded for
an upper bound the host knows (``capacity``) and reads the count where it lies
(``gpu_shaders/include/build_count.glsl``). ``read()`` exists for tests and diagnostics.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class DeviceCount:
    """A uint32 count in a GL buffer at byte ``offset`` (a multiple of 4), and ``capacity``,
    an upper bound of it that sizes the work recorded for it."""

    buffer: object
    offset: int
    capacity: int

    def read(self) -> int:
        """The count, read back: a synchronisation point (tests, diagnostics)."""
        return int(np.frombuffer(self.buffer.read(size=4, offset=self.offset), np.uint32)[0])
