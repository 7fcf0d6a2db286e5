# SPDX-License-Identifier: GPL-3.0-or-later
"""The checks every scene class runs on the arrays it is given, and the error they raise.

Scene data reaches the core from the Blender adapter, builders and tests as numpy arrays of
any dtype and layout; each class converts them once, here, to contiguous arrays of the
dtype the GPU upload reads, and refuses a wrong shape with a message naming the array.
"""
from __future__ import annotations

import numpy as np


class SceneDataError(ValueError):
    """Scene arrays are malformed (wrong shape, dtype or inconsistent counts)."""


def as_array(values, dtype, shape_tail: tuple[int, ...], name: str) -> np.ndarray:
    """``values`` as a C-contiguous array of ``dtype`` shaped (N, *shape_tail); no copy when
    it already is one. Raises SceneDataError naming ``name`` otherwise."""
    arr = np.ascontiguousarray(np.asarray(values, dtype=dtype))
    if arr.ndim != 1 + len(shape_tail) or tuple(arr.shape[1:]) != shape_tail:
        want = "(N, " + ", ".join(map(str, shape_tail)) + ")" if shape_tail else "(N,)"
        raise SceneDataError(f"{name} must have shape {want}, got {arr.shape}")
    return arr
