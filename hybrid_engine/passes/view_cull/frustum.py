# SPDX-License-Identifier: GPL-3.0-or-later
"""Per-object frustum culling for draw calls.

On a CPU rasterizer every triangle sent to the GPU costs vertex work even when it is
clipped, so each view (primary camera, shadow-map slots, and later the six cube-map faces)
draws only the objects whose AABB can touch its frustum. The test is conservative: an
object is dropped only when all eight corners lie outside the same clip plane.
"""
from __future__ import annotations

import numpy as np

_CORNER_BITS = np.array([[(i >> 0) & 1, (i >> 1) & 1, (i >> 2) & 1] for i in range(8)], bool)


def visible_objects(view_proj: np.ndarray, object_bounds: np.ndarray) -> np.ndarray:
    """Boolean mask of objects whose AABB may intersect the clip volume of ``view_proj``.

    Objects with empty (inverted or non-finite) bounds are never visible.
    """
    bounds = np.asarray(object_bounds, np.float64).reshape(-1, 2, 3)
    if len(bounds) == 0:
        return np.zeros(0, bool)
    lo, hi = bounds[:, 0], bounds[:, 1]
    valid = np.isfinite(bounds).all(axis=(1, 2)) & (lo <= hi).all(axis=1)
    lo = np.where(valid[:, None], lo, 0.0)
    hi = np.where(valid[:, None], hi, 0.0)
    corners = np.where(_CORNER_BITS[None], hi[:, None, :], lo[:, None, :])  # (K, 8, 3)
    clip = corners @ view_proj[:3, :3].T + view_proj[:3, 3]  # xyz
    w = corners @ view_proj[3, :3] + view_proj[3, 3]
    outside = np.zeros(len(bounds), bool)
    for axis in range(3):
        outside |= (clip[:, :, axis] < -w).all(axis=1)
        outside |= (clip[:, :, axis] > w).all(axis=1)
    return valid & ~outside


def beyond_near_plane(view_proj: np.ndarray, object_bounds: np.ndarray) -> np.ndarray:
    """Boolean mask of objects whose AABB lies wholly in front of the near plane of
    ``view_proj`` (all eight corners have clip z >= -w): the near plane cuts none of them
    and, for a perspective view, the eye lies outside every one. Only such objects may have
    their back faces culled (:mod:`.solids`)."""
    bounds = np.asarray(object_bounds, np.float64).reshape(-1, 2, 3)
    if len(bounds) == 0:
        return np.zeros(0, bool)
    finite = np.isfinite(bounds).all(axis=(1, 2))
    b = np.where(finite[:, None, None], bounds, 0.0)
    corners = np.where(_CORNER_BITS[None], b[:, 1][:, None, :], b[:, 0][:, None, :])
    z = corners @ view_proj[2, :3] + view_proj[2, 3]
    w = corners @ view_proj[3, :3] + view_proj[3, 3]
    return finite & (z >= -w).all(axis=1) & (w > 0).all(axis=1)


def front_face_winding(view_proj: np.ndarray) -> str:
    """"ccw" when triangles wound counter-clockwise seen from outside stay counter-clockwise
    in window space under ``view_proj`` (every proper OpenGL projection of a right-handed
    view: its determinant is negative), "cw" when the view mirrors them."""
    return "ccw" if np.linalg.det(np.asarray(view_proj, np.float64)) < 0 else "cw"


def draw_ranges(mask: np.ndarray, object_ranges: np.ndarray) -> list[tuple[int, int]]:
    """Merge the triangle ranges of visible objects into as few (first, count) runs as
    possible, so that adjacent visible objects cost one draw call."""
    ranges = np.asarray(object_ranges, np.int64).reshape(-1, 2)[np.asarray(mask, bool)]
    ranges = ranges[ranges[:, 1] > 0]
    if len(ranges) == 0:
        return []
    ranges = ranges[np.argsort(ranges[:, 0], kind="stable")]
    starts = ranges[:, 0]
    run_end = np.maximum.accumulate(starts + ranges[:, 1])
    breaks = np.nonzero(starts[1:] > run_end[:-1])[0] + 1
    first_idx = np.concatenate([[0], breaks])
    last_idx = np.concatenate([breaks, [len(ranges)]]) - 1
    firsts, ends = starts[first_idx], run_end[last_idx]
    return [(int(f), int(e - f)) for f, e in zip(firsts, ends)]
