# SPDX-License-Identifier: GPL-3.0-or-later
"""A flat world-space geometry converted to instances (hybrid_engine/scene/geometry.py):
one instance per object under the identity, its triangles the mesh; kept from frame to frame,
the conversion re-makes exactly the objects whose rows changed in any bit."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine import Geometry
from hybrid_engine.scene.arrays import SceneDataError
from hybrid_engine.scene.geometry import GeometryEdit, InstancedGeometry


def geometry(rng, objects=4, per_object=500, uvs=False) -> Geometry:
    tris = [rng.normal(size=(per_object, 3, 3)).astype(np.float32) for _ in range(objects)]
    geo = Geometry.from_objects([(t, None, i % 2) for i, t in enumerate(tris)])
    if uvs:
        geo.uvs = rng.random((geo.triangle_count, 3, 2)).astype(np.float32)
    return geo


def changed(previous: InstancedGeometry, current: InstancedGeometry) -> list[int]:
    """The objects whose mesh is not the previous frame's (a new or a deformed one)."""
    return [k for k, (a, b) in enumerate(zip(previous.instances.meshes, current.instances.meshes)) if a is not b]


def test_the_instances_are_the_objects_own_triangles_under_the_identity(rng):
    geo = geometry(rng, uvs=True)
    instanced = geo.as_instances()
    assert instanced.as_instances() is instanced  # already instances
    np.testing.assert_array_equal(instanced.object_ranges, geo.object_ranges)
    world = instanced.world_arrays()
    np.testing.assert_array_equal(world["triangles"], geo.triangles)
    np.testing.assert_array_equal(world["material_ids"], geo.material_ids)
    np.testing.assert_array_equal(world["uvs"], geo.uvs)
    np.testing.assert_allclose(world["normals"], geo.normals, atol=1e-6)


def test_an_identical_frame_keeps_every_mesh_even_as_new_arrays(rng):
    geo = geometry(rng)
    first = geo.as_instances()
    copy = Geometry(geo.triangles.copy(), geo.normals.copy(), geo.material_ids.copy(),
                    geo.object_ranges.copy(), geo.object_bounds.copy())
    assert changed(first, copy.as_instances(first)) == []


def test_a_moved_object_edited_in_place_deforms_exactly_its_mesh(rng):
    """The meshes hold copies: an edit of the caller's arrays in place is still seen."""
    geo = geometry(rng)
    first = geo.as_instances()
    start, count = (int(v) for v in geo.object_ranges[2])
    geo.triangles[start:start + count] += np.float32(0.5)
    second = geo.as_instances(first)
    assert changed(first, second) == [2]
    old, new = first.instances.meshes[2], second.instances.meshes[2]
    assert new.mesh_id == old.mesh_id and new.version == old.version + 1  # re-sent into place
    assert changed(second, geo.as_instances(second)) == []  # the move was remembered


def test_normal_material_and_uv_edits_are_changes_of_their_objects_only(rng):
    geo = geometry(rng, uvs=True)
    first = geo.as_instances()
    geo.normals[10, 1, 2] = 7.0  # object 0
    geo.material_ids[2 * 500 - 1] = 1 - geo.material_ids[2 * 500 - 1]  # object 1
    geo.uvs[1503, 0, 0] += 1.0  # object 3
    second = geo.as_instances(first)
    assert changed(first, second) == [0, 1, 3]
    assert all(m.mesh_id == o.mesh_id for m, o in zip(second.instances.meshes, first.instances.meshes))
    np.testing.assert_array_equal(second.world_arrays()["material_ids"], geo.material_ids)


def test_nan_triangles_that_stay_the_same_are_not_changes(rng):
    geo = geometry(rng)
    geo.triangles[5] = np.nan
    first = geo.as_instances()
    assert changed(first, geo.as_instances(first)) == []


def test_a_layout_change_makes_every_mesh_anew(rng):
    geo = geometry(rng)
    first = geo.as_instances()
    smaller = geometry(rng, objects=3)
    second = smaller.as_instances(first)
    assert not {m.mesh_id for m in second.instances.meshes} & {m.mesh_id for m in first.instances.meshes}


def _edited(geo: Geometry, source: int, generation: int, objects) -> Geometry:
    geo.edit = GeometryEdit(source, generation, None if objects is None else tuple(objects))
    return geo


def test_an_edit_that_follows_the_last_generation_is_taken_at_its_word(rng):
    """The producer says object 1 was rewritten: only it is compared (a change it does not
    mention, in object 3, is not seen: the producer is trusted)."""
    geo = _edited(geometry(rng), source=7, generation=1, objects=None)
    first = geo.as_instances()
    start, count = (int(v) for v in geo.object_ranges[1])
    geo.triangles[start:start + count] += np.float32(1.0)
    geo.triangles[int(geo.object_ranges[3, 0])] += np.float32(1.0)
    second = _edited(geo, 7, 2, [1]).as_instances(first)
    assert changed(first, second) == [1]
    assert changed(second, _edited(geo, 7, 3, []).as_instances(second)) == []


@pytest.mark.parametrize("source,generation", [(7, 3), (8, 2)])
def test_an_edit_after_a_missed_generation_or_from_another_source_is_compared_whole(rng, source, generation):
    geo = _edited(geometry(rng), source=7, generation=1, objects=None)
    first = geo.as_instances()
    start, count = (int(v) for v in geo.object_ranges[2])
    geo.triangles[start:start + count] += np.float32(1.0)
    assert changed(first, _edited(geo, source, generation, [0]).as_instances(first)) == [2]


def test_object_ranges_that_leave_triangles_out_are_refused(rng):
    geo = geometry(rng, objects=2)
    geo.object_ranges = np.array([[0, 500], [600, 400]], np.int32)
    with pytest.raises(SceneDataError, match="cover its triangles in order"):
        geo.as_instances()


@pytest.mark.parametrize("bad", [np.nan, np.inf, np.finfo(np.float32).max])
def test_object_bounds_leave_out_a_non_finite_or_float_max_corner(bad):
    """Blender stores an infinite coordinate as float32's largest value: the bounds every
    shadow fit and cull reads must leave it out like a NaN."""
    good = [[0, 0, 0], [1, 0, 0], [0, 1, 2]]
    geometry = Geometry.from_objects([([good, [[0, 0, 0], [bad, 0, 0], [0, 1, 0]]], None, 0)])
    np.testing.assert_array_equal(geometry.object_bounds[0], [[0, 0, 0], [1, 1, 2]])
