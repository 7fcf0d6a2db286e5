# SPDX-License-Identifier: GPL-3.0-or-later
"""Instances made world space on the GPU (hybrid_engine/passes/scene_upload/instance_transform.py and
scene/meshes.py, scene/geometry.py): the shader agrees with the host's arithmetic and with hand-computed
triangles, meshes are uploaded once and shared, a moved instance costs its own row, and a
scene given as instances renders as the same scene given as world-space triangles."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine import RenderSettings
from hybrid_engine.gpu import dispatch as gpu_dispatch
from hybrid_engine.gpu.dispatch import SceneLimitError
from hybrid_engine.scene.camera import Camera, look_at
from hybrid_engine.passes.scene_upload import previous_rows
from hybrid_engine.passes.scene_upload.scene_buffers import GPUScene
from hybrid_engine.scene.geometry import InstancedGeometry
from hybrid_engine.scene.meshes import Instances, ObjectMesh
from hybrid_engine.frame.renderer import Renderer
from hybrid_engine.scene.geometry import Geometry
from hybrid_engine.scene.data import Lights, MaterialTable, SceneData
from uv_rows_reference import TRIANGLE_UV_DTYPE, triangle_uv_rows


def _read(buffer, count: int, dtype, width: int) -> np.ndarray:
    return np.frombuffer(buffer.read(size=count * width * np.dtype(dtype).itemsize), dtype).reshape(count, -1)


def _assert_positions(gpu: GPUScene, geometry: InstancedGeometry) -> None:
    """The GPU's world positions equal the host's arithmetic (instancing.world_arrays)."""
    n = geometry.triangle_count
    np.testing.assert_allclose(_read(gpu.positions.buffer, n, np.float32, 9), geometry.triangles.reshape(n, 9),
                               atol=2e-5)


def _box_mesh(rng=None, uvs=True, slots=(0, 1)) -> ObjectMesh:
    """A unit cube as Blender stores it: 8 vertices, 12 triangles, face normals, UVs."""
    positions = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], np.float32) - 0.5
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    normals = np.array([[0, 0, -1], [0, 0, 1], [0, -1, 0], [0, 1, 0], [-1, 0, 0], [1, 0, 0]], np.float32)
    corners, corner_normals = [], []
    for face, (a, b, c, d) in enumerate(quads):
        corners += [a, b, c, a, c, d]
        corner_normals += [face] * 6
    n = len(corners) // 3
    uv = None
    if uvs:
        uv = (rng.random((3 * n, 2)) if rng is not None else np.tile([[0, 0], [1, 0], [1, 1]], (n, 1))).astype(np.float32)
    return ObjectMesh(positions=positions, corner_vertices=np.array(corners, np.int32), normals=normals,
                      corner_normals=np.array(corner_normals, np.int32),
                      slots=np.array([slots[i % len(slots)] for i in range(n)], np.int32), uvs=uv, closed=True)


def _matrix(translate=(0, 0, 0), angle=0.0, scale=(1, 1, 1)) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    m = np.eye(4)
    m[:3, :3] = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ np.diag(scale)
    m[:3, 3] = translate
    return m.astype(np.float32)


def _random_instances(rng, count=12) -> InstancedGeometry:
    meshes = [_box_mesh(rng), _box_mesh(rng, uvs=False, slots=(0, 1, 2))]
    matrices = []
    for k in range(count):
        scale = rng.uniform(0.5, 2.0, 3) * (-1 if k % 4 == 3 else 1)  # every fourth mirrors
        matrices.append(_matrix(rng.uniform(-5, 5, 3), rng.uniform(0, 6.28), scale))
    slot_materials = [np.array([1 + k % 3, 4], np.int32) for k in range(count)]  # slot 2 is missing
    instances = Instances(meshes=meshes, mesh=np.arange(count) % 2, matrices=np.array(matrices),
                          slot_materials=slot_materials)
    return InstancedGeometry(instances)


def _materials(count=5) -> MaterialTable:
    return MaterialTable.from_rows([{"base_color": (0.2 * i, 0.5, 0.8 - 0.1 * i)} for i in range(count)])


def test_world_arrays_match_hand_computed_corners_normals_and_mirrored_winding():
    mesh = _box_mesh()
    mirror = _matrix(translate=(1, 2, 3), scale=(-2, 1, 1))
    geometry = InstancedGeometry(Instances([mesh], np.array([0, 0]), np.array([_matrix((0, 0, 5)), mirror]),
                                           [np.array([3, 4]), np.array([2])]))
    tris, normals = geometry.triangles, geometry.normals
    first = mesh.positions[mesh.corner_vertices].reshape(-1, 3, 3)
    np.testing.assert_allclose(tris[:12], first + [0, 0, 5], atol=1e-6)
    # The mirrored instance: corners 1 and 2 swapped, x scaled by -2, still wound outward.
    swapped = first[:, [0, 2, 1]] * [-2, 1, 1] + [1, 2, 3]
    np.testing.assert_allclose(tris[12:], swapped, atol=1e-6)
    face_normal = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    assert (np.einsum("ij,ij->i", face_normal, normals[:, 0]) > 0).all()  # winding agrees with normals
    np.testing.assert_allclose(np.linalg.norm(normals, axis=2), 1.0, atol=1e-6)
    assert geometry.material_ids[:12].tolist() == [3, 4] * 6
    assert geometry.material_ids[12:].tolist() == [2, 0] * 6  # slot 1 missing: material 0
    lo, hi = geometry.object_bounds[1]
    assert (tris[12:].reshape(-1, 3) >= lo - 1e-6).all() and (tris[12:].reshape(-1, 3) <= hi + 1e-6).all()
    assert geometry.object_closed.tolist() == [True, True]


def test_the_gpu_makes_the_same_world_rows_as_the_host(ctx, rng):
    geometry = _random_instances(rng)
    scene = SceneData(geometry=geometry, materials=_materials())
    gpu = GPUScene(ctx)
    try:
        gpu.upload(scene)
        gpu.transform()
        _assert_positions(gpu, geometry)
        n = geometry.triangle_count
        np.testing.assert_allclose(_read(gpu.normals.buffer, n, np.float32, 9),
                                   geometry.normals.reshape(n, 9), atol=2e-5)
        np.testing.assert_array_equal(_read(gpu.uvs.buffer, n, np.float32, 6), geometry.uvs.reshape(n, 6))
        np.testing.assert_array_equal(_read(gpu.triangle_materials.buffer, n, np.int32, 1)[:, 0],
                                      geometry.material_ids)
        rows = np.frombuffer(gpu.uv_rows.buffer.read(size=n * 32), TRIANGLE_UV_DTYPE)
        packed = triangle_uv_rows(geometry.triangles, geometry.uvs)
        np.testing.assert_allclose(rows.view(np.float32).reshape(n, 8)[:, :7],
                                   packed.view(np.float32).reshape(n, 8)[:, :7], rtol=1e-4, atol=1e-6)
    finally:
        gpu.release()


def test_instances_of_one_mesh_share_its_upload_and_moving_one_writes_one_row(ctx):
    mesh = _box_mesh()
    count = 1000
    matrices = np.array([_matrix((k % 40, k // 40, 0)) for k in range(count)])
    instances = Instances([mesh], np.zeros(count, np.int32), matrices, [np.array([1, 2])] * count)
    geometry = InstancedGeometry(instances)
    scene = SceneData(geometry=geometry, materials=_materials())
    gpu = GPUScene(ctx)
    try:
        gpu.upload(scene)
        gpu.transform()
        stats = gpu.instance_transform.stats
        assert stats.store_rebuilt and stats.meshes_uploaded == 1
        assert stats.instances_written == count and stats.triangles_transformed == 12 * count
        assert gpu.instance_transform.store_capacity()["positions"] < 1024  # one cube's 8 vertices, not 1000
        gpu.upload(scene)
        gpu.transform()  # the same version: nothing
        assert gpu.instance_transform.stats.instances_written == 0

        instances.matrices[500] = _matrix((0, 0, 9), angle=0.3)
        geometry.refresh([500])  # no producer's edit: the rows are compared
        gpu.upload(scene)
        gpu.transform()
        stats = gpu.instance_transform.stats
        assert (stats.instances_written, stats.triangles_transformed, stats.meshes_uploaded) == (1, 12, 0)
        _assert_positions(gpu, geometry)
    finally:
        gpu.release()


def _still_and_wobbly() -> tuple[InstancedGeometry, SceneData]:
    """A box mesh under instance 0 and another under instances 1 and 2."""
    instances = Instances([_box_mesh(), _box_mesh()], np.array([0, 1, 1]),
                          np.array([_matrix((k * 3, 0, 0)) for k in range(3)]), [np.array([1])] * 3)
    geometry = InstancedGeometry(instances)
    return geometry, SceneData(geometry=geometry, materials=_materials())


def _deform_wobbly(geometry: InstancedGeometry) -> None:
    """Deform the second mesh (its vertices scaled by 1.5) and tell its instances."""
    meshes = geometry.instances.meshes
    meshes[1] = meshes[1].deformed(meshes[1].positions * 1.5, meshes[1].normals)
    geometry.refresh([1, 2])


def test_a_deformed_mesh_re_sends_its_vertices_into_place_and_transforms_its_instances(ctx):
    geometry, scene = _still_and_wobbly()
    gpu = GPUScene(ctx)
    try:
        gpu.upload(scene)
        gpu.transform()
        _deform_wobbly(geometry)
        gpu.upload(scene)
        gpu.transform()
        stats = gpu.instance_transform.stats
        assert not stats.store_rebuilt and stats.meshes_uploaded == 1
        assert (stats.instances_written, stats.triangles_transformed) == (2, 24)
        _assert_positions(gpu, geometry)
    finally:
        gpu.release()


def test_a_deformed_meshs_instances_keep_last_frames_world_rows_before_the_transform_rewrites_them(ctx, monkeypatch):
    # The surface-motion pass needs where a deformed surface stood last frame: its instances'
    # world rows are copied, packed in instance order, before the transform writes the new
    # ones; the still mesh's instance is not, and a frame that deforms nothing keeps none.
    geometry, scene = _still_and_wobbly()
    gpu = GPUScene(ctx)
    try:
        gpu.upload(scene)
        gpu.transform()
        assert not len(gpu.previous_rows.instances)  # a first frame has no rows to keep
        before = _read(gpu.positions.buffer, geometry.triangle_count, np.float32, 9)
        _deform_wobbly(geometry)
        gpu.upload(scene)
        gpu.transform()
        kept = gpu.previous_rows
        assert kept.instances.tolist() == [1, 2] and kept.offsets.tolist() == [0, 12] and kept.rows == 24
        first, count = geometry.object_ranges[1]
        np.testing.assert_array_equal(_read(kept.positions.buffer, 24, np.float32, 9),
                                      before[first:first + 2 * count])
        assert kept.offsets_of(np.array([0, 2, 1])).tolist() == [-1, 12, 0]
        _assert_positions(gpu, geometry)
        geometry.refresh([0])
        gpu.upload(scene)
        gpu.transform()
        assert not len(gpu.previous_rows.instances)
        # More deformed rows than one storage block holds (the pass binds them as one): none.
        monkeypatch.setattr(previous_rows, "max_block_bytes", lambda: 23 * 36)
        _deform_wobbly(geometry)
        gpu.upload(scene)
        gpu.transform()
        assert not len(gpu.previous_rows.instances)
        _assert_positions(gpu, geometry)
    finally:
        gpu.release()


def test_outputs_past_one_storage_block_are_written_chunk_by_chunk(ctx, rng):
    geometry = _random_instances(rng, count=14)  # 168 triangles; a table of 2,240 bytes
    scene = SceneData(geometry=geometry, materials=_materials())
    gpu = GPUScene(ctx)
    try:
        with gpu_dispatch.forced_limits(max_block=64 * 36):  # 64 rows of positions per chunk
            gpu.upload(scene)
            gpu.transform()
        assert gpu.instance_transform.stats.dispatches == 3
        _assert_positions(gpu, geometry)
    finally:
        gpu.release()


@pytest.mark.parametrize("mode", ["HYBRID", "FULL_BVH"])
def test_a_scene_of_instances_renders_as_its_world_space_triangles(gl, rng, mode):
    geometry = _random_instances(rng, count=10)
    floor = ObjectMesh(positions=np.array([[-9, -9, -3], [9, -9, -3], [9, 9, -3], [-9, 9, -3]], np.float32),
                       corner_vertices=np.array([0, 1, 2, 0, 2, 3], np.int32), normals=np.array([[0, 0, 1]], np.float32),
                       corner_normals=np.zeros(6, np.int32), slots=np.zeros(2, np.int32))
    instances = geometry.instances
    instances = Instances(instances.meshes + [floor], np.r_[instances.mesh, 2],
                          np.concatenate([instances.matrices, np.eye(4, dtype=np.float32)[None]]),
                          instances.slot_materials + [np.array([0])])
    geometry = InstancedGeometry(instances)
    materials = _materials()
    materials.reflectivity[:] = [0.0, 1.0, 0.0, 1.0, 0.0]
    materials.roughness[:] = 0.0
    lights = Lights.from_rows([{"kind": "SUN", "direction": (0.3, 0.2, -1.0), "color": (3.0, 3.0, 3.0)}])
    camera = Camera(matrix_world=look_at((9.0, -11.0, 7.0), (0.0, 0.0, 0.0)), width=48, height=32, lens=30.0)
    settings = RenderSettings(mode=mode, cube_resolution=64, shadow_resolution=256, near_size=6.0, max_depth=3)
    world = Geometry(triangles=geometry.triangles, normals=geometry.normals, material_ids=geometry.material_ids,
                     object_ranges=geometry.object_ranges, object_bounds=geometry.object_bounds,
                     uvs=geometry.uvs, object_closed=geometry.object_closed)
    images = []
    for geo in (geometry, world):
        renderer = Renderer(gl)
        try:
            images.append(renderer.render(SceneData(geometry=geo, materials=materials, lights=lights),
                                          camera, settings).image)
        finally:
            renderer.release()
    # The GPU's float arithmetic may differ from numpy's in the last bit of a corner.
    assert np.abs(images[0] - images[1]).max() < 2e-3 or np.mean(np.abs(images[0] - images[1]) > 1e-3) < 0.002
    assert images[0].max() > 0.05  # something was lit


def test_a_producers_next_edit_packs_and_writes_only_the_rows_it_lists(ctx, rng):
    from hybrid_engine.scene.geometry import GeometryEdit

    geometry = _random_instances(rng, count=20)
    geometry.edit = GeometryEdit(source=7, generation=1)
    scene = SceneData(geometry=geometry, materials=_materials())
    gpu = GPUScene(ctx)
    try:
        gpu.upload(scene)
        gpu.transform()
        assert gpu.instance_transform.stats.instances_written == 20
        geometry.instances.matrices[5] = _matrix((1, 2, 3), angle=1.0)
        geometry.instances.matrices[9] = _matrix((0, 0, 7))  # changed, but not listed: not seen
        geometry.refresh([5, 9])
        geometry.edit = GeometryEdit(source=7, generation=2, objects=(5,))
        gpu.upload(scene)
        gpu.transform()
        assert (gpu.instance_transform.stats.instances_written, gpu.instance_transform.stats.triangles_transformed) \
            == (1, 12)
        geometry.edit = GeometryEdit(source=7, generation=3, objects=())  # e.g. only a material changed
        gpu.upload(scene)
        gpu.transform()
        assert gpu.instance_transform.stats.instances_written == 0
        geometry.edit = None  # no producer's word: every row compared, instance 9 found
        gpu.upload(scene)
        gpu.transform()
        assert gpu.instance_transform.stats.instances_written == 1
        _assert_positions(gpu, geometry)
    finally:
        gpu.release()


def test_a_store_past_one_storage_block_is_cut_into_pages_that_make_the_same_rows(ctx, rng):
    """Meshes whose arrays together exceed one storage block go into pages, each bound on
    its own for its instances' dispatches: the world rows are the host's arithmetic."""
    parts = [((rng.random((100, 3, 3)) * 4 + k).astype(np.float32), None, k % 3) for k in range(3)]
    geometry = Geometry.from_objects(parts)
    geometry.uvs = rng.random((geometry.triangle_count, 3, 2)).astype(np.float32)
    scene = SceneData(geometry=geometry, materials=_materials())
    gpu = GPUScene(ctx)
    try:
        # A 100-triangle soup mesh takes 3600 bytes of positions: one mesh per 4096-byte page.
        with gpu_dispatch.forced_limits(max_block=4096):
            gpu.upload(scene)
            gpu.transform()
            stats = gpu.instance_transform.stats
            assert stats.store_pages == 3 and stats.dispatches >= 3
        n = geometry.triangle_count
        np.testing.assert_array_equal(_read(gpu.positions.buffer, n, np.float32, 9), geometry.triangles.reshape(n, 9))
        np.testing.assert_array_equal(_read(gpu.triangle_materials.buffer, n, np.int32, 1)[:, 0],
                                      geometry.material_ids)
        rows = np.frombuffer(gpu.uv_rows.buffer.read(size=n * 32), TRIANGLE_UV_DTYPE)
        np.testing.assert_allclose(rows.view(np.float32).reshape(n, 8)[:, :7],
                                   triangle_uv_rows(geometry.triangles, geometry.uvs).view(np.float32)
                                   .reshape(n, 8)[:, :7], rtol=1e-4, atol=1e-6)
    finally:
        gpu.release()


def test_a_mesh_larger_than_a_storage_block_is_refused_naming_its_object(ctx, rng):
    tris = rng.random((200, 3, 3)).astype(np.float32)
    geometry = Geometry.from_objects([(tris, None, 0)], names=["Sculpt"])
    gpu = GPUScene(ctx)
    try:
        with gpu_dispatch.forced_limits(max_block=4096), pytest.raises(SceneLimitError, match="'Sculpt'.*200 triangles"):
            gpu.upload(SceneData(geometry=geometry, materials=_materials()))
    finally:
        gpu.release()

