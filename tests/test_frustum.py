# SPDX-License-Identifier: GPL-3.0-or-later
"""hybrid_engine/passes/view_cull/frustum.py: per-object culling of draw calls and the near-plane test that
decides which closed objects may lose their back faces."""
from __future__ import annotations

import math

import numpy as np

from hybrid_engine.scene.camera import look_at, perspective_matrix, view_from_world, orthographic_matrix
from hybrid_engine.passes.view_cull.frustum import (beyond_near_plane, candidate_masks, draw_ranges, front_face_winding,
                                                  frustum_masks, visible_objects)

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


def _reference_masks(view_proj: np.ndarray, bounds: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each object's eight corners tested one view and one object at a time."""
    visible, beyond = [], []
    for lo, hi in np.asarray(bounds, np.float64):
        finite = bool(np.isfinite(lo).all() and np.isfinite(hi).all())
        corners = [np.array([(hi if (i >> a) & 1 else lo)[a] for a in range(3)] + [1.0]) for i in range(8)]
        clip = np.array([view_proj @ c for c in corners]) if finite else np.zeros((8, 4))
        outside = any((clip[:, a] < -clip[:, 3]).all() or (clip[:, a] > clip[:, 3]).all() for a in range(3))
        visible.append(finite and bool((lo <= hi).all()) and not outside)
        beyond.append(finite and bool((clip[:, 2] >= -clip[:, 3]).all() and (clip[:, 3] > 0).all()))
    return np.array(visible), np.array(beyond)


def test_all_views_tested_at_once_agree_with_each_view_tested_alone(rng):
    centres = rng.uniform(-30.0, 30.0, (200, 3))
    bounds = boxes(*centres, half=1.5)
    bounds[3] = [[np.nan] * 3, [1.0] * 3]  # never visible
    bounds[4] = [[1.0] * 3, [0.0] * 3]  # inverted: never visible
    views = [PERSPECTIVE, orthographic_matrix(20.0, 10.0, 0.1, 50.0) @ VIEW,
             PERSPECTIVE @ np.diag([-1.0, 1.0, 1.0, 1.0])]
    views += [perspective_matrix(math.radians(90.0), 1.0, 0.5, 80.0)
              @ view_from_world(look_at(rng.uniform(-5, 5, 3), rng.uniform(-40, 40, 3))) for _ in range(6)]
    visible, beyond = frustum_masks(views, bounds)
    assert visible.shape == beyond.shape == (len(views), len(bounds))
    for v, view_proj in enumerate(views):
        want_visible, want_beyond = _reference_masks(view_proj, bounds)
        np.testing.assert_array_equal(visible[v], want_visible)
        np.testing.assert_array_equal(beyond[v], want_beyond)
        np.testing.assert_array_equal(visible_objects(view_proj, bounds), want_visible)
    assert visible.any() and (~visible).any() and beyond.any()


def test_no_views_or_no_objects_give_empty_masks():
    visible, beyond = frustum_masks([], boxes((0, 10, 0)))
    assert visible.shape == beyond.shape == (0, 1)
    visible, beyond = frustum_masks([PERSPECTIVE], np.zeros((0, 2, 3)))
    assert visible.shape == beyond.shape == (1, 0)


def test_only_the_candidates_are_tested_and_the_others_are_neither_visible_nor_culled(rng):
    bounds = boxes(*rng.uniform(-30.0, 30.0, (50, 3)), half=2.0)
    views = [PERSPECTIVE, orthographic_matrix(40.0, 40.0, 0.1, 80.0) @ VIEW]
    candidates = rng.random(len(bounds)) < 0.3
    visible, beyond = candidate_masks(views, bounds, candidates)
    all_visible, all_beyond = frustum_masks(views, bounds)
    np.testing.assert_array_equal(visible, all_visible & candidates)
    np.testing.assert_array_equal(beyond, all_beyond & candidates)
    assert visible[:, candidates].any() and (all_visible & ~candidates).any()
    none = candidate_masks(views, bounds, np.zeros(len(bounds), bool))
    assert not none[0].any() and not none[1].any()
