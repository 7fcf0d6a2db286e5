# SPDX-License-Identifier: GPL-3.0-or-later
"""passes/trace/diagnostic_views.py and the DIAGNOSTIC trace: each view's per-pixel counts against
counts made independently on the CPU (embree for the paths, the read-back BVH for the node
visits; the march steps against the numpy reference march in test_cube_march.py), and the
legends and the rays' story that make them readable."""
from __future__ import annotations

import numpy as np
import pytest
from embreex import rtcore_scene as rtcs
from embreex.mesh_construction import TriangleMesh

from hybrid_engine import Camera, Geometry, Lights, MaterialTable, RenderSettings, SceneData, Sky
from hybrid_engine.reports import chart_svg
from hybrid_engine.passes.trace import diagnostic_views as diagnostics
from hybrid_engine.reports import diagnostic_legend
from hybrid_engine.reports import timing_report
from hybrid_engine.scene.camera import look_at
from hybrid_engine.frame.renderer import Renderer
from scenes_analytic import box, quad

MIRROR = dict(base_color=(0.9, 0.9, 0.9), reflectivity=1.0)
OFFSET = 1e-4  # the tracer's spawn offset (relative and absolute, hybrid_trace.comp.glsl)
MIN_AGREEMENT = 0.97  # pixels whose rays graze an edge may go either way


@pytest.fixture(scope="module")
def renderer():
    r = Renderer()
    yield r
    r.release()


def mirror_room() -> SceneData:
    """Mirrors only (floor, two boxes, a tilted wall) under a sky: every hit reflects, so a
    pixel's path is one ray per bounce until it escapes or reaches the depth limit."""
    objects = [(quad((0, 0, 0), (4, 0, 0), (0, 4, 0)), None, 0),
               (box((-1.2, -0.5, 0), (-0.2, 0.5, 1.5)), None, 0),
               (box((0.6, 0.2, 0), (1.4, 1.0, 0.8)), None, 0),
               (quad((0, 3, 1.5), (4, 0, 0), (0, 0.6, 1.5)), None, 0)]
    return SceneData(Geometry.from_objects(objects), MaterialTable.from_rows([MIRROR]), Lights.empty(),
                     Sky(color=(0.4, 0.5, 0.7)))


CAMERA = Camera(matrix_world=look_at((0.3, -3.0, 2.2), (0.0, 0.5, 0.4)), width=64, height=48)


def cpu_paths(scene: SceneData, camera: Camera, max_depth: int) -> np.ndarray:
    """(H, W, max_depth + 2) int: per pixel and bounce 1.. what its one ray ended at
    (1 a surface, 4 the sky, 0 no ray), traced with embree and perfect reflection."""
    tris = scene.geometry.triangles.astype(np.float32)
    mesh_scene = rtcs.EmbreeScene()
    TriangleMesh(mesh_scene, tris)
    normals = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    origins, dirs = (a.reshape(-1, 3).astype(np.float64) for a in camera.pixel_rays())
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    out = np.zeros((len(origins), max_depth + 2), np.int32)
    alive = np.ones(len(origins), bool)  # rays still bouncing (the primary hit included)
    for depth in range(0, max_depth + 2):
        idx = np.flatnonzero(alive)
        if not len(idx):
            break
        hit = mesh_scene.run(origins[idx].astype(np.float32), dirs[idx].astype(np.float32), output=1)
        prim, t = hit["primID"], hit["tfar"]
        missed = prim < 0
        if depth > 0:
            out[idx, depth] = np.where(missed, 4, 1)
        alive[idx[missed]] = False
        keep = idx[~missed]
        if depth > max_depth:  # the depth limit's extra ray spawns nothing
            break
        n = normals[prim[~missed]]
        d = dirs[keep]
        p = origins[keep] + d * t[~missed, None]
        facing = np.where((np.einsum("ij,ij->i", n, d) < 0)[:, None], n, -n)
        dirs[keep] = d - 2 * np.einsum("ij,ij->i", d, facing)[:, None] * facing
        origins[keep] = p + facing * (OFFSET + OFFSET * np.abs(p).max(axis=1, keepdims=True))
    return out.reshape(camera.height, camera.width, -1)


def test_the_bounces_view_counts_each_pixel_s_deepest_bounce_as_embree_does(renderer):
    scene, max_depth = mirror_room(), 3
    result = renderer.render(scene, CAMERA, RenderSettings(mode="BOUNCES", near_size=10.0, cube_far=50.0,
                                                           max_depth=max_depth, cube_resolution=64))
    paths = cpu_paths(scene, CAMERA, max_depth)
    expected = np.max(np.where(paths > 0, np.arange(paths.shape[-1]), 0), axis=-1)
    got = result.diagnostic
    assert set(np.unique(expected)) >= {1, 2, 3}  # the room covers several depths
    assert (got == expected).mean() >= MIN_AGREEMENT
    # The depth limit's extra ray is counted: some paths reach bounce max_depth + 1.
    assert (got == max_depth + 1).any() == (expected == max_depth + 1).any()


@pytest.mark.parametrize("bounce", [1, 2])
def test_the_bounce_paths_view_tells_bvh_hits_from_sky_as_embree_does(renderer, bounce):
    scene = mirror_room()
    result = renderer.render(scene, CAMERA, RenderSettings(mode="BOUNCE_PATHS", near_size=10.0, cube_far=50.0,
                                                           max_depth=3, cube_resolution=64,
                                                           diagnostic_bounce=bounce))
    expected = cpu_paths(scene, CAMERA, 3)[..., bounce]  # 1: a surface (all in the BVH), 4: sky
    assert {1, 4} <= set(np.unique(expected))
    assert (result.diagnostic == expected).mean() >= MIN_AGREEMENT


def test_the_bounce_paths_view_marks_rays_ending_in_the_cube_map(renderer):
    """With the camera outside a small near cube the far mirrors are met in the cube map."""
    result = renderer.render(mirror_room(), CAMERA, RenderSettings(mode="BOUNCE_PATHS", near_size=0.5,
                                                                   cube_far=50.0, max_depth=2,
                                                                   cube_resolution=64))
    assert {2, 4} <= set(np.unique(result.diagnostic).astype(int))


def cpu_node_visits(nodes: np.ndarray, origin: np.ndarray, direction: np.ndarray, tmin: float,
                    tmax: float) -> int:
    """Nodes a closest-hit traversal fetches for a ray that hits no triangle: the root and
    every inner node whose box (as its parent stores it) the ray's [tmin, tmax] enters. With
    no hit nothing is pruned, so the count does not depend on the traversal order."""
    inv = 1.0 / np.where(np.abs(direction) < 1e-30, 1e-30, direction)
    visits, stack = 0, [0]
    while stack:
        node = nodes[stack.pop()]
        visits += 1
        for lo, hi, child in ((node["left_min"], node["left_max"], node["left_child"]),
                              (node["right_min"], node["right_max"], node["right_child"])):
            t0, t1 = (lo - origin) * inv, (hi - origin) * inv
            enter = max(np.minimum(t0, t1).max(), tmin)
            leave = min(np.maximum(t0, t1).min(), tmax)
            if enter <= leave and child >= 0:
                stack.append(int(child))
    return visits


def test_the_bvh_nodes_view_counts_the_nodes_a_missing_ray_enters(renderer, rng):
    """A mirror floor under a cloud of small triangles: the floor's reflections that miss the
    cloud visit exactly the nodes whose boxes they cross, counted here from the read-back BVH."""
    centres = rng.uniform((-2, -2, 0.8), (2, 2, 2.0), (300, 3))
    cloud = (centres[:, None, :] + rng.normal(0, 0.06, (300, 3, 3))).astype(np.float32)
    floor = quad((0, 0, 0), (3, 0, 0), (0, 3, 0))
    geometry = Geometry.from_objects([(floor, None, 0), (cloud, None, 1)])
    scene = SceneData(geometry, MaterialTable.from_rows([MIRROR, dict(base_color=(0.5, 0.5, 0.5))]),
                      Lights.empty(), Sky(color=(0.4, 0.5, 0.7)))
    camera = Camera(matrix_world=look_at((0.0, -1.5, 0.5), (0.0, 1.0, 0.0)), width=48, height=32)
    near = 6.0
    result = renderer.render(scene, camera, RenderSettings(mode="BVH_NODES", near_size=near, cube_far=50.0,
                                                           max_depth=1, cube_resolution=64))
    nodes = renderer.bvh.read_nodes()
    paths = cpu_paths(scene, camera, 1)
    origins, dirs = (a.reshape(-1, 3).astype(np.float64) for a in camera.pixel_rays())
    mesh_scene = rtcs.EmbreeScene()
    TriangleMesh(mesh_scene, scene.geometry.triangles.astype(np.float32))
    first = mesh_scene.run(origins.astype(np.float32), dirs.astype(np.float32), output=1)
    on_floor = (first["primID"] >= 0) & (first["primID"] < 2)
    missing = on_floor & (paths.reshape(-1, paths.shape[-1])[:, 1] == 4)
    assert missing.sum() > 200
    got = result.diagnostic.reshape(-1)
    d = dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
    agree = []
    margin = near * (1 + 1e-3)  # the culled region: the near cube and its overlap margin
    for i in np.flatnonzero(missing):
        p = origins[i] + d[i] * first["tfar"][i]
        r = d[i] * np.array([1.0, 1.0, -1.0])  # reflected off the floor (normal +z)
        o = p + np.array([0.0, 0.0, 1.0]) * (OFFSET + OFFSET * np.abs(p).max())
        lo, hi = (camera.position - margin - o) / r, (camera.position + margin - o) / r
        t1 = np.maximum(lo, hi).min()
        agree.append(cpu_node_visits(nodes, o, r, 0.0, t1) == got[i])
    assert np.mean(agree) >= MIN_AGREEMENT
    assert got[missing].max() > 3  # the cloud's boxes make the rays descend


def test_the_cube_steps_view_sums_to_the_frame_counter_and_is_zero_inside_the_bvh(renderer):
    """The per-pixel march steps add up to the trace's step counter (the march's own count is
    checked against the numpy reference in test_cube_march.py); a near cube holding the
    whole room sends no ray to the cube map."""
    room = mirror_room()
    outside = renderer.render(room, CAMERA, RenderSettings(mode="CUBE_STEPS", near_size=0.5, cube_far=50.0,
                                                           max_depth=2, cube_resolution=64, cube_march="SAMPLED"))
    assert outside.diagnostic.sum() == outside.counts["cube_steps"] > 0
    inside = renderer.render(room, CAMERA, RenderSettings(mode="CUBE_STEPS", near_size=10.0, cube_far=50.0,
                                                          max_depth=2, cube_resolution=64))
    assert inside.diagnostic.max() == 0 and inside.counts["cube_steps"] == 0


@pytest.mark.parametrize("mode", ["BOUNCES", "CUBE_STEPS", "BVH_NODES", "BOUNCE_PATHS"])
def test_each_view_hands_its_legend_as_data_and_the_painter_draws_it(renderer, mode):
    """The core never paints text into pixels: the frame carries its legend, and the
    legend painter (which the Blender adapter calls on F12 and the viewport) draws it."""
    settings = RenderSettings(mode=mode, near_size=1.0, cube_far=50.0, max_depth=2, cube_resolution=64)
    result = renderer.render(mirror_room(), Camera(matrix_world=CAMERA.matrix_world, width=400, height=200),
                             settings)
    entries = diagnostics.legend(settings)
    assert result.legend == entries and entries[-1].label == "no reflection or refraction"
    rows = len(entries) * 14 + 8

    def corner(image):  # the top-left corner
        return image[-rows:, :120, :3].reshape(-1, 3)

    assert not np.isclose(corner(result.image), diagnostic_legend.LEGEND_BACKGROUND).all(axis=1).any()
    image = result.image.copy()
    diagnostic_legend.draw_legend(image, result.legend)
    for entry in entries:  # every swatch is there
        assert np.isclose(corner(image), entry.colour, atol=1e-6).all(axis=1).any(), entry.label
    assert np.isclose(corner(image), diagnostic_legend.LEGEND_TEXT).all(axis=1).any()  # and its text


def test_a_hybrid_frame_carries_no_diagnostic(renderer):
    result = renderer.render(mirror_room(), CAMERA, RenderSettings(near_size=1.0, cube_far=50.0,
                                                                   cube_resolution=64))
    assert result.diagnostic is None and result.legend == []


def test_the_ray_story_shares_add_up_and_reach_the_csv_and_the_chart(renderer, tmp_path):
    settings = RenderSettings(near_size=1.0, cube_far=50.0, max_depth=2, cube_resolution=64)
    result = renderer.render(mirror_room(), CAMERA, settings)
    record = timing_report.FrameRecord.from_result(1, result)
    story = record.ray_story
    assert story.rays == result.counts["rays_traced"] > 0
    assert story.ended_bvh + story.ended_cube_map + story.ended_sky == pytest.approx(1.0)
    assert story.ended_cube_map > 0 and story.cube_steps_per_ray > 0
    report = timing_report.TimingReport(records=[record], requested_mode="HYBRID")
    paths = timing_report.write_report(report, tmp_path / "r")
    header, row = paths["csv"].read_text().splitlines()[:2]
    columns = dict(zip(header.split(","), row.split(",")))
    assert float(columns["rays_ended_sky"]) == pytest.approx(story.ended_sky, abs=1e-6)
    assert float(columns["bvh_nodes_per_ray"]) == pytest.approx(story.bvh_nodes_per_ray, abs=1e-6)
    svg = paths["svg"].read_text()
    assert svg.count("class='ray-share'") >= 2 and "rays ended" in svg
    assert "BVH nodes and" in timing_report.chart_summary(report)
    assert chart_svg.RAY_END_COLOURS[0][0] == "BVH"
