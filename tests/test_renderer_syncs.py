# SPDX-License-Identifier: GPL-3.0-or-later
"""The frame drains the GPU only at its end (hybrid_engine/frame/renderer.py): no read-back
and no ``ctx.finish()`` between passes, counts read only when asked, timing only on request
(tests/sync_probe.py records every synchronisation point against the pass boundaries)."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine import Camera, Geometry, Lights, MaterialTable, RenderSettings, SceneData, Sky
from hybrid_engine.frame.renderer import Renderer
from hybrid_engine.scene.camera import look_at
from scenes_analytic import quad, uv_sphere
from sync_probe import SyncProbe

SMALL = dict(cube_resolution=32, shadow_resolution=128, near_size=2.0)
CAMERA = Camera(matrix_world=look_at((0, -4, 1), (0, 0, 0)), width=24, height=16)
PROBED_MODES = ("RASTER", "HYBRID", "FULL_BVH")


def scene() -> SceneData:
    """A mirror sphere on a floor, a glass ball beside it and one far away: objects inside,
    straddling and outside the near cube, and rays for the trace to follow."""
    ball, normals = uv_sphere((0, 0, 0), 1.0, 16, 8)
    small, small_normals = uv_sphere((1.2, -2.5, 0.5), 0.3, 8, 4)
    far, far_normals = uv_sphere((0, 30, 2), 2.0, 8, 4)
    mats = MaterialTable.from_rows([dict(base_color=(0.9, 0.9, 0.9), reflectivity=1.0),
                                    dict(base_color=(0.6, 0.6, 0.6)),
                                    dict(base_color=(1, 1, 1), transmission=1.0, ior=1.5)])
    return SceneData(Geometry.from_objects([(ball, normals, 0), (quad((0, 0, -1), (5, 0, 0), (0, 5, 0)), None, 1),
                                            (small, small_normals, 2), (far, far_normals, 1)]),
                     mats, Lights.from_rows([dict(kind="SUN", direction=(0, 0.3, -1), color=(2, 2, 2))]),
                     Sky(color=(0.2, 0.3, 0.5)))


@pytest.fixture(scope="module")
def warm(renderer):
    """The module's renderer after one frame of each mode (kernels compiled, buffers grown)."""
    for mode in PROBED_MODES:
        dict(renderer.render(scene(), CAMERA, RenderSettings(mode=mode, **SMALL)).counts)
    return renderer


# -- (a) nothing drains the GPU before the frame's end --------------------------------------

@pytest.mark.parametrize("mode", PROBED_MODES)
def test_a_frame_reads_nothing_back_and_finishes_nothing_before_its_readback(warm, mode):
    with SyncProbe() as probe:
        result = warm.render(scene(), CAMERA, RenderSettings(mode=mode, **SMALL))
    begun = [event.name for event in probe.events if event.kind == "begin"]
    assert begun[-1] == "readback" and ("trace" in begun) == (mode != "RASTER")
    early = [event for event in probe.syncs() if event.inside != "readback"]
    assert early == [], f"{mode}: synchronisation points before the frame's end: {early}"
    assert result.image.shape == (16, 24, 4)


def test_a_hybrid_frame_culls_and_builds_without_reading_the_kept_count(warm):
    """The near-cube cull's count reaches the LBVH build on the GPU: no read between the
    cull and the trace, and the BVH holds what the cull kept."""
    with SyncProbe() as probe:
        result = warm.render(scene(), CAMERA, RenderSettings(mode="HYBRID", **SMALL))
    between = []
    inside = False
    for event in probe.events:
        if event.kind == "begin" and event.name == "cull":
            inside = True
        if event.kind == "begin" and event.name == "trace":
            inside = False
        if inside and event.kind == "sync":
            between.append(event)
    assert between == []
    kept = warm._world["near_triangles"].count  # read back only now, after the frame
    assert 0 < kept < scene().geometry.triangle_count
    assert result.counts["triangles_bvh"] == kept == warm.bvh.leaf_count


# -- (b) ctx.finish() only when timing is asked for -----------------------------------------

@pytest.mark.parametrize("mode", PROBED_MODES)
def test_a_frame_without_timing_calls_finish_at_most_once_and_timing_brackets_every_pass(warm, mode):
    settings = RenderSettings(mode=mode, **SMALL)
    with SyncProbe() as plain:
        untimed = warm.render(scene(), CAMERA, settings)
    with SyncProbe() as timed_probe:
        timed = warm.render(scene(), CAMERA, settings, timing=True)
    assert plain.finishes() <= 1 and untimed.passes == {}
    assert timed_probe.finishes() >= 2 * len(timed.passes) and timed.passes
    np.testing.assert_array_equal(untimed.image, timed.image)


def test_f12_without_a_timing_request_calls_finish_at_most_once(addon, tmp_path):
    """Blender's final render (the engine's render_depsgraph) times its passes only when a
    tool asks; the timing report asks."""
    import bpy

    from test_engine import build_plane_scene

    scene_ = build_plane_scene(bpy, "SUN", 1.0, size=8)
    scene_.render.engine = "HYBRID_RT"
    scene_.hybrid_rt.mode = "HYBRID"
    scene_.hybrid_rt.render_samples = 1
    engine = addon.blender_adapter.engine
    bpy.ops.render.render()  # compile and allocate
    with SyncProbe() as probe:
        bpy.ops.render.render()
    frame = engine.last_frame
    assert frame.mode == "HYBRID" and set(frame.passes) == {"extract"}
    assert probe.finishes() <= 1
    with SyncProbe() as report_probe:
        timed = engine.render_depsgraph(bpy.context.evaluated_depsgraph_get(), timing=True)
    assert {"cull", "lbvh_build", "trace"} <= set(timed.passes)
    assert report_probe.finishes() >= 2 * (len(timed.passes) - 1)


# -- (d) counts: read when asked, the same as read at once ----------------------------------

def eager_counts(renderer: Renderer, settings: RenderSettings) -> dict[str, int]:
    """The frame's GPU counters read straight from the passes' buffers."""
    counts = renderer.tracer.read_stats(settings.max_depth).as_counts()
    counts["triangles_bvh"] = renderer.bvh.count.read()
    if settings.mode == "HYBRID":
        counts.update(renderer._world["near_triangles"].read_class_counts())
    return counts


@pytest.mark.parametrize("mode", ("HYBRID", "FULL_BVH"))
def test_counts_read_lazily_equal_the_counters_read_at_once(warm, mode):
    settings = RenderSettings(mode=mode, **SMALL)
    with SyncProbe() as probe:
        result = warm.render(scene(), CAMERA, settings)
    eager = eager_counts(warm, settings)
    assert not result.counts.resolved, "the frame read its counts without being asked"
    assert len(probe.reads()) == 1  # the image only
    with SyncProbe() as asked:
        lazy = dict(result.counts)
    assert [event.name for event in asked.syncs()] == ["Buffer.read"]  # one read, of the ring
    assert {name: lazy[name] for name in eager} == eager
    assert lazy["rays_traced_bounce_1"] > 0 and lazy["triangles_total"] == scene().geometry.triangle_count
    if mode == "HYBRID":
        assert lazy["objects_near_inside"] + lazy["objects_near_straddling"] + lazy["objects_near_outside"] == 4
        assert lazy["objects_near_outside"] >= 1 and lazy["objects_near_straddling"] >= 1


def test_counts_asked_for_frames_later_are_those_of_their_frame(warm):
    """Later frames (other near cubes: other counts) reuse the statistics ring's slots; a
    frame's counts asked for after them are still its own."""
    sizes = (2.0, 0.6, 3.5, 1.2, 5.0, 0.9)
    results, eager = [], []
    for size in sizes:
        settings = RenderSettings(mode="HYBRID", **{**SMALL, "near_size": size})
        results.append(warm.render(scene(), CAMERA, settings))
        eager.append(eager_counts(warm, settings))
    assert len({e["triangles_bvh"] for e in eager}) > 2, "the near cubes should keep different triangles"
    for result, expected in zip(results, eager):
        assert {name: result.counts[name] for name in expected} == expected


def test_a_frame_without_statistics_copies_and_reads_no_gpu_counter(warm):
    settings = RenderSettings(mode="HYBRID", **SMALL)
    with SyncProbe() as probe:
        result = warm.render(scene(), CAMERA, settings, statistics=False)
        counts = dict(result.counts)
    assert len(probe.reads()) == 1
    assert counts["triangles_total"] == scene().geometry.triangle_count
    assert "triangles_bvh" not in counts and "rays_traced" not in counts
