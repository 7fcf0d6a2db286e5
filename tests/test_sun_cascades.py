# SPDX-License-Identifier: GPL-3.0-or-later
"""hybrid_engine/passes/shadow_maps/sun_cascades.py and its use by the shadow pass: shadow maps for a sun fitted
to the first stretches of the view, finer there than the map of the whole scene, kept while
the camera stands still or jitters, re-rendered alone when it moves."""
from __future__ import annotations

import numpy as np

from hybrid_engine import Camera, Geometry, Lights, MaterialTable, RenderSettings, SceneData, Sky
from hybrid_engine.frame.antialias import jittered_camera
from hybrid_engine.scene.camera import look_at
from hybrid_engine.frame.renderer import Renderer
from hybrid_engine.scene.bounds import SceneBounds
from hybrid_engine.passes.shadow_maps.shadow_depth import frame_shadow_views
from hybrid_engine.passes.shadow_maps.sun_cascades import CASCADE_SPLIT, quantized, sun_cascade_views
from scenes_analytic import box, quad, ray_box, ray_plane_z

SUN = np.array([0.5, 0.3, -1.0]) / np.linalg.norm([0.5, 0.3, -1.0])
BOUNDS = SceneBounds(np.array([-100.0, -100.0, 0.0]), np.array([100.0, 100.0, 10.0]))
CAMERA = Camera(matrix_world=look_at((0, -8, 3), (0, 0, 0)), width=96, height=64, clip_start=0.1, clip_end=500.0)


def frustum_corners(camera: Camera, distance: float) -> np.ndarray:
    """(8, 3) world-space corners of the camera's frustum between its clip start and
    ``distance``."""
    left, right, bottom, top = camera.viewplane()
    start = float(camera.clip_start)
    corners = []
    for depth in (start, max(distance, start)):
        scale = 1.0 if camera.projection == "ORTHO" else depth / start
        for x in (left, right):
            for y in (bottom, top):
                corners.append((x * scale, y * scale, -depth))
    local = np.asarray(corners, np.float64)
    return local @ camera.rotation.T + camera.position


def ndc(view, points: np.ndarray) -> np.ndarray:
    clip = np.c_[points, np.ones(len(points))] @ np.asarray(view.view_proj).T
    return clip[:, :3] / clip[:, 3:]


def test_each_cascade_holds_its_part_of_the_view_and_every_caster_of_the_scene():
    views = sun_cascade_views(CAMERA, SUN, BOUNDS, 2, 512)
    assert len(views) == 2
    corners_of_scene = np.array([[x, y, z] for x in (BOUNDS.lo[0], BOUNDS.hi[0]) for y in (BOUNDS.lo[1], BOUNDS.hi[1])
                                 for z in (BOUNDS.lo[2], BOUNDS.hi[2])])
    reach = np.linalg.norm(CAMERA.position - BOUNDS.center) + BOUNDS.radius
    for k, view in enumerate(views):
        corners = frustum_corners(CAMERA, reach * CASCADE_SPLIT ** -(2 - k))
        assert (np.abs(ndc(view, corners)) <= 1.0).all(), f"cascade {k} misses part of its view"
        assert (np.abs(ndc(view, corners_of_scene)[:, 2]) <= 1.0).all(), f"cascade {k} clips casters"
    scene_map = 2.0 * BOUNDS.radius
    assert views[0].extent < views[1].extent < scene_map / 2


def test_a_jittered_or_still_camera_keeps_the_cascade_matrices_and_a_moved_one_changes_them():
    first = sun_cascade_views(CAMERA, SUN, BOUNDS, 2, 512)
    for dx, dy in ((0.25, -0.5), (-0.4, 0.3)):
        jittered = sun_cascade_views(jittered_camera(CAMERA, dx, dy), SUN, BOUNDS, 2, 512)
        for a, b in zip(first, jittered):
            np.testing.assert_array_equal(a.view_proj, b.view_proj)
    moved = Camera(matrix_world=look_at((3, -8, 3), (3, 0, 0)), width=96, height=64, clip_start=0.1, clip_end=500.0)
    assert not np.array_equal(first[0].view_proj, sun_cascade_views(moved, SUN, BOUNDS, 2, 512)[0].view_proj)


def test_a_walking_camera_keeps_each_cascade_for_steps_within_a_cell_that_moves_by_whole_texels():
    """200 steps of 1 cm: every view still holds its part of the frustum, the fine cascade's
    matrix changes only when its centre crosses a cell (a few times, not at every step), and
    each change moves the map by a whole number of texels (still shadow edges)."""
    reach = np.linalg.norm(CAMERA.position - BOUNDS.center) + BOUNDS.radius
    seen, changes = None, 0
    for step in range(200):
        x = 0.01 * step
        camera = Camera(matrix_world=look_at((x, -8, 3), (x, 0, 0)), width=96, height=64, clip_start=0.1,
                        clip_end=500.0)
        views = sun_cascade_views(camera, SUN, BOUNDS, 2, 512)
        for k, view in enumerate(views):
            corners = frustum_corners(camera, reach * CASCADE_SPLIT ** -(2 - k))
            assert (np.abs(ndc(view, corners)) <= 1.0).all(), f"cascade {k} misses part of its view at step {step}"
        if seen is not None and not np.array_equal(seen.view_proj, views[0].view_proj):
            changes += 1
            if np.isclose(seen.extent, views[0].extent):
                shift = (ndc(views[0], np.zeros((1, 3))) - ndc(seen, np.zeros((1, 3))))[0, :2] * 512 / 2
                np.testing.assert_allclose(shift, np.round(shift), atol=1e-3)
        seen = views[0]
    assert 1 <= changes <= 20, changes


def test_cascade_radii_are_quarter_octaves_at_least_as_large_as_asked():
    for radius in (0.013, 1.0, 3.7, 250.0):
        got = quantized(radius)
        assert radius <= got < radius * 2 ** 0.25 * (1 + 1e-9)
        assert np.isclose(np.log2(got) * 4, round(np.log2(got) * 4))


def sun_scene(sun_count: int = 1) -> SceneData:
    """A 200 m ground (the scene map's texels are 40 cm at 512) with a thin post near the
    camera casting a sun shadow; suns without angle cast hard shadows."""
    post_lo, post_hi = np.array([-0.05, -0.05, 0.0]), np.array([0.05, 0.05, 1.5])
    geo = Geometry.from_objects([(quad((0, 0, 0), (100, 0, 0), (0, 100, 0)), None, 0), (box(post_lo, post_hi), None, 0)])
    lights = Lights.from_rows([dict(kind="SUN", direction=SUN, color=(3.0, 3.0, 3.0))] * sun_count)
    return SceneData(geo, MaterialTable.from_rows([dict(base_color=(0.8,) * 3)]), lights, Sky(color=(0.0, 0.0, 0.0)))


def shadow_mismatch(image: np.ndarray, camera: Camera) -> tuple[float, int]:
    """The share of ground pixels whose shadow differs from the post's exact shadow, and
    how many ground pixels the exact shadow covers."""
    lo, hi = np.array([-0.05, -0.05, 0.0]), np.array([0.05, 0.05, 1.5])
    origins, dirs = camera.pixel_rays()
    t = ray_plane_z(origins, dirs)
    points = origins + dirs * np.where(np.isfinite(t), t, 0)[..., None]
    ground = np.isfinite(t) & ~(ray_box(origins, dirs, lo, hi) < np.where(np.isfinite(t), t, np.inf))
    shadowed = np.isfinite(ray_box(points + 1e-4 * -SUN, np.broadcast_to(-SUN, points.shape), lo, hi))
    lit = 0.8 / np.pi * 3.0 * -SUN[2]
    dark = image[..., 0] < 0.5 * lit
    return float((dark != shadowed)[ground].mean()), int(shadowed[ground].sum())


def test_cascades_draw_a_thin_posts_sun_shadow_that_the_scene_map_loses(gl):
    camera = Camera(matrix_world=look_at((0.6, -2.5, 1.6), (0.4, 0.6, 0.0)), width=96, height=72)
    scene = sun_scene()
    renderer = Renderer(gl)
    try:
        mismatch = {}
        for cascades in (0, 2):
            settings = RenderSettings(mode="RASTER", shadow_resolution=512, shadow_bias=0.0, shadow_cascades=cascades)
            mismatch[cascades], shadow_pixels = shadow_mismatch(renderer.render(scene, camera, settings).image, camera)
    finally:
        renderer.release()
    assert shadow_pixels > 80, "the post's shadow must be on screen"
    assert mismatch[2] < 0.005
    assert mismatch[0] > 3 * mismatch[2]


def counts_then_last_view_again_and_fresh(gl, scene, settings, cameras):
    """Each view's counts from one renderer, then its image of the last view rendered again,
    and a fresh renderer's image of that view (what the kept layers must reproduce)."""
    renderer = Renderer(gl)
    try:
        counts = [renderer.render(scene, camera, settings).counts for camera in cameras]
        again = renderer.render(scene, cameras[-1], settings).image
    finally:
        renderer.release()
    fresh = Renderer(gl)
    try:
        expected = fresh.render(scene, cameras[-1], settings).image
    finally:
        fresh.release()
    return counts, again, expected


def test_a_moving_camera_re_renders_the_cascades_alone_and_matches_a_fresh_render(gl):
    scene = sun_scene()
    settings = RenderSettings(mode="RASTER", shadow_resolution=256)
    still = Camera(matrix_world=look_at((0.6, -2.5, 1.6), (0.4, 0.6, 0.0)), width=64, height=48)
    moved = Camera(matrix_world=look_at((1.6, -2.0, 1.6), (0.4, 0.6, 0.0)), width=64, height=48)
    layout = frame_shadow_views(scene, still, settings.shadow_cascades, settings.shadow_resolution)
    assert layout.per_light == [(0, 3)] and layout.cascade.tolist() == [True, True, False]
    counts, again, expected = counts_then_last_view_again_and_fresh(gl, scene, settings, [still, still, moved])
    assert [c["shadow_maps_rendered"] for c in counts] == [1, 0, 1]
    assert [c["shadow_static_rendered"] for c in counts] == [1, 0, 0]  # the scene map is kept
    assert [c["shadow_cascades_rendered"] for c in counts] == [1, 0, 1]
    np.testing.assert_array_equal(again, expected)


def test_a_step_that_moves_only_the_finest_cascade_redraws_it_alone_and_matches_a_fresh_render(gl):
    scene = sun_scene()
    settings = RenderSettings(mode="RASTER", shadow_resolution=256)
    start = Camera(matrix_world=look_at((0.6, -2.5, 1.6), (0.4, 0.6, 0.0)), width=64, height=48)
    steps = [Camera(matrix_world=look_at((0.6 + 0.01 * k, -2.5, 1.6), (0.4 + 0.01 * k, 0.6, 0.0)), width=64, height=48)
             for k in range(1, 40)]
    views = lambda camera: frame_shadow_views(scene, camera, 2, 256).views  # noqa: E731
    first = views(start)
    # The first step that moves the finest cascade keeps the coarser one (SNAP_CELLS steps).
    step = next(c for c in steps if not np.array_equal(views(c)[0].view_proj, first[0].view_proj))
    assert np.array_equal(views(step)[1].view_proj, first[1].view_proj)
    counts, image, expected = counts_then_last_view_again_and_fresh(gl, scene, settings, [start, step])
    assert [c["shadow_cascade_maps_rendered"] for c in counts] == [2, 1]
    assert [c["shadow_static_rendered"] for c in counts] == [1, 0]
    np.testing.assert_array_equal(image, expected)
