# SPDX-License-Identifier: GPL-3.0-or-later
"""Change tracking between frames (hybrid_engine/scene/changes.py)."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine import Geometry
from hybrid_engine.scene.changes import MERGE_GAP_TRIANGLES, GeometryTracker, changed_rows, merge_ranges


def geometry(rng, objects=4, per_object=5000, uvs=False) -> Geometry:
    tris = [rng.normal(size=(per_object, 3, 3)).astype(np.float32) for _ in range(objects)]
    geo = Geometry.from_objects([(t, None, i % 2) for i, t in enumerate(tris)])
    if uvs:
        geo.uvs = rng.random((geo.triangle_count, 3, 2)).astype(np.float32)
    return geo


def test_the_first_frame_and_layout_changes_upload_everything(rng):
    tracker = GeometryTracker()
    geo = geometry(rng)
    first = tracker.update(geo)
    assert first.full and first.ranges == ((0, geo.triangle_count),)
    smaller = geometry(rng, objects=3)
    assert tracker.update(smaller).full
    assert tracker.update(geometry(rng, objects=3, uvs=True)).full  # UVs appeared


def test_an_identical_frame_changes_nothing_even_as_new_arrays(rng):
    tracker = GeometryTracker()
    geo = geometry(rng)
    tracker.update(geo)
    copy = Geometry(geo.triangles.copy(), geo.normals.copy(), geo.material_ids.copy(),
                    geo.object_ranges.copy(), geo.object_bounds.copy())
    delta = tracker.update(copy)
    assert delta.unchanged and delta.changed_triangles == 0


def test_a_moved_object_yields_exactly_its_range(rng):
    tracker = GeometryTracker()
    geo = geometry(rng)
    tracker.update(geo)
    first, count = (int(v) for v in geo.object_ranges[2])
    geo.triangles[first:first + count] += np.float32(0.5)  # edited in place: still detected
    delta = tracker.update(geo)
    assert not delta.full
    assert delta.ranges == ((first, count),)
    assert delta.changed_triangles == count
    assert tracker.update(geo).unchanged  # the tracker remembered the move


def test_normal_material_and_uv_edits_are_changes(rng):
    tracker = GeometryTracker()
    geo = geometry(rng, uvs=True)
    tracker.update(geo)
    geo.normals[10, 1, 2] = 7.0
    geo.material_ids[20_000 - 1] = 5
    geo.uvs[15_003, 0, 0] += 1.0  # none of them an object's first triangle: compared row by row
    delta = tracker.update(geo)
    changed = {i for first, count in delta.ranges for i in range(first, first + count)}
    assert {10, 15_003, 19_999} <= changed
    assert delta.changed_triangles == 3


def test_an_object_whose_first_triangle_changed_is_taken_whole_and_no_other_object_is(rng):
    """A moved or deformed object is taken whole without comparing the rest of its rows
    (all of them changed, in an animation); the objects around it stay out of the delta."""
    tracker = GeometryTracker()
    geo = geometry(rng, uvs=True)
    tracker.update(geo)
    first, count = (int(v) for v in geo.object_ranges[2])
    geo.uvs[first, 2, 1] += 1.0
    geo.normals[3, 0, 0] = 2.0
    delta = tracker.update(geo)
    assert delta.ranges == ((3, 1), (first, count))
    assert delta.changed_triangles == count + 1
    assert tracker.update(geo).unchanged  # the whole object was remembered


def test_nan_triangles_that_stay_the_same_are_not_changes(rng):
    tracker = GeometryTracker()
    geo = geometry(rng)
    geo.triangles[5] = np.nan
    tracker.update(geo)
    assert tracker.update(geo).unchanged


def test_close_changes_merge_into_one_range_and_distant_ones_do_not():
    mask = np.zeros(100_000, bool)
    mask[[10, 20, 20 + MERGE_GAP_TRIANGLES, 20 + 3 * MERGE_GAP_TRIANGLES]] = True
    assert merge_ranges(mask) == [(10, MERGE_GAP_TRIANGLES + 11), (20 + 3 * MERGE_GAP_TRIANGLES, 1)]
    assert merge_ranges(np.zeros(5, bool)) == []


def test_moving_most_triangles_still_yields_ranges_not_a_full_upload(rng):
    """A large object moving (Sponza's dragon is two thirds of the scene) is a range like any
    other: ``full`` means a layout change only, so per-object consumers (the shadow layers)
    keep knowing which objects stayed still."""
    tracker = GeometryTracker()
    geo = geometry(rng)
    tracker.update(geo)
    moved = geo.triangle_count * 3 // 4
    geo.triangles[:moved] *= 2
    delta = tracker.update(geo)
    assert not delta.full and delta.ranges == ((0, moved),)
    assert delta.changed_triangles == moved


@pytest.mark.parametrize("shape", [(500,), (500, 3, 2), (500, 3, 3), (500, 6, 3), (3, 3, 3)])
def test_changed_rows_finds_exactly_the_rows_that_differ_in_any_bit(rng, shape):
    old = rng.random(shape).astype(np.float32)
    new = old.copy()
    rows = rng.choice(len(old), max(1, len(old) // 7), replace=False)
    flat = new.reshape(len(new), -1)
    flat[rows, rng.integers(0, flat.shape[1], len(rows))] = np.nextafter(
        flat[rows, 0], np.float32(np.inf))  # one word, by as little as a float can move
    expected = (old.reshape(len(old), -1).view(np.uint32) != new.reshape(len(new), -1).view(np.uint32)).any(axis=1)
    np.testing.assert_array_equal(changed_rows(old, new), expected)
    assert expected.sum() == len(rows)


def _edited(geo: Geometry, source: int, generation: int, objects) -> Geometry:
    from hybrid_engine.scene.data import GeometryEdit

    geo.edit = GeometryEdit(source, generation, None if objects is None else tuple(objects))
    return geo


def test_an_edit_that_follows_the_last_generation_is_taken_without_comparing(rng):
    """The producer says object 1 was rewritten: its range is re-sent and no row is compared
    (a change it does not mention, in object 3, is not seen: the producer is trusted)."""
    tracker = GeometryTracker()
    geo = _edited(geometry(rng), source=7, generation=1, objects=None)
    assert tracker.update(geo).full
    first, count = (int(v) for v in geo.object_ranges[1])
    geo.triangles[first:first + count] += np.float32(1.0)
    other = int(geo.object_ranges[3, 0])
    geo.triangles[other] += np.float32(1.0)
    delta = tracker.update(_edited(geo, 7, 2, [1]))
    assert not tracker.compared
    assert delta.ranges == ((first, count),) and delta.changed_triangles == count
    assert tracker.update(_edited(geo, 7, 3, [])).unchanged
    assert tracker.update(geo).unchanged and not tracker.compared  # the same version again


@pytest.mark.parametrize("source,generation", [(7, 3), (8, 2)])
def test_an_edit_after_a_missed_generation_or_from_another_source_is_uploaded_whole(rng, source, generation):
    """The claim does not follow what this tracker saw: everything is sent (no copy of a
    producer's rows is kept to compare with)."""
    tracker = GeometryTracker()
    geo = _edited(geometry(rng), source=7, generation=1, objects=None)
    tracker.update(geo)
    first, count = (int(v) for v in geo.object_ranges[2])
    geo.triangles[first:first + count] += np.float32(1.0)
    delta = tracker.update(_edited(geo, source, generation, [0]))
    assert delta.full and delta.changed_triangles == geo.triangle_count


def test_an_edit_sends_nearby_objects_as_one_range_and_distant_ones_apart(rng):
    tracker = GeometryTracker()
    small = Geometry.from_objects([(rng.normal(size=(10, 3, 3)), None, 0) for _ in range(4)]
                                  + [(rng.normal(size=(MERGE_GAP_TRIANGLES + 5, 3, 3)), None, 0)]
                                  + [(rng.normal(size=(10, 3, 3)), None, 0)])
    tracker.update(_edited(small, 1, 1, None))
    delta = tracker.update(_edited(small, 1, 2, [2, 0, 5]))
    assert delta.ranges == ((0, 30), (int(small.object_ranges[5, 0]), 10))
    assert delta.changed_triangles == 30
