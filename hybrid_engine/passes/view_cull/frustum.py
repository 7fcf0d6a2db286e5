# SPDX-License-Identifier: GPL-3.0-or-later
"""Per-object frustum culling for draw calls.

On a CPU rasterizer every triangle sent to the GPU costs vertex work even when it is
clipped, so each view (primary camera, shadow-map slots, and later the six cube-map faces)
draws only the objects whose AABB can touch its frustum. The test is conservative: an
object is dropped only when all eight corners lie outside the same clip plane.
"""
from __future__ import annotations

import numpy as np

from ...scene.matrix4 import determinant

def frustum_masks(view_projs, object_bounds: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`visible_objects` and :func:`beyond_near_plane` of every view at once, as
    (V, K) masks. A pass tests the same objects against several views (the six cube faces,
    the shadow slots): one round of array operations for all of them costs the host less
    than a round per view and test."""
    matrices = np.asarray(view_projs, np.float64).reshape(-1, 4, 4)
    bounds = np.asarray(object_bounds, np.float64).reshape(-1, 2, 3)
    views, count = len(matrices), len(bounds)
    if count == 0 or views == 0:
        return np.zeros((views, count), bool), np.zeros((views, count), bool)
    finite = np.isfinite(bounds).all(axis=(1, 2))
    valid = finite & (bounds[:, 0] <= bounds[:, 1]).all(axis=1)
    # Row r of view v at a corner (x, y, z) is ((x M[r,0] + y M[r,1]) + z M[r,2]) + M[r,3]. A
    # corner takes each coordinate from the box's low or high side, so the six products per
    # row are made once and the eight corners are sums of them (the same operations, in the
    # same order, as corner by corner). The objects are the last, contiguous axis, so that
    # every operation is a long loop; a matrix product would go to a threaded BLAS, whose
    # threads contend with the GL driver's. A non-finite box is tested as the origin's.
    sides = np.ascontiguousarray(np.where(finite[:, None, None], bounds, 0.0).transpose(2, 1, 0))  # (axis, side, K)
    row = matrices[:, :, :, None, None]  # (V, row, column, 1, 1)
    px, py, pz = (row[:, :, axis] * sides[axis] for axis in range(3))  # (V, row, side, K)
    offset = matrices[:, :, 3, None, None, None, None]
    clip = ((px[:, :, :, None, None] + py[:, :, None, :, None]) + pz[:, :, None, None, :]) + offset
    clip = clip.reshape(views, 4, 8, count)  # (V, row, corner, K)
    w = clip[:, 3]
    below = -w
    outside = np.zeros((views, count), bool)
    for axis in range(3):
        outside |= (clip[:, axis] < below).all(axis=1)
        outside |= (clip[:, axis] > w).all(axis=1)
    visible = valid & ~outside
    beyond = finite & (clip[:, 2] >= below).all(axis=1) & (w > 0).all(axis=1)
    return visible, beyond


def candidate_masks(view_projs, object_bounds: np.ndarray, candidates: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`frustum_masks` of the objects ``candidates`` selects, False for the others: a
    layer that draws only what moved (the shadows' dynamic layer) tests only that, so its
    cost follows what changed rather than the scene's size."""
    matrices = np.asarray(view_projs, np.float64).reshape(-1, 4, 4)
    picked = np.flatnonzero(candidates)
    visible = np.zeros((len(matrices), len(candidates)), bool)
    beyond = np.zeros_like(visible)
    if len(picked) == len(candidates):
        return frustum_masks(matrices, object_bounds)
    if len(picked):
        bounds = np.asarray(object_bounds).reshape(-1, 2, 3)
        visible[:, picked], beyond[:, picked] = frustum_masks(matrices, bounds[picked])
    return visible, beyond


def visible_objects(view_proj: np.ndarray, object_bounds: np.ndarray) -> np.ndarray:
    """Boolean mask of objects whose AABB may intersect the clip volume of ``view_proj``.

    Objects with empty (inverted or non-finite) bounds are never visible.
    """
    return frustum_masks(view_proj, object_bounds)[0][0]


def beyond_near_plane(view_proj: np.ndarray, object_bounds: np.ndarray) -> np.ndarray:
    """Boolean mask of objects whose AABB lies wholly in front of the near plane of
    ``view_proj`` (all eight corners have clip z >= -w): the near plane cuts none of them
    and, for a perspective view, the eye lies outside every one. Only such objects may have
    their back faces culled (:mod:`.solids`)."""
    return frustum_masks(view_proj, object_bounds)[1][0]


def front_face_winding(view_proj: np.ndarray) -> str:
    """"ccw" when triangles wound counter-clockwise seen from outside stay counter-clockwise
    in window space under ``view_proj`` (every proper OpenGL projection of a right-handed
    view: its determinant is negative), "cw" when the view mirrors them. The determinant is
    matrix4's closed form: a frame asks for tens of windings, and LAPACK's (through a
    threaded OpenBLAS) costs each of them far more than the arithmetic."""
    return "ccw" if determinant(view_proj) < 0 else "cw"


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
