# SPDX-License-Identifier: GPL-3.0-or-later
"""The scene's GPU buffers (hybrid_engine/passes/scene_upload/scene_buffers.py): a flat
world-space geometry reaches them the one way every triangle does (as instances, transformed
on the GPU), changed objects are rewritten in place and named exactly by the frame's delta,
and non-finite input is sanitised on the way."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine import Geometry, Lights, MaterialTable, SceneData, Sky
from hybrid_engine.passes.scene_upload.scene_buffers import GPUScene

BUFFERS = ("positions", "normals", "uvs", "triangle_materials")


def soup(rng, objects=6, per_object=400, uvs=True) -> Geometry:
    parts = []
    for k in range(objects):
        tris = (rng.random((per_object, 3, 3)) + k).astype(np.float32)
        normals = rng.standard_normal((per_object, 3, 3)).astype(np.float32)
        normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
        parts.append((tris, normals, k % 3))
    geo = Geometry.from_objects(parts)
    if uvs:
        geo.uvs = rng.random((geo.triangle_count, 3, 2)).astype(np.float32)
    return geo


def scene_of(geo: Geometry) -> SceneData:
    mats = MaterialTable.from_rows([dict(name=f"m{i}") for i in range(3)])
    return SceneData(geo, mats, Lights.from_rows([]), Sky())


def read_back(gpu: GPUScene, n: int) -> dict[str, np.ndarray]:
    shapes = {"positions": (np.float32, (n, 3, 3)), "normals": (np.float32, (n, 3, 3)),
              "uvs": (np.float32, (n, 3, 2)), "triangle_materials": (np.int32, (n,))}
    out = {}
    for name, (dtype, shape) in shapes.items():
        nbytes = int(np.prod(shape)) * np.dtype(dtype).itemsize
        out[name] = np.frombuffer(getattr(gpu, name).buffer.read(size=nbytes), dtype).reshape(shape)
    return out


def upload(gpu: GPUScene, geo: Geometry):
    """One frame's upload step and instance transform step; the frame's delta."""
    _scene, delta = gpu.upload(scene_of(geo))
    gpu.transform()
    return delta


# Unit normals come back through the identity's normal matrix, renormalised: float rounding.
NORMAL_TOLERANCE = 1e-6


def assert_holds(gpu: GPUScene, geo: Geometry) -> None:
    got = read_back(gpu, geo.triangle_count)
    np.testing.assert_array_equal(got["positions"], geo.triangles)
    np.testing.assert_allclose(got["normals"], geo.normals, atol=NORMAL_TOLERANCE)
    np.testing.assert_array_equal(got["triangle_materials"], geo.material_ids)
    np.testing.assert_array_equal(got["uvs"], geo.uvs if geo.uvs is not None else 0.0)


@pytest.mark.parametrize("with_uvs", [True, False])
def test_a_flat_geometry_reaches_the_gpu_as_its_world_rows(ctx, with_uvs):
    geo = soup(np.random.default_rng(1), uvs=with_uvs)
    gpu = GPUScene(ctx)
    try:
        delta = upload(gpu, geo)
        assert delta.full and delta.changed_triangles == geo.triangle_count
        assert_holds(gpu, geo)
    finally:
        gpu.release()


def test_changed_objects_are_rewritten_in_place_and_the_delta_names_exactly_them(ctx):
    """Moved triangles, changed materials and UVs, and a NaN corner in three frames: after each
    upload every buffer holds that frame's geometry, the delta is exactly the edited objects'
    ranges (never a row of an object that did not change) and no buffer is re-allocated."""
    rng = np.random.default_rng(2)
    geo = soup(rng)
    gpu = GPUScene(ctx)
    try:
        upload(gpu, geo)
        allocations = [getattr(gpu, name).allocations for name in BUFFERS]
        edits = [
            (lambda g: g.triangles.__setitem__(slice(400, 800), g.triangles[400:800] + 0.5), [(400, 400)]),
            (lambda g: (g.material_ids.__setitem__(slice(1700, 1710), 2),
                        g.uvs.__setitem__(slice(2300, 2301), 0.25)), [(1600, 800)]),
            (lambda g: (g.triangles.__setitem__((100, 1, 2), np.nan),
                        g.normals.__setitem__((2000, 0, 0), np.inf)), [(0, 400), (2000, 400)]),
        ]
        for edit, ranges in edits:
            geo = Geometry(geo.triangles.copy(), geo.normals.copy(), geo.material_ids.copy(),
                           geo.object_ranges, geo.object_bounds, uvs=geo.uvs.copy())
            edit(geo)
            delta = upload(gpu, geo)
            assert not delta.full and list(delta.ranges) == ranges
            expected = geo.as_instances().world_arrays()  # the host's arithmetic: NaN corners collapsed
            got = read_back(gpu, geo.triangle_count)
            np.testing.assert_array_equal(got["positions"], expected["triangles"])
            np.testing.assert_allclose(got["normals"], expected["normals"], atol=NORMAL_TOLERANCE)
            np.testing.assert_array_equal(got["triangle_materials"], expected["material_ids"])
        assert [getattr(gpu, name).allocations for name in BUFFERS] == allocations
    finally:
        gpu.release()


def test_an_unchanged_frame_writes_nothing_and_says_so(ctx):
    geo = soup(np.random.default_rng(3))
    gpu = GPUScene(ctx)
    try:
        upload(gpu, geo)
        copy = Geometry(geo.triangles.copy(), geo.normals.copy(), geo.material_ids.copy(), geo.object_ranges,
                        geo.object_bounds, uvs=geo.uvs.copy())
        delta = upload(gpu, copy)
        assert delta.unchanged and gpu.instance_transform.stats.triangles_transformed == 0
    finally:
        gpu.release()


def test_a_triangle_with_a_non_finite_corner_collapses_to_the_origin_and_bad_normals_to_zero(ctx):
    tris = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]],
                     [[np.nan, 0, 0], [1, 0, 0], [0, 1, 0]],
                     [[2, 2, 2], [3, 2, 2], [2, np.inf, 2]]], np.float32)
    normals = np.zeros((3, 3, 3), np.float32)
    normals[:, :, 2] = 1.0
    normals[0, 1] = (np.nan, 0.0, 1.0)
    geo = Geometry.from_objects([(tris, normals, 0)])
    gpu = GPUScene(ctx)
    try:
        upload(gpu, geo)
        got = read_back(gpu, 3)
    finally:
        gpu.release()
    np.testing.assert_array_equal(got["positions"][0], tris[0])
    assert not got["positions"][1:].any()
    # A normal without a direction becomes 0, which the G-buffer replaces by the face's.
    np.testing.assert_array_equal(got["normals"][0, 1], [0.0, 0.0, 0.0])
    np.testing.assert_array_equal(got["normals"][1:], normals[1:])


def test_a_scene_past_the_gpus_memory_fails_with_a_message_naming_the_buffer_and_its_size(ctx):
    from hybrid_engine.gpu import dispatch as gpu_dispatch

    class RefusingContext:
        def buffer(self, reserve):
            raise RuntimeError("glBufferData: out of memory")

    grow = gpu_dispatch.GrowBuffer(RefusingContext(), "scene positions")
    with pytest.raises(gpu_dispatch.GPUMemoryError, match=r"scene positions \(3,072\.0 MiB\).*out of memory"):
        grow.ensure(3 * 2**30)
    assert grow.buffer is None and grow.allocations == 0
