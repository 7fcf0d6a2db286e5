# SPDX-License-Identifier: GPL-3.0-or-later
"""The frame's ``lbvh_build`` pass: the LBVH over the triangles the near-cube cull kept
(paper §3.3), or over the whole scene in FULL_BVH mode, the paper's ground truth."""
from __future__ import annotations

from ...scene.settings import RenderSettings
from ..frame_context import FrameContext, PassIO
from .lbvh import LBVHBuilder


def builds_over_near_cube(settings: RenderSettings) -> bool:
    """Whether the BVH holds the near cube's triangles (the hybrid modes) rather than all."""
    return settings.mode != "FULL_BVH"


class LBVHBuildPass:
    """Builds the frame's BVH with one ``LBVHBuilder``, kept across frames."""

    name = "lbvh_build"

    def __init__(self, builder: LBVHBuilder) -> None:
        self.builder = builder

    def io(self, settings: RenderSettings) -> PassIO:
        reads = ("world_triangles", "near_triangles") if builds_over_near_cube(settings) else ("world_triangles",)
        return PassIO(reads=reads, writes=("bvh",))

    def run(self, frame: FrameContext) -> None:
        buffers = frame.read("world_triangles")
        if builds_over_near_cube(frame.settings):
            culled = frame.read("near_triangles")
            # The cull's count stays on the GPU: the build is sized for what it tested.
            built = self.builder.build(buffers.positions.buffer, culled.kept, indices=culled.indices,
                                       input_count=buffers.triangle_count)
        else:
            built = self.builder.build(buffers.positions.buffer, buffers.triangle_count)
        frame.write("bvh", built)
