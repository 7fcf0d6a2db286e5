# SPDX-License-Identifier: GPL-3.0-or-later
"""The scene's GPU buffers (hybrid_engine/passes/scene_upload/scene_buffers.py): what lands in them, in full and by
changed ranges, and how non-finite input is sanitised on the way."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine import Geometry, Lights, MaterialTable, SceneData, Sky
from hybrid_engine.passes.scene_upload.scene_buffers import GPUScene, attribute_arrays, finite_positions
from hybrid_engine.scene.changes import GeometryTracker

BUFFERS = ("positions", "normals", "uvs", "triangle_materials")


def soup(rng, objects=6, per_object=400, uvs=True) -> Geometry:
    parts = []
    for k in range(objects):
        tris = (rng.random((per_object, 3, 3)) + k).astype(np.float32)
        normals = rng.standard_normal((per_object, 3, 3)).astype(np.float32)
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


def assert_holds(gpu: GPUScene, geo: Geometry) -> None:
    got = read_back(gpu, geo.triangle_count)
    for name, expected in attribute_arrays(geo).items():
        np.testing.assert_array_equal(got[name], expected, err_msg=name)


@pytest.mark.parametrize("with_uvs", [True, False])
def test_full_upload_writes_each_attribute_as_given(ctx, with_uvs):
    geo = soup(np.random.default_rng(1), uvs=with_uvs)
    gpu = GPUScene(ctx)
    try:
        gpu.upload(scene_of(geo))
        assert_holds(gpu, geo)
        np.testing.assert_array_equal(read_back(gpu, geo.triangle_count)["positions"], geo.triangles)
        if not with_uvs:
            assert not read_back(gpu, geo.triangle_count)["uvs"].any()
    finally:
        gpu.release()


def test_changed_ranges_are_written_in_place_and_nothing_else(ctx):
    """Moved triangles, changed materials and UVs, and a NaN corner in three frames: after each
    incremental upload every buffer equals a fresh upload of that frame's geometry, with no
    buffer re-allocated."""
    rng = np.random.default_rng(2)
    geo = soup(rng)
    tracker, gpu = GeometryTracker(), GPUScene(ctx)
    try:
        gpu.upload(scene_of(geo), tracker.update(geo))
        allocations = [getattr(gpu, name).allocations for name in BUFFERS]
        edits = [
            lambda g: g.triangles.__setitem__(slice(400, 800), g.triangles[400:800] + 0.5),
            lambda g: (g.material_ids.__setitem__(slice(1700, 1710), 2),
                       g.uvs.__setitem__(slice(2300, 2301), 0.25)),
            lambda g: (g.triangles.__setitem__((100, 1, 2), np.nan),
                       g.normals.__setitem__((2000, 0, 0), np.inf)),
        ]
        for edit in edits:
            geo = Geometry(geo.triangles.copy(), geo.normals.copy(), geo.material_ids.copy(),
                           geo.object_ranges, geo.object_bounds, uvs=geo.uvs.copy())
            edit(geo)
            delta = tracker.update(geo)
            assert not delta.full and delta.ranges
            gpu.upload(scene_of(geo), delta)
            assert_holds(gpu, geo)
        assert [getattr(gpu, name).allocations for name in BUFFERS] == allocations
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
        gpu.upload(scene_of(geo))
        got = read_back(gpu, 3)
    finally:
        gpu.release()
    np.testing.assert_array_equal(got["positions"][0], tris[0])
    assert not got["positions"][1:].any()
    np.testing.assert_array_equal(got["normals"][0, 1], [0.0, 0.0, 1.0])
    np.testing.assert_array_equal(got["normals"][1:], normals[1:])
    clean = tris[:1]
    assert finite_positions(clean) is clean  # no copy when there is nothing to sanitise


def test_a_scene_past_the_gpus_memory_fails_with_a_message_naming_the_buffer_and_its_size(ctx):
    from hybrid_engine.gpu import dispatch as gpu_dispatch

    class RefusingContext:
        def buffer(self, reserve):
            raise RuntimeError("glBufferData: out of memory")

    grow = gpu_dispatch.GrowBuffer(RefusingContext(), "scene positions")
    with pytest.raises(gpu_dispatch.GPUMemoryError, match=r"scene positions \(3,072\.0 MiB\).*out of memory"):
        grow.ensure(3 * 2**30)
    assert grow.buffer is None and grow.allocations == 0
