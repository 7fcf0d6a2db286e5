# SPDX-License-Identifier: GPL-3.0-or-later
"""hybrid_engine/passes/view_cull/frustum.py: per-object culling of draw calls and the near-plane test that
decides which closed objects may lose their back faces."""
from __future__ import annotations

import math

import numpy as np

from hybrid_engine.scene.camera import look_at, perspective_matrix, view_from_world, orthographic_matrix
from hybrid_engine.passes.view_cull.frustum import beyond_near_plane, draw_ranges, front_face_winding, visible_objects

VIEW = view_from_world(look_at(np.zeros(3), np.array([0.0, 10.0, 0.0])))  # eye at the origin, looking +y
PERSPECTIVE = perspective_matrix(math.radians(60.0), 1.0, 1.0, 100.0) @ VIEW


def boxes(*centres, half=0.5):
    c = np.asarray(centres, np.float64)
    return np.stack([c - half, c + half], axis=1)


def test_objects_outside_the_frustum_are_dropped_and_the_rest_kept():
    mask = visible_objects(PERSPECTIVE, boxes((0, 10, 0), (0, -10, 0), (50, 10, 0), (0, 200, 0)))
    np.testing.assert_array_equal(mask, [True, False, False, False])


def test_only_boxes_wholly_past_the_near_plane_qualify_for_back_face_culling():
    bounds = boxes((0, 10, 0), (0, 1.2, 0), (0, 0, 0), (0, -5, 0))  # far, cut by near, around eye, behind
    np.testing.assert_array_equal(beyond_near_plane(PERSPECTIVE, bounds), [True, False, False, False])
    bad = np.array([[[np.nan] * 3, [1.0] * 3]])
    assert not beyond_near_plane(PERSPECTIVE, bad).any()


def test_front_face_winding_follows_the_views_handedness():
    assert front_face_winding(PERSPECTIVE) == "ccw"
    assert front_face_winding(orthographic_matrix(5.0, 5.0, 0.1, 50.0) @ VIEW) == "ccw"
    mirror = np.diag([-1.0, 1.0, 1.0, 1.0])
    assert front_face_winding(PERSPECTIVE @ mirror) == "cw"


def test_cube_map_faces_keep_counter_clockwise_front_faces():
    from hybrid_engine.passes.cube_map.cube_map import CubeFaces

    faces = CubeFaces.at(np.array([1.0, 2.0, 3.0]), 0.5, 50.0)
    assert all(front_face_winding(m) == "ccw" for m in faces.view_proj)


def test_draw_ranges_merge_adjacent_visible_objects():
    ranges = np.array([[0, 4], [4, 2], [6, 3], [9, 1]])
    assert draw_ranges(np.array([True, True, False, True]), ranges) == [(0, 6), (9, 1)]
