# SPDX-License-Identifier: GPL-3.0-or-later
"""Small analytic scenes shared by the renderer tests (planes, boxes, spheres)."""
from __future__ import annotations

import numpy as np


def quad(center, half_u, half_v) -> np.ndarray:
    """Two triangles spanning center ± half_u ± half_v (counter-clockwise seen from u×v)."""
    c, u, v = (np.asarray(x, np.float32) for x in (center, half_u, half_v))
    a, b, cc, d = c - u - v, c + u - v, c + u + v, c - u + v
    return np.array([[a, b, cc], [a, cc, d]], np.float32)


def box(lo, hi) -> np.ndarray:
    """12 outward-facing triangles of an axis-aligned box."""
    lo, hi = np.asarray(lo, np.float32), np.asarray(hi, np.float32)
    c, h = (lo + hi) / 2, (hi - lo) / 2
    ex, ey, ez = np.diag(h)
    faces = [
        quad(c + ex, ey, ez), quad(c - ex, ez, ey),
        quad(c + ey, ez, ex), quad(c - ey, ex, ez),
        quad(c + ez, ex, ey), quad(c - ez, ey, ex),
    ]
    return np.concatenate(faces)


def uv_sphere(center, radius, segments=24, rings=12) -> tuple[np.ndarray, np.ndarray]:
    """Triangles and smooth per-corner normals of a UV sphere."""
    theta = np.linspace(0, np.pi, rings + 1)
    phi = np.linspace(0, 2 * np.pi, segments + 1)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    n = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1)
    a, b = n[:-1, :-1], n[:-1, 1:]
    c, d = n[1:, 1:], n[1:, :-1]
    tri_n = np.concatenate([np.stack([a, d, c], -2).reshape(-1, 3, 3), np.stack([a, c, b], -2).reshape(-1, 3, 3)])
    area = np.linalg.norm(np.cross(tri_n[:, 1] - tri_n[:, 0], tri_n[:, 2] - tri_n[:, 0]), axis=1)
    tri_n = tri_n[area > 1e-9]
    tris = tri_n * radius + np.asarray(center, np.float64)
    return tris.astype(np.float32), tri_n.astype(np.float32)


def ray_box(origins, dirs, lo, hi) -> np.ndarray:
    """Slab test: distance to an axis-aligned box along each ray (inf on miss)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / dirs
        t0 = (np.asarray(lo) - origins) * inv
        t1 = (np.asarray(hi) - origins) * inv
    tmin = np.nanmax(np.minimum(t0, t1), axis=-1)
    tmax = np.nanmin(np.maximum(t0, t1), axis=-1)
    hit = (tmax >= np.maximum(tmin, 0.0))
    return np.where(hit, np.maximum(tmin, 0.0), np.inf)


def ray_plane_z(origins, dirs, z=0.0) -> np.ndarray:
    """Distance to the plane Z = z along each ray (inf when parallel or behind)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (z - origins[..., 2]) / dirs[..., 2]
    return np.where(np.isfinite(t) & (t > 0), t, np.inf)
