# SPDX-License-Identifier: GPL-3.0-or-later
"""The diffuse paths' world-space radiance cache: where a path bounces off its first
surface, a pixel whose history is short takes the light that many paths brought back from
around that spot, instead of its own one path's.

In a closed room most of the light a wall gets has bounced more than once, and one path of
four bounces per pixel and frame carries the noise of every bounce: in a still view's first
samples the later bounces are most of what the denoiser cannot remove (docs/BENCHMARKS.md,
"A still view against clean references"). Every path still traces its whole length, but where
it bounces off its first surface (the path's second vertex, on screen or off it, in the
near-cube BVH or the cube map) it also leaves what the rest of the path brought back there,
times pi (an irradiance sample), in the cell of the world it bounced from
(``gpu_shaders/include/radiance_cache.glsl``). A pixel then counts the cell's mean instead of
its path's own continuation (the world-space caches of Müller et al. 2021 and NVIDIA's SHaRC,
here filled by the paths themselves), where the cell holds ``MIN_DEPOSITS``, by a weight
that falls from 1 where the pixel's denoiser history is new (the first frames of a view,
what the camera uncovers) to 0 where it holds ``HISTORY_FRAMES`` frames. A new history's
estimate then keeps the first bounce's noise (which surface the path meets, lit or
shadowed) and loses most of the later ones'. A long history already averages that many
frames of the pixel's own independent paths, unblurred, where a cell's mean, which changes
slowly, would keep its error from frame to frame (docs/BENCHMARKS.md, "The radiance
cache").

What the cells leave, the first bounce's noise, is then most of a new history's: a pixel
that counts the cells traces up to ``SHORT_PATHS`` / 2 short paths beside its own (fewer as
its history grows, to ``SHORT_FLOOR``), each of which ends where it bounces off its first
surface, on that cell, once the surface's own light is in: one ray and a lamp's or emitter's
estimate instead of a whole path. They count the cell by the pixel's weight as its own paths
do, its own paths' continuations standing in for the rest (``diffuse_gather.comp.glsl``
``path_result``), so the light the pixel converges to is the same. Their first directions
are consecutive points of a lattice, so that a frame's few of them cover the hemisphere
evenly. Where a pixel's first rays escape to the sky a short path is a whole one, and the
sky's smooth light leaves little first-bounce noise: a pixel traces them by the share of its
first rays that did not escape, as its history holds it (none on an open floor).

The cells are cubes a ``CELL_DIVISIONS``-th of the view's height across at their distance from
the camera, in powers of two of the scene's typical object size, and split by the surface's
facing normal: the table holds about as many cells at any resolution, and more pixels leave
more paths in each. Each frame's deposits are folded into the cells' means after the gather
(``gpu_shaders/diffuse_light/radiance_cache_resolve.comp.glsl``), a cell holding at most
``CAP`` deposits; a cell unvisited for ``MAX_AGE`` frames is freed. What a frame reads is the
means as they stood after the last frame.

The cache lives as long as the denoiser's history (DiffuseLightPass): it is used in denoised
frames only and starts over whenever that history does (a frame without the denoiser, a final
render's first sample, another estimate: that frame's paths fill it again), so that an
undenoised frame stays the plain path-traced estimate; and it starts over when a lamp, the
World, a material or an object changes.
"""
from __future__ import annotations

import math

import numpy as np

from ...gpu import shader_loader
from ...gpu.bindings import Bindings, bind
from ...gpu.dispatch import storage_barrier

SLOTS = 1 << 18  # cells the table holds (a power of two)
PROBES = 8  # slots tried from a cell's hash before a deposit is dropped
# A cell's size: the view's height at its distance from the camera over this many (then
# rounded down to a power of two of the typical object size).
CELL_DIVISIONS = 9.0
FIXED_BITS = 24  # the deposits' fixed point: fraction bits
CAP = 64.0  # the deposits a cell's mean holds at most
MAX_AGE = 32  # frames a cell stays without deposits before its slot is freed
MIN_DEPOSITS = 2.0  # deposits a cell's mean needs before a pixel counts it
# The denoiser's history at which a pixel no longer counts the cells: by a weight falling
# from 1 (no history) to 0 there.
HISTORY_FRAMES = 32.0
# Short paths a pixel that counts the cells traces beside its own where its history is new,
# fewer as it grows: SHORT_PATHS over the frames it holds (one at least) plus one (as the
# extra paths of a short history fall), no fewer than SHORT_FLOOR, times the cells' weight
# and the share of its first rays that do not escape, to the nearest whole path
# (diffuse_gather.comp.glsl pixel_paths). Each ends on the cell where it bounces off its
# first surface, one ray and that surface's estimates instead of a whole path, so the first
# bounce, which the cells cannot stand in for, is sampled several times where the history
# has few frames to average.
# The floor keeps a few while the weight lasts, where the eighth sample of a still view
# still shows the first bounce's noise; the schedules measured, and what they cost indoors
# and out, are in docs/BENCHMARKS.md, "Short paths where the first rays meet the scene".
SHORT_PATHS = 12
SHORT_FLOOR = 2
SLOT_BYTES = 64  # radiance_cache.glsl RadianceSlot
RESOLVE_SHADER = "diffuse_light/radiance_cache_resolve.comp.glsl"
LOCAL_SIZE = 64


def radiance_cache_defines() -> dict[str, int]:
    """What every program that reads or writes the cache compiles with."""
    return {"RADIANCE_CACHE_SLOTS": SLOTS, "RADIANCE_PROBES": PROBES, "RADIANCE_FIXED_BITS": FIXED_BITS}


class RadianceCache:
    """The cache's table on the GPU and the step that folds each frame's deposits in."""

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.buffer = ctx.buffer(reserve=SLOTS * SLOT_BYTES)
        self.buffer.clear()
        self.resolve_program = shader_loader.compute(ctx, RESOLVE_SHADER, radiance_cache_defines())
        # Whether a frame has deposited since the table was last cleared (forget clears only
        # then: a scene in motion forgets every frame).
        self.filled = False
        # What the cells' light was gathered for: the lamps, the World, Diffuse Bounces and
        # the image's height (DiffuseLightPass compares).
        self.key: tuple | None = None

    def bindings(self, height: int) -> Bindings:
        """The table, the cells' size for an image ``height`` pixels high, when a pixel
        counts a cell's mean, and its short paths (none until a frame has filled the cells:
        they would all go on as whole paths)."""
        return Bindings(storage={"RadianceCache": self.buffer},
                        uniforms={"u_radiance_cell_pixels": max(float(height) / CELL_DIVISIONS, 1.0),
                                  "u_radiance_min_deposits": MIN_DEPOSITS,
                                  "u_radiance_history_frames": HISTORY_FRAMES,
                                  "u_radiance_short_paths": SHORT_PATHS if self.filled else 0,
                                  "u_radiance_short_floor": SHORT_FLOOR if self.filled else 0})

    def resolve(self) -> None:
        """Fold this frame's deposits into the cells' means (after the gather)."""
        bind(self.resolve_program, storage={"RadianceCache": self.buffer},
             uniforms={"u_cap": CAP, "u_max_age": MAX_AGE})
        self.resolve_program.run(math.ceil(SLOTS / LOCAL_SIZE), 1, 1)
        storage_barrier(self.ctx)
        self.filled = True

    def forget(self) -> None:
        """Empty every cell (the denoiser's history started over, or the light changed)."""
        if self.filled:
            self.buffer.clear()
        self.filled = False

    def read(self) -> tuple[np.ndarray, np.ndarray]:
        """The cells' mean irradiance (n x 3) and the deposits each holds (n), for the slots
        that hold a cell (tests, diagnostics: a read-back)."""
        words = np.frombuffer(self.buffer.read(), np.uint32).reshape(SLOTS, SLOT_BYTES // 4)
        live = words[:, 0] != 0
        means = words[live, 12:16].view(np.float32)
        return means[:, :3].copy(), means[:, 3].copy()

    def release(self) -> None:
        self.buffer.release()
