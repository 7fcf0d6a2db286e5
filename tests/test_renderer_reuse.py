# SPDX-License-Identifier: GPL-3.0-or-later
"""Frame-to-frame reuse in hybrid_engine/frame/renderer.py: only changed triangles are
re-uploaded and shadow maps are re-rendered only when something they depend on changed;
every frame must still equal a from-scratch render of the same scene."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hybrid_engine import RenderSettings
from hybrid_engine.frame.renderer import Renderer
from benchmarks.scenes.chess import build_chess

DETAIL = 0.02  # ~35k triangles: several objects move from frame to frame
SIZE = (64, 36)
SETTINGS = dict(cube_resolution=64, shadow_resolution=256, near_size=3.5, cube_far=100.0, max_depth=3)


@pytest.fixture(scope="module")
def frames():
    return [build_chess(DETAIL, frame, *SIZE) for frame in (0, 1, 2)]


@pytest.mark.parametrize("mode", ["HYBRID", "FULL_BVH", "RASTER"])
def test_an_animation_rendered_incrementally_equals_fresh_renders(gl, frames, mode):
    settings = RenderSettings(mode=mode, **SETTINGS)
    reused = Renderer(gl)
    try:
        results = [reused.render(scene, camera, settings) for scene, camera in frames]
    finally:
        reused.release()
    total = frames[0][0].geometry.triangle_count
    uploaded = [r.counts["triangles_uploaded"] for r in results]
    assert uploaded[0] == total
    assert 0 < uploaded[1] < total and 0 < uploaded[2] < total  # some objects moved, not all
    for (scene, camera), result in zip(frames, results):
        fresh = Renderer(gl)
        try:
            expected = fresh.render(scene, camera, settings).image
        finally:
            fresh.release()
        np.testing.assert_array_equal(result.image, expected)


def test_shadow_maps_are_reused_only_while_nothing_they_depend_on_changes(gl, frames):
    scene, camera = frames[0]
    settings = RenderSettings(mode="RASTER", **SETTINGS)
    renderer = Renderer(gl)
    try:
        first = renderer.render(scene, camera, settings)
        again = renderer.render(scene, camera, settings)
        assert (first.counts["shadow_maps_rendered"], again.counts["shadow_maps_rendered"]) == (1, 0)
        assert again.counts["triangles_uploaded"] == 0
        np.testing.assert_array_equal(first.image, again.image)
        # A moved light, a new shadow resolution, moved geometry: each re-renders them.
        moved = dataclasses.replace(scene, lights=dataclasses.replace(
            scene.lights, position=scene.lights.position + np.float32(0.5)))
        assert renderer.render(moved, camera, settings).counts["shadow_maps_rendered"] == 1
        assert renderer.render(moved, camera, settings).counts["shadow_maps_rendered"] == 0
        sharper = dataclasses.replace(settings, shadow_resolution=512)
        assert renderer.render(moved, camera, sharper).counts["shadow_maps_rendered"] == 1
        next_scene, _ = frames[1]
        assert renderer.render(next_scene, camera, sharper).counts["shadow_maps_rendered"] == 1
    finally:
        renderer.release()


def test_switching_to_a_traced_mode_mid_animation_uploads_the_tracer_in_full(gl, frames):
    """The tracer joins after RASTER frames: it never saw the earlier deltas."""
    renderer = Renderer(gl)
    try:
        renderer.render(*frames[0], RenderSettings(mode="RASTER", **SETTINGS))
        hybrid = RenderSettings(mode="HYBRID", **SETTINGS)
        image = renderer.render(*frames[1], hybrid).image
    finally:
        renderer.release()
    fresh = Renderer(gl)
    try:
        np.testing.assert_array_equal(image, fresh.render(*frames[1], hybrid).image)
    finally:
        fresh.release()


@pytest.mark.parametrize("mode", ["HYBRID", "FULL_BVH"])
def test_shading_normals_split_over_storage_blocks_render_the_same_image(gl, frames, mode):
    """Past the driver's storage-block limit the scene's shading normals (which the tracer
    interpolates at BVH hits), its triangles and the BVH arrays are bound as several blocks;
    forcing a tiny limit must not change a pixel. HYBRID's limit splits the normals in two;
    FULL_BVH's splits its whole-scene BVH (64-byte nodes, 48-byte triangles) and not the
    36-byte normals, as a 2-3 M triangle scene does (more splits than that exceed llvmpipe's
    16 storage blocks per kernel)."""
    from hybrid_engine.gpu import dispatch as gpu_dispatch
    from hybrid_engine.passes.trace.tracer import NORMAL_BYTES

    scene, camera = frames[0]
    n = scene.geometry.triangle_count
    settings = RenderSettings(mode=mode, **SETTINGS)
    plain = Renderer(gl)
    try:
        expected = plain.render(scene, camera, settings).image
    finally:
        plain.release()
    limit = (NORMAL_BYTES if mode == "HYBRID" else 64) * n * 2 // 3
    split = Renderer(gl)
    try:
        with gpu_dispatch.forced_limits(max_block=limit):
            image = split.render(scene, camera, settings).image
            normal_blocks = gpu_dispatch.split_blocks(n, NORMAL_BYTES, "normals").blocks
            assert normal_blocks == (2 if mode == "HYBRID" else 1)
            if mode == "FULL_BVH":
                assert split.bvh.node_split.blocks > 1
    finally:
        split.release()
    np.testing.assert_array_equal(image, expected)
