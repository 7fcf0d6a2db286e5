# SPDX-License-Identifier: GPL-3.0-or-later
"""Which objects are closed, outward-facing surfaces, whose back faces rasterization may skip.

Blender shades both sides of a face, so the raster passes draw without back-face culling.
For a closed surface whose triangles all wind counter-clockwise seen from outside, though,
every back-facing triangle an outside eye could see lies behind a front-facing triangle of
the same surface (a ray that reaches a back face from outside has entered the solid through
a front face first), so culling it changes no depth and no G-buffer texel. On a software
rasterizer, where per-triangle setup dominates, that spares the setup of every back face, a
large part of the raster passes' cost (shadow maps, primary and cube-map G-buffers). The
condition "eye outside" is checked per view and object in :mod:`.frustum` (the object must
lie wholly in front of the near plane: an object cut by the near plane shows its inside).
"""
from __future__ import annotations

import numpy as np


def closed_outward(triangles: np.ndarray) -> bool:
    """True when ``triangles`` ((T, 3, 3)) form closed, consistently oriented surfaces
    enclosing positive volume, after welding corners with identical coordinates (see
    :func:`closed_outward_indexed`). Non-finite or empty input is not closed. Several
    disjoint or interpenetrating closed parts (a knight's head on its body) count as
    closed: each hides its own back faces."""
    tris = np.asarray(triangles, np.float64).reshape(-1, 3, 3)
    if len(tris) < 4 or not np.isfinite(tris).all():
        return False
    positions, ids = np.unique(tris.reshape(-1, 3), axis=0, return_inverse=True)
    return closed_outward_indexed(positions, ids.reshape(-1, 3))


def closed_outward_indexed(positions: np.ndarray, corners: np.ndarray) -> bool:
    """The same test on an indexed mesh: ``corners`` ((T, 3)) index ``positions`` ((V, 3)).

    Closed and consistent: every directed edge (a, b) occurs exactly once and so does its
    reverse (b, a). Outward: the signed volume (divergence theorem) is positive."""
    ids = np.asarray(corners, np.int64).reshape(-1, 3)
    pts = np.asarray(positions, np.float64).reshape(-1, 3)
    if len(ids) < 4 or ids.min() < 0 or ids.max() >= len(pts):
        return False
    count = int(ids.max()) + 1
    tails = np.roll(ids, -1, axis=1)
    keys = np.sort((ids * count + tails).ravel())
    if (keys[1:] == keys[:-1]).any():
        return False  # an edge used twice in the same direction: not a consistent 2-manifold
    if not np.array_equal(keys, np.sort((tails * count + ids).ravel())):
        return False  # an edge without its partner: a hole or a boundary
    a, b, c = pts[ids[:, 0]], pts[ids[:, 1]], pts[ids[:, 2]]
    if not (np.isfinite(a).all() and np.isfinite(b).all() and np.isfinite(c).all()):
        return False
    volume = np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0
    return bool(volume > 0.0)
