# SPDX-License-Identifier: GPL-3.0-or-later
"""hybrid_engine.frame.overlay: the near cube the *Show Near Cube* overlay draws."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine.frame.overlay import near_cube_edges
from hybrid_engine.frame.views import ViewportError


def test_near_cube_edges_are_the_twelve_edges_of_the_cube():
    center, half = np.array([1.0, -2.0, 0.5]), 1.5
    edges = near_cube_edges(center, half)
    assert edges.shape == (12, 2, 3) and edges.dtype == np.float32
    direction = edges[:, 1] - edges[:, 0]
    lengths = np.linalg.norm(direction, axis=1)
    np.testing.assert_allclose(lengths, 2 * half, rtol=1e-6)
    assert ((np.abs(direction) > 1e-6).sum(axis=1) == 1).all()  # axis-aligned
    assert np.bincount(np.argmax(np.abs(direction), axis=1), minlength=3).tolist() == [4, 4, 4]
    corners, uses = np.unique(edges.reshape(-1, 3), axis=0, return_counts=True)
    assert len(corners) == 8 and (uses == 3).all()  # each corner joins three edges
    np.testing.assert_allclose(np.abs(corners - center), half, rtol=1e-6)
    with pytest.raises(ViewportError):
        near_cube_edges(center, 0.0)
