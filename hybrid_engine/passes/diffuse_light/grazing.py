# SPDX-License-Identifier: GPL-3.0-or-later
"""The near cube's grazing triangles: the few BVH leaves the diffuse paths test along the
whole ray (beyond the paper; trace_ray.glsl ``BVH_WHOLE_RAY``).

The cube map is rasterized from the near cube's centre beyond the near planes (paper §3.2).
A surface whose plane passes close to that centre, a wall the camera stands against, is seen
there edge-on: a sliver of texels that the diffuse paths' march slips through, so a room
takes the sky through its wall. The BVH holds the whole triangles that reach into the near
cube, and such a wall's are among them, so a path meets them wherever it crosses them. A
traversal of the whole BVH from outside the near cube found them, but visited 2.8 times the
nodes in Chess (every large triangle that straddles the near cube stretches its ancestors'
boxes, and the paths through those boxes descend towards it), and a second traversal in the
diffuse kernel made a GPU's shading pass two to three times slower, by the kernel's size
more than by the work (docs/BENCHMARKS.md, GPU figures). Only the triangles that reach well
beyond the near cube in a plane close to its centre are seen edge-on, and they are few (none
or a few dozen in most views): their list, collected each frame on the GPU
(``gpu_shaders/diffuse_light/grazing_triangles.comp.glsl``), is what the paths test, every
invocation reading the same few triangles. Where more graze than :data:`GRAZING_CAPACITY`,
the list keeps those whose planes pass nearest the centre (binned in :data:`GRAZING_BINS`
steps), the surfaces seen most nearly edge-on.
"""
from __future__ import annotations

import numpy as np

from ...gpu import shader_loader
from ...gpu.bindings import Storage, bind
from ...gpu.dispatch import dispatch, storage_barrier
from ..lbvh.lbvh import BuiltLBVH

SHADER = "diffuse_light/grazing_triangles.comp.glsl"
LOCAL_SIZE = 64
# The leaves the list holds (grazing_leaves.glsl), and the bins of their planes' distances
# from the centre by which it keeps the nearest when more graze.
GRAZING_CAPACITY = 64
GRAZING_BINS = 8
HEADER_WORDS = 3 + GRAZING_BINS  # the counts and the bins before the leaves
# A grazing triangle reaches more than this many near-cube half-sizes beyond the near cube,
# in a plane that passes within PLANE_REACH of them from its centre. Beyond the near cube's
# faces, such a plane lies at most that angle's tangent off the centre's line of sight (at
# 0.25: 14 degrees at the faces, 1.4 degrees ten half-sizes away), where the cube map's
# texels each span a long stretch of it.
BEYOND = 0.25
PLANE_REACH = 0.25


def grazing_defines() -> dict[str, int]:
    """What every program that reads the list compiles with."""
    return {"GRAZING_CAPACITY": GRAZING_CAPACITY, "GRAZING_BINS": GRAZING_BINS}


class GrazingTriangles:
    """The list's buffer (grazing_leaves.glsl) and the kernels that fill it."""

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.buffer = ctx.buffer(reserve=(HEADER_WORDS + GRAZING_CAPACITY) * 4)
        self._zero = bytes(HEADER_WORDS * 4)

    def collect(self, built: BuiltLBVH, center, near_half: float) -> dict[str, object]:
        """Fill the list from ``built``'s leaves for the near cube at ``center`` of half-size
        ``near_half``; the storage block the tracing kernels bind."""
        defines = {"LOCAL_SIZE": LOCAL_SIZE, **grazing_defines(), **built.traversal_defines()}
        self.buffer.write(self._zero)
        count = built.count
        storage = {**built.storage(), "BuildCount": Storage(count.buffer, None, count.offset),
                   "GrazingLeaves": self.buffer}
        uniforms = {"u_near_center": tuple(float(c) for c in center), "u_near_half": float(near_half),
                    "u_beyond": BEYOND * float(near_half), "u_plane_reach": PLANE_REACH * float(near_half)}
        for step in ({"GRAZING_COUNT": 1}, {}):
            prog = shader_loader.compute(self.ctx, SHADER, {**defines, **step})
            bind(prog, storage=storage, uniforms=uniforms)
            dispatch(prog, built.capacity, LOCAL_SIZE)
            storage_barrier(self.ctx)
        return {"GrazingLeaves": self.buffer}

    def deposit(self, statistics) -> None:
        """Add the count of grazing leaves to the frame's statistics (``grazing_triangles``, all
        of them: past GRAZING_CAPACITY the list held those whose planes pass nearest the
        centre), copied with the frame's other counters rather than read back."""
        statistics.deposit(self.buffer, 1, _grazing_counts)

    def _words(self) -> np.ndarray:
        return np.frombuffer(self.buffer.read(), np.uint32)

    def read(self) -> np.ndarray:
        """The listed leaves, read back (tests)."""
        words = self._words()
        listed = min(int(words[1]) + int(words[2]), GRAZING_CAPACITY)
        return words[HEADER_WORDS:HEADER_WORDS + listed].copy()

    def read_count(self) -> int:
        """How many leaves graze, also those the list does not hold (tests, diagnostics)."""
        return int(self._words()[0])

    def release(self) -> None:
        self.buffer.release()


def _grazing_counts(words: np.ndarray) -> dict[str, int]:
    return {"grazing_triangles": int(np.asarray(words, np.uint32)[0])}
