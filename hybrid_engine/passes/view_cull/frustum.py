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

_CORNER_BITS = np.array([[(i >> 0) & 1, (i >> 1) & 1, (i >> 2) & 1] for i in range(8)], bool)


def object_corners(object_bounds: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The eight corners of each object's AABB ((K, 8, 3) float64; an object with a
    non-finite bound gets the origin's), which objects have finite bounds, and which have
    valid ones (finite, min <= max). Made once for all the views a pass tests."""
    bounds = np.asarray(object_bounds, np.float64).reshape(-1, 2, 3)
    finite = np.isfinite(bounds).all(axis=(1, 2))
    valid = finite & (bounds[:, 0] <= bounds[:, 1]).all(axis=1)
    b = np.where(finite[:, None, None], bounds, 0.0)
    corners = np.where(_CORNER_BITS[None], b[:, 1][:, None, :], b[:, 0][:, None, :])
    return corners, finite, valid


def frustum_masks(view_projs, object_bounds: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`visible_objects` and :func:`beyond_near_plane` of every view at once, as
    (V, K) masks. A pass tests the same objects against several views (the six cube faces,
    the shadow slots): the corners are made once and every view's clip coordinates come
    from one product, so the host's cost per view is a few array operations whatever the
    object count, not a numpy round per test."""
    matrices = np.asarray(view_projs, np.float64).reshape(-1, 4, 4)
    corners, finite, valid = object_corners(object_bounds)
    views, count = len(matrices), len(corners)
    if count == 0 or views == 0:
        return np.zeros((views, count), bool), np.zeros((views, count), bool)
    # (K*8, 3) @ (3, V*4) + (V*4): row r of view v is corners . M_v[r, :3] + M_v[r, 3].
    linear = matrices[:, :, :3].reshape(views * 4, 3).T
    clip = (corners.reshape(-1, 3) @ linear + matrices[:, :, 3].reshape(-1)).reshape(count, 8, views, 4)
    clip = clip.transpose(2, 0, 1, 3)  # (V, K, 8, 4)
    xyz, w = clip[..., :3], clip[..., 3:]
    outside = ((xyz < -w).all(axis=2) | (xyz > w).all(axis=2)).any(axis=2)
    visible = valid & ~outside
    beyond = finite & (clip[..., 2] >= -clip[..., 3]).all(axis=2) & (clip[..., 3] > 0).all(axis=2)
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
