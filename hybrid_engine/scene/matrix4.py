# SPDX-License-Identifier: GPL-3.0-or-later
"""Inverse and determinant of 4x4 matrices without LAPACK.

A frame inverts a handful of 4x4 matrices (the view, its projection, the cube faces'). numpy's
``linalg`` hands each to LAPACK through a multi-threaded OpenBLAS, whose threads contend with
the GL driver's (llvmpipe runs the GPU work on the same cores) and turn a few microseconds
into most of a millisecond per call. The closed form by 2x2 minors below is plain float64
arithmetic on the calling thread, with the same result to rounding.
"""
from __future__ import annotations

import numpy as np


class SingularMatrixError(ValueError):
    """A matrix without an inverse (determinant 0 or not finite)."""


def _minors(a: list[list[float]]) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The 2x2 minors of the top two rows (s) and of the bottom two (c), as in the
    Laplace expansion of a 4x4 determinant by complementary minors."""
    s = (a[0][0] * a[1][1] - a[1][0] * a[0][1], a[0][0] * a[1][2] - a[1][0] * a[0][2],
         a[0][0] * a[1][3] - a[1][0] * a[0][3], a[0][1] * a[1][2] - a[1][1] * a[0][2],
         a[0][1] * a[1][3] - a[1][1] * a[0][3], a[0][2] * a[1][3] - a[1][2] * a[0][3])
    c = (a[2][0] * a[3][1] - a[3][0] * a[2][1], a[2][0] * a[3][2] - a[3][0] * a[2][2],
         a[2][0] * a[3][3] - a[3][0] * a[2][3], a[2][1] * a[3][2] - a[3][1] * a[2][2],
         a[2][1] * a[3][3] - a[3][1] * a[2][3], a[2][2] * a[3][3] - a[3][2] * a[2][3])
    return s, c


def determinant(matrix) -> float:
    """The determinant of a 4x4 matrix."""
    s, c = _minors(np.asarray(matrix, np.float64).reshape(4, 4).tolist())
    return float(s[0] * c[5] - s[1] * c[4] + s[2] * c[3] + s[3] * c[2] - s[4] * c[1] + s[5] * c[0])


def inverse(matrix) -> np.ndarray:
    """The inverse of a 4x4 matrix (float64); SingularMatrixError when it has none."""
    a = np.asarray(matrix, np.float64).reshape(4, 4).tolist()
    s, c = _minors(a)
    det = s[0] * c[5] - s[1] * c[4] + s[2] * c[3] + s[3] * c[2] - s[4] * c[1] + s[5] * c[0]
    if det == 0.0 or not np.isfinite(det):
        raise SingularMatrixError(f"a 4x4 matrix with determinant {det} has no inverse")
    r = 1.0 / det
    out = [[0.0] * 4 for _ in range(4)]
    out[0][0] = (a[1][1] * c[5] - a[1][2] * c[4] + a[1][3] * c[3]) * r
    out[0][1] = (-a[0][1] * c[5] + a[0][2] * c[4] - a[0][3] * c[3]) * r
    out[0][2] = (a[3][1] * s[5] - a[3][2] * s[4] + a[3][3] * s[3]) * r
    out[0][3] = (-a[2][1] * s[5] + a[2][2] * s[4] - a[2][3] * s[3]) * r
    out[1][0] = (-a[1][0] * c[5] + a[1][2] * c[2] - a[1][3] * c[1]) * r
    out[1][1] = (a[0][0] * c[5] - a[0][2] * c[2] + a[0][3] * c[1]) * r
    out[1][2] = (-a[3][0] * s[5] + a[3][2] * s[2] - a[3][3] * s[1]) * r
    out[1][3] = (a[2][0] * s[5] - a[2][2] * s[2] + a[2][3] * s[1]) * r
    out[2][0] = (a[1][0] * c[4] - a[1][1] * c[2] + a[1][3] * c[0]) * r
    out[2][1] = (-a[0][0] * c[4] + a[0][1] * c[2] - a[0][3] * c[0]) * r
    out[2][2] = (a[3][0] * s[4] - a[3][1] * s[2] + a[3][3] * s[0]) * r
    out[2][3] = (-a[2][0] * s[4] + a[2][1] * s[2] - a[2][3] * s[0]) * r
    out[3][0] = (-a[1][0] * c[3] + a[1][1] * c[1] - a[1][2] * c[0]) * r
    out[3][1] = (a[0][0] * c[3] - a[0][1] * c[1] + a[0][2] * c[0]) * r
    out[3][2] = (-a[3][0] * s[3] + a[3][1] * s[1] - a[3][2] * s[0]) * r
    out[3][3] = (a[2][0] * s[3] - a[2][1] * s[1] + a[2][2] * s[0]) * r
    return np.array(out)


def affine_inverses(matrices) -> np.ndarray:
    """Inverses of (n, 4, 4) affine matrices (object-to-world, world-to-world moves) by the 3x3
    adjugate, float64, the same plain arithmetic as above. A singular one (a zero scale) gives
    zeros, which map every point to the origin: its instance draws nothing anyway."""
    m = np.asarray(matrices, np.float64)
    a = m[:, :3, :3]
    cofactors = np.stack([np.cross(a[:, 1], a[:, 2]), np.cross(a[:, 2], a[:, 0]), np.cross(a[:, 0], a[:, 1])],
                         axis=1)  # rows: the adjugate's columns
    det = np.einsum("ij,ij->i", a[:, 0], cofactors[:, 0])
    scale = np.where(np.abs(det) > 0.0, 1.0 / np.where(det == 0.0, 1.0, det), 0.0)
    inverse3 = np.transpose(cofactors, (0, 2, 1)) * scale[:, None, None]
    out = np.zeros_like(m)
    out[:, :3, :3] = inverse3
    out[:, :3, 3] = -np.einsum("nij,nj->ni", inverse3, m[:, :3, 3])
    out[:, 3, 3] = 1.0
    return out
