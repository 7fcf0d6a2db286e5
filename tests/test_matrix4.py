# SPDX-License-Identifier: GPL-3.0-or-later
"""4x4 inverse and determinant without LAPACK (hybrid_engine/scene/matrix4.py), against numpy's."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine.scene import matrix4
from hybrid_engine.scene.camera import look_at, perspective_matrix, view_from_world


def test_the_inverse_and_determinant_equal_lapacks_to_rounding(rng):
    for _ in range(500):
        m = rng.normal(size=(4, 4)) * rng.choice([1e-3, 1.0, 1e3])
        np.testing.assert_allclose(matrix4.inverse(m), np.linalg.inv(m), rtol=1e-9, atol=1e-12 * np.abs(np.linalg.inv(m)).max())
        assert matrix4.determinant(m) == pytest.approx(np.linalg.det(m), rel=1e-9, abs=1e-300)


def test_a_view_projection_inverts_back_to_the_identity():
    vp = perspective_matrix(0.8, 16 / 9, 0.01, 1000.0) @ view_from_world(look_at((3.0, -4.0, 2.0), (0.0, 0.0, 0.5)))
    np.testing.assert_allclose(matrix4.inverse(vp) @ vp, np.eye(4), atol=1e-9)


def test_a_singular_matrix_is_refused():
    with pytest.raises(matrix4.SingularMatrixError, match="no inverse"):
        matrix4.inverse(np.diag([1.0, 1.0, 0.0, 1.0]))


def test_affine_inverses_equal_lapacks_and_a_zero_scale_maps_to_the_origin(rng):
    m = np.zeros((64, 4, 4))
    m[:, :3, :] = rng.normal(size=(64, 3, 4))
    m[:, 3, 3] = 1.0
    np.testing.assert_allclose(matrix4.affine_inverses(m), np.linalg.inv(m), rtol=1e-9, atol=1e-9)
    flat = np.diag([2.0, 0.0, 1.0, 1.0])
    flat[:3, 3] = (1.0, 2.0, 3.0)
    np.testing.assert_array_equal(matrix4.affine_inverses(flat[None])[0], np.diag([0.0, 0.0, 0.0, 1.0]))
