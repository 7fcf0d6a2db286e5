# SPDX-License-Identifier: GPL-3.0-or-later
"""What the *Show Near Cube* overlay draws: the near cube's edges (paper §3: the cube of
half-size ``near_size`` around the eye, whose faces are the cube map's near planes)."""
from __future__ import annotations

import math

import numpy as np

from .views import ViewportError

# ---------------------------------------------------------------------------------------
# Near cube overlay (paper §3: the cube of half-size near_size around the eye)
# ---------------------------------------------------------------------------------------
# The 12 edges of a cube as pairs of corner indices; corner k has coordinate bit i = axis i.
_CUBE_EDGES = np.array(
    [[0, 1], [2, 3], [4, 5], [6, 7],  # along x
     [0, 2], [1, 3], [4, 6], [5, 7],  # along y
     [0, 4], [1, 5], [2, 6], [3, 7]],  # along z
    np.int64,
)


def near_cube_edges(center, half_size: float) -> np.ndarray:
    """The near cube's 12 edges as (12, 2, 3) float32 world-space segment end points: the
    axis-aligned cube ``center ± half_size`` (the near planes of the six cube-map faces)."""
    c = np.asarray(center, np.float64).reshape(3)
    if not (np.isfinite(c).all() and math.isfinite(half_size) and half_size > 0):
        raise ViewportError(f"near cube needs a finite centre and a positive size, got {center}, {half_size}")
    bits = (np.arange(8)[:, None] >> np.arange(3)[None, :]) & 1
    corners = c + (bits * 2 - 1) * float(half_size)
    return corners[_CUBE_EDGES].astype(np.float32)
