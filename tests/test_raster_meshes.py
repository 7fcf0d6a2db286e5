# SPDX-License-Identifier: GPL-3.0-or-later
"""The raster passes' object-space vertex and index buffers (passes/scene_upload/
raster_meshes.py): distinct corners once, index lists that give every corner back (mirrored
too), the instances that must be drawn from the world-space rows, and deformations re-sent
in place without a rebuild."""
from __future__ import annotations

import numpy as np

from hybrid_engine import Geometry
from hybrid_engine.passes.scene_upload.raster_meshes import VERTEX_DTYPE, RasterMeshes, distinct_corners, vertex_rows
from hybrid_engine.scene.geometry import InstancedGeometry
from hybrid_engine.scene.meshes import MIRROR_CORNERS, Instances
from scenes_analytic import quad
from scenes_instanced import instanced_scene, sphere_mesh


def test_distinct_corners_are_stored_once_and_the_indices_give_every_corner_back():
    mesh = sphere_mesh()
    corners, indices = distinct_corners(mesh)
    rows = vertex_rows(mesh, corners)
    n = mesh.triangle_count
    # One vertex per distinct (position, normal, UV): smooth shading shares each position's
    # corners, the sphere's UV seam does not split any (UVs come from positions).
    keys = {(int(v), int(nrm), *mesh.uvs[c].tobytes()) for c, (v, nrm) in
            enumerate(zip(mesh.corner_vertices, mesh.corner_normals))}
    assert len(rows) == len(keys) < 3 * n / 4
    np.testing.assert_array_equal(rows["position"][indices], mesh.positions[mesh.corner_vertices])
    np.testing.assert_array_equal(rows["normal"][indices], mesh.normals[mesh.corner_normals])
    np.testing.assert_array_equal(rows["uv"][indices], mesh.uvs)
    assert indices[0] == 0 and np.all(np.diff(np.maximum.accumulate(indices)) <= 1)  # first-use order


def test_a_uv_seam_splits_a_shared_vertex_and_a_non_finite_uv_reads_as_zero():
    """Two triangles share an edge's positions and normals; across it one corner's UV
    differs (a seam), the other's is equal; a NaN UV is stored as 0, as the transform reads it."""
    from hybrid_engine.scene.meshes import ObjectMesh

    uvs = np.float32([[0, 0], [1, 0], [1, 1],  [0, 0], [1, 1], [np.nan, 1]]).reshape(-1, 2)
    uvs_seam = uvs.copy()
    uvs_seam[4] = (0.5, 1.0)  # corner of vertex 2 in the second triangle
    for corner_uvs, expected in ((uvs, 4), (uvs_seam, 5)):
        mesh = ObjectMesh(positions=np.float32([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]),
                          corner_vertices=[0, 1, 2, 0, 2, 3], normals=np.float32([[0, 0, 1]]),
                          corner_normals=[0] * 6, slots=[0, 0], uvs=corner_uvs)
        corners, indices = distinct_corners(mesh)
        rows = vertex_rows(mesh, corners)
        assert len(rows) == expected
        assert rows["uv"][indices[5]].tolist() == [0.0, 0.0]
        np.testing.assert_array_equal(rows["uv"][indices[:5]], corner_uvs[:5])


def test_instances_get_their_mesh_draw_and_mirrored_ones_the_swapped_list(ctx):
    scene = instanced_scene()
    geometry = scene.geometry
    meshes = RasterMeshes(ctx)
    try:
        meshes.update(geometry)
        draws = meshes.draws(geometry)
        stored = np.frombuffer(meshes.indices.buffer.read(), np.uint32)
        vertices = np.frombuffer(meshes.vertices.buffer.read(), VERTEX_DTYPE)
        mirrored = geometry.instances.mirrored()
        assert draws.instanced.all()
        for k in range(len(geometry.instances)):
            mesh = geometry.instances.meshes[geometry.instances.mesh[k]]
            first, count = int(draws.first_index[k]), int(draws.count[k])
            assert count == 3 * mesh.triangle_count
            corners = stored[first:first + count].astype(np.int64) + int(draws.base_vertex[k])
            order = MIRROR_CORNERS if mirrored[k] else np.arange(3)
            expected = mesh.positions[mesh.corner_vertices.reshape(-1, 3)[:, order].reshape(-1)]
            np.testing.assert_array_equal(vertices["position"][corners], expected)
    finally:
        meshes.release()


def test_flat_geometry_is_drawn_from_the_rows_and_its_edits_cost_no_rebuild(ctx):
    objects = Geometry.from_objects([(quad((0, 0, 0), (1, 0, 0), (0, 1, 0)), None, 0),
                                     (quad((0, 0, 1), (1, 0, 0), (0, 1, 0)), None, 0)])
    flat = Geometry(triangles=objects.triangles, normals=objects.normals, material_ids=objects.material_ids,
                    object_ranges=objects.object_ranges, object_bounds=objects.object_bounds,
                    uvs=objects.triangles[..., :2].copy())
    converted = flat.as_instances()
    meshes = RasterMeshes(ctx)
    try:
        meshes.update(converted)
        assert not meshes.draws(converted).instanced.any()
        generation = meshes.generation
        moved = Geometry(triangles=flat.triangles + np.float32(0.5), normals=flat.normals,
                         material_ids=flat.material_ids, object_ranges=flat.object_ranges,
                         object_bounds=flat.object_bounds + np.float32(0.5), uvs=flat.uvs * np.float32(2))
        again = moved.as_instances(converted)
        assert again.instances.meshes[0].version == 1  # deformed in place
        meshes.update(again)
        assert meshes.meshes_sent == 0 and meshes.generation == generation
        assert not meshes.draws(again).instanced.any()
    finally:
        meshes.release()


def test_a_huge_matrix_is_drawn_from_the_rows(ctx):
    scene = instanced_scene()
    instances = scene.geometry.instances
    matrices = instances.matrices.copy()
    matrices[1, :3, :3] *= np.float32(1e19)
    huge = InstancedGeometry(Instances(instances.meshes, instances.mesh, matrices, instances.slot_materials))
    meshes = RasterMeshes(ctx)
    try:
        meshes.update(huge)
        assert meshes.draws(huge).instanced.tolist() == [True, False, True, True, True, True]
    finally:
        meshes.release()


def test_draws_are_made_once_per_change_of_the_instances(ctx):
    scene = instanced_scene()
    geometry = scene.geometry
    meshes = RasterMeshes(ctx)
    try:
        meshes.update(geometry)
        first = meshes.draws(geometry)
        meshes.update(geometry)  # every layer of draws brings the buffers up to date first
        assert meshes.draws(geometry) is first
        mirror = np.diag([-1.0, 1.0, 1.0, 1.0]).astype(np.float32)
        geometry.instances.matrices[0] = mirror @ geometry.instances.matrices[0]  # a change in place
        moved = meshes.draws(geometry)
        assert moved is not first
        assert moved.first_index[0] != first.first_index[0]  # now the mirrored list
        np.testing.assert_array_equal(moved.first_index[1:], first.first_index[1:])
    finally:
        meshes.release()
