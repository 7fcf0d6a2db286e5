# SPDX-License-Identifier: GPL-3.0-or-later
"""Generated's texture space (passes/scene_upload/node_programs.py ``texture_space``): the
mesh's object-space bounds as Blender's automatic texture space makes them, with an axis the
mesh is flat along (to rounding) held flat, so that Generated reads 0.5 across it. Through
Blender's render path: tests/test_node_cube_hits.py
``test_a_bumps_generated_and_attribute_heights_step_as_in_cycles_on_either_face``."""
from __future__ import annotations

import numpy as np

from hybrid_engine.passes.scene_upload.node_programs import TEXTURE_SPACE_MIN_HALF_SIZE, texture_space


def test_the_texture_space_is_the_bounds_of_the_finite_points():
    points = np.array([[-1.0, 2.0, 0.5], [3.0, 4.0, -0.5], [np.nan, 9.0, 9.0], [0.0, 3.0, 0.0]], np.float32)
    corner, size = texture_space(points)
    np.testing.assert_allclose(corner, [-1.0, 2.0, -0.5])
    np.testing.assert_allclose(size, [4.0, 2.0, 1.0])


def test_an_axis_flat_to_rounding_has_no_size_at_its_centre():
    """A grid primitive's vertices lie within 1e-14 of z = 0: scaled to 0..1 by their own
    extent, the noise would make Generated's z anything."""
    points = np.array([[-1.5, -1.5, 5e-15], [1.5, -1.5, -5e-15], [1.5, 1.5, 0.0]], np.float32)
    corner, size = texture_space(points)
    np.testing.assert_allclose(size, [3.0, 3.0, 0.0])
    np.testing.assert_allclose(corner, [-1.5, -1.5, 0.0], atol=1e-14)


def test_an_axis_just_thicker_than_blenders_floor_keeps_its_extent():
    half = 2.0 * TEXTURE_SPACE_MIN_HALF_SIZE
    points = np.array([[0.0, 0.0, -half], [1.0, 1.0, half]], np.float32)
    corner, size = texture_space(points)
    np.testing.assert_allclose(size[2], 2.0 * half, rtol=1e-6)
    np.testing.assert_allclose(corner[2], -half, rtol=1e-6)


def test_no_finite_point_gives_a_flat_space_at_the_origin():
    corner, size = texture_space(np.full((2, 3), np.inf, np.float32))
    assert not corner.any() and not size.any()
