# SPDX-License-Identifier: GPL-3.0-or-later
"""Static and dynamic shadow-map layers, so that an animation re-renders only what moved.

Paper §3.5 renders the shadow maps every frame. On a GPU that is a small cost; on a software
rasterizer it is a large share of the frame for a scene of millions of triangles, most of
which (floors, walls, objects at rest) never move. Every shadow slot therefore has two depth
layers: a *static* one holding the objects that have stayed still, re-rendered only when
one of them changes (it is demoted) or a moving object has rested long enough to join
(``PROMOTE_AFTER_FRAMES``), and a *dynamic* one holding the others, re-rendered when one of
them changes. The lookup takes the nearer of the two depths (lighting.glsl), which is
exactly what one map of all objects holds, so the split never changes the image.

The shadow frusta are fitted to the scene's bounds (shadow_depth.frame_shadow_views); a moving object
would change them, and with them every slot's matrix, every frame. The bounds are
therefore snapped outwards to a grid of 1/32 of their extent (:func:`snapped_bounds`): a
pure function of the current frame, so an incremental render and a fresh one of the same
scene use the same matrices, and the matrices change only when the scene grows past a grid
line.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...scene.changes import GeometryDelta

# Frames an object must stay unchanged before it joins the static layer again. Joining costs
# a static re-render, so an object that moves now and then should not churn it.
PROMOTE_AFTER_FRAMES = 30
# The bounds grid, as a fraction of the bounds' extent (rounded down to a power of two).
BOUNDS_GRID_FRACTION = 1.0 / 32.0


def snapped_bounds(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``lo`` rounded down and ``hi`` rounded up to a power-of-two grid of about 1/32 of the
    largest extent; empty or non-finite bounds are returned unchanged."""
    lo = np.asarray(lo, np.float64)
    hi = np.asarray(hi, np.float64)
    if not (np.isfinite(lo).all() and np.isfinite(hi).all() and (lo <= hi).all()):
        return lo, hi
    extent = float(np.max(hi - lo))
    if extent <= 0.0:
        return lo, hi
    step = 2.0 ** math.floor(math.log2(extent * BOUNDS_GRID_FRACTION))
    return np.floor(lo / step) * step, np.ceil(hi / step) * step


def changed_objects(object_ranges: np.ndarray, delta: GeometryDelta) -> np.ndarray:
    """Bool per object: does its triangle range overlap a range the delta re-uploads.

    The delta's ranges are merged across small gaps, so an unchanged object between two
    changed ones may be reported changed: conservative, never wrong."""
    ranges = np.asarray(object_ranges, np.int64).reshape(-1, 2)
    if delta.full:
        return np.ones(len(ranges), bool)
    changed = np.zeros(len(ranges), bool)
    first, end = ranges[:, 0], ranges[:, 0] + ranges[:, 1]
    for start, count in delta.ranges:
        changed |= (first < start + count) & (end > start) & (ranges[:, 1] > 0)
    return changed


@dataclass(frozen=True)
class ShadowPlan:
    """What to re-render this frame: the static layer (objects in ``static_mask``) and/or
    the dynamic layer (the others)."""

    static_mask: np.ndarray
    render_static: bool
    render_dynamic: bool

    @property
    def anything(self) -> bool:
        return self.render_static or self.render_dynamic


class ShadowCache:
    """Remembers which objects are static and decides what each frame must re-render."""

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Forget everything: the next plan re-renders both layers."""
        self._key: tuple | None = None
        self._static: np.ndarray | None = None
        self._still_frames: np.ndarray | None = None
        self._sequence: int | None = None

    def plan(self, object_ranges: np.ndarray, delta: GeometryDelta, key: tuple) -> ShadowPlan:
        """The plan for a frame whose geometry changed by ``delta``. ``key`` holds everything
        else the maps depend on (lights, slot matrices, resolution): when it changes, both
        layers are re-rendered, each with the objects it held (what moves is the objects'
        business, not the matrices': a sun cascade following the camera would otherwise
        draw the moving objects into its static layer and, demoting them, draw that layer
        again the next frame). When the layout changes or a delta was missed (a frame
        cancelled between upload and shadows), every object starts static."""
        count = len(object_ranges)
        missed = self._sequence is None or delta.sequence != self._sequence + 1
        self._sequence = delta.sequence
        new_key = key != self._key
        self._key = key
        if delta.full or missed or self._static is None or len(self._static) != count:
            # A still scene then never needs the dynamic layer; what moves next frame is
            # demoted then, once.
            self._static = np.ones(count, bool)
            self._still_frames = np.zeros(count, np.int64)
            return ShadowPlan(self._static.copy(), True, True)
        changed = changed_objects(object_ranges, delta)
        self._still_frames = np.where(changed, 0, self._still_frames + 1)
        demoted = changed & self._static
        promoted = ~self._static & (self._still_frames >= PROMOTE_AFTER_FRAMES)
        moved_dynamic = bool((changed & ~self._static).any())
        self._static = (self._static & ~changed) | promoted
        render_static = new_key or bool(demoted.any() or promoted.any())
        return ShadowPlan(self._static.copy(), render_static, render_static or moved_dynamic)
