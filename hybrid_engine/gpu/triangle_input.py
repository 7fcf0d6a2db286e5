# SPDX-License-Identifier: GPL-3.0-or-later
"""How a pass binds the scene's world-space triangles as its input (triangle_input.glsl).

The near-cube cull, the LBVH build and the per-view raster cull all read the same
(N, 3, 3) float32 triangle buffer, which may span several storage blocks on a driver whose
block limit is smaller than the scene; this module is the one place that plans that split.
"""
from __future__ import annotations

from .bindings import split_storage
from .dispatch import BlockSplit, split_blocks

# Input triangles: 9 float32 (the (N, 3, 3) layout of Geometry.triangles).
INPUT_TRIANGLE_BYTES = 36


def input_split(count: int) -> BlockSplit:
    """How an input buffer of ``count`` triangles is bound (triangle_input.glsl)."""
    return split_blocks(count, INPUT_TRIANGLE_BYTES, "input triangle buffer")


def input_defines(split: BlockSplit) -> dict[str, int]:
    """Defines of triangle_input.glsl for an input bound as ``split``."""
    return split.defines("TRI_INPUT_BLOCKS", "TRI_INPUT_BLOCK_SIZE")


def input_storage(buffer, split: BlockSplit, indices=None) -> dict[str, object]:
    """The storage blocks of triangle_input.glsl: the input triangles bound as ``split``
    and the index list (``indices``: a buffer or Storage range, None when not read)."""
    return {**split_storage("TriangleInput", buffer, split), "TriangleIndex": indices}
