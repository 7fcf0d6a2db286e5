# SPDX-License-Identifier: GPL-3.0-or-later
"""RASTER mode (the G-buffer, shadow and deferred-shading passes through Renderer) against analytic numpy references.

The references trace the camera's own pixel rays (Camera.pixel_rays) against the analytic
geometry and apply Blender's light units (checked against Cycles: sun strength S gives
irradiance S; a point light of power P has intensity P / 4π), so they share no code with the
GPU passes beyond the camera description.
"""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine import Camera, Geometry, Lights, MaterialTable, RenderSettings, SceneData, Sky
from hybrid_engine.scene.camera import look_at
from hybrid_engine.frame.renderer import Renderer
from scenes_analytic import box, quad, ray_box, ray_plane_z, uv_sphere
from conftest import save_failure_images

RASTER = RenderSettings(mode="RASTER", shadow_resolution=1024, shadow_bias=0.02)
# Radiance agreement on lit pixels: the G-buffer stores albedo in half floats (0.8 -> 0.7998)
# and positions are reconstructed from float32 depth.
RADIANCE_RTOL = 2e-3
# Shadow maps are discrete: pixels whose shadow status differs from the exact reference are
# confined to a band of about one shadow texel along the shadow's outline.
MAX_SHADOW_MISMATCH_FRACTION = 0.02
ALBEDO = 0.8


# Lamp tests see a black World unless they ask for a sky: the World lights diffuse surfaces too.
def diffuse_scene(objects, lights, materials=None, sky=Sky(color=(0.0, 0.0, 0.0))):
    geo = Geometry.from_objects(objects)
    mats = materials or MaterialTable.from_rows([dict(base_color=(ALBEDO,) * 3)])
    return SceneData(geo, mats, Lights.from_rows(lights), sky)


def plane_hits(camera):
    origins, dirs = camera.pixel_rays()
    t = ray_plane_z(origins, dirs)
    on_plane = np.isfinite(t) & (np.abs(origins + dirs * np.where(np.isfinite(t), t, 0)[..., None])[..., :2] < 5).all(-1)
    points = origins + dirs * np.where(on_plane, t, 0)[..., None]
    return on_plane, points, dirs


def test_sunlit_plane_has_the_radiance_of_a_lambertian_surface(renderer):
    camera = Camera(matrix_world=look_at((0, -6, 4), (0, 0, 0)), width=64, height=48)
    sun_dir = np.array([0.3, 0.2, -1.0])
    sun_dir /= np.linalg.norm(sun_dir)
    scene = diffuse_scene([(quad((0, 0, 0), (5, 0, 0), (0, 5, 0)), None, 0)],
                          [dict(kind="SUN", direction=sun_dir, color=(2.0, 3.0, 4.0))],
                          sky=Sky(color=(0.1, 0.2, 0.3)))
    image = renderer.render(scene, camera, RASTER).image
    on_plane, _, _ = plane_hits(camera)
    # The sun, plus the World's uniform sky over the whole upper hemisphere (irradiance pi L).
    sky = np.asarray(scene.sky.color) * scene.sky.strength
    expected = ALBEDO / np.pi * (np.array([2.0, 3.0, 4.0]) * -sun_dir[2] + np.pi * sky)
    np.testing.assert_allclose(image[on_plane][:, :3], np.broadcast_to(expected, (on_plane.sum(), 3)), rtol=RADIANCE_RTOL)


def test_sky_colour_fills_pixels_where_nothing_is_hit(renderer):
    camera = Camera(matrix_world=look_at((0, -6, 4), (0, 0, 0)), width=48, height=32)
    sky = Sky(color=(0.25, 0.5, 1.0), strength=0.8)
    scene = diffuse_scene([(quad((0, 0, 0), (1, 0, 0), (0, 1, 0)), None, 0)], [], sky=sky)
    image = renderer.render(scene, camera, RASTER).image
    origins, dirs = camera.pixel_rays()
    t = ray_plane_z(origins, dirs)
    hit = np.isfinite(t) & (np.abs(origins + dirs * np.where(np.isfinite(t), t, 0)[..., None])[..., :2] < 1.02).all(-1)
    np.testing.assert_allclose(image[~hit][:, :3], np.broadcast_to([0.2, 0.4, 0.8], ((~hit).sum(), 3)), rtol=1e-6)
    assert (~hit).sum() > 0.5 * hit.size


def test_box_casts_a_sun_shadow_where_geometry_says(renderer):
    camera = Camera(matrix_world=look_at((0, -7, 6), (0, 0, 0)), width=96, height=72)
    sun_dir = np.array([0.5, 0.3, -1.0])
    sun_dir /= np.linalg.norm(sun_dir)
    lo, hi = np.array([-1.0, -1.0, 0.5]), np.array([0.5, 0.5, 1.5])  # floating box
    scene = diffuse_scene(
        [(quad((0, 0, 0), (5, 0, 0), (0, 5, 0)), None, 0), (box(lo, hi), None, 0)],
        [dict(kind="SUN", direction=sun_dir, color=(3.0, 3.0, 3.0))],
    )
    image = renderer.render(scene, camera, RASTER).image
    on_plane, points, dirs = plane_hits(camera)
    # Pixels that see the plane and not the box in front of it
    visible = on_plane & ~(ray_box(camera.pixel_rays()[0], dirs, lo, hi) < np.linalg.norm(points - camera.position, axis=-1))
    shadowed = np.isfinite(ray_box(points + 1e-4 * -sun_dir, np.broadcast_to(-sun_dir, points.shape), lo, hi))
    lit_value = ALBEDO / np.pi * 3.0 * -sun_dir[2]
    expected = np.where(shadowed, 0.0, lit_value)
    got = image[..., 0]
    mismatch = np.abs(got - expected) > 0.05 * lit_value
    fraction = mismatch[visible].mean()
    if fraction > MAX_SHADOW_MISMATCH_FRACTION:
        save_failure_images("sun_shadow", got=got, expected=expected)
    assert shadowed[visible].sum() > 100, "the test scene must put a real shadow on screen"
    assert fraction <= MAX_SHADOW_MISMATCH_FRACTION


def test_point_light_follows_inverse_square_and_cosine_law(renderer):
    camera = Camera(matrix_world=look_at((0, -5, 5), (0, 0, 0)), width=64, height=48)
    light_pos = np.array([0.5, 0.0, 2.0])
    power = 100.0
    scene = diffuse_scene([(quad((0, 0, 0), (5, 0, 0), (0, 5, 0)), None, 0)],
                          [dict(kind="POINT", position=light_pos, color=(power,) * 3)])
    image = renderer.render(scene, camera, RASTER).image
    on_plane, points, _ = plane_hits(camera)
    delta = light_pos - points
    dist2 = (delta ** 2).sum(-1)
    cos = delta[..., 2] / np.sqrt(dist2)
    expected = ALBEDO / np.pi * power / (4 * np.pi * dist2) * cos
    np.testing.assert_allclose(image[..., 0][on_plane], expected[on_plane], rtol=5e-3)


def test_point_light_shadow_from_the_cube_shadow_map(renderer):
    camera = Camera(matrix_world=look_at((0, -6, 7), (0, 0, 0)), width=80, height=60)
    light_pos = np.array([0.0, 0.0, 3.0])
    lo, hi = np.array([-0.5, -0.5, 1.0]), np.array([0.5, 0.5, 1.6])
    scene = diffuse_scene(
        [(quad((0, 0, 0), (5, 0, 0), (0, 5, 0)), None, 0), (box(lo, hi), None, 0)],
        [dict(kind="POINT", position=light_pos, color=(200.0,) * 3)],
    )
    image = renderer.render(scene, camera, RASTER).image
    on_plane, points, dirs = plane_hits(camera)
    visible = on_plane & ~(ray_box(camera.pixel_rays()[0], dirs, lo, hi) < np.linalg.norm(points - camera.position, axis=-1))
    to_light = light_pos - points
    dist = np.linalg.norm(to_light, axis=-1)
    t_box = ray_box(points, to_light / dist[..., None], lo, hi)
    shadowed = t_box < dist
    lit = ~shadowed & visible
    got = image[..., 0]
    assert shadowed[visible].sum() > 100
    assert (got[shadowed & visible] < 1e-6).mean() > 1 - MAX_SHADOW_MISMATCH_FRACTION * 4
    assert (got[lit] > 1e-3).mean() > 1 - MAX_SHADOW_MISMATCH_FRACTION


def test_spot_light_lights_only_inside_its_cone(renderer):
    camera = Camera(matrix_world=look_at((0, -0.01, 10), (0, 0, 0)), width=64, height=64, lens=30.0)
    scene = diffuse_scene([(quad((0, 0, 0), (5, 0, 0), (0, 5, 0)), None, 0)],
                          [dict(kind="SPOT", position=(0, 0, 2), direction=(0, 0, -1), color=(100.0,) * 3,
                                spot_size=np.radians(60.0), spot_blend=0.0)])
    image = renderer.render(scene, camera, RASTER).image
    on_plane, points, _ = plane_hits(camera)
    radius = np.linalg.norm(points[..., :2], axis=-1)
    cone_radius = 2 * np.tan(np.radians(30.0))
    inside = on_plane & (radius < cone_radius * 0.95)
    outside = on_plane & (radius > cone_radius * 1.05)
    assert inside.sum() > 50 and outside.sum() > 50
    assert (image[..., 0][inside] > 0.1).all()
    assert (image[..., 0][outside] == 0).all()


def test_emission_adds_radiance_without_lights(renderer):
    camera = Camera(matrix_world=look_at((0, 0, 5), (0, 0.0001, 0)), width=32, height=32)
    mats = MaterialTable.from_rows([dict(base_color=(0.5, 0.5, 0.5), emission=(1.5, 0.25, 0.0))])
    scene = diffuse_scene([(quad((0, 0, 0), (10, 0, 0), (0, 10, 0)), None, 0)], [], materials=mats)
    image = renderer.render(scene, camera, RASTER).image
    np.testing.assert_allclose(image[..., :3].reshape(-1, 3), np.broadcast_to([1.5, 0.25, 0.0], (1024, 3)), rtol=1e-6)


def test_mirror_reflects_the_sky_tinted_by_base_colour_in_raster_mode(renderer):
    camera = Camera(matrix_world=look_at((0, -3, 3), (0, 0, 0)), width=32, height=32)
    mats = MaterialTable.from_rows([dict(base_color=(1.0, 0.5, 0.25), reflectivity=1.0)])
    sky = Sky(color=(0.4, 0.4, 0.4))
    scene = diffuse_scene([(quad((0, 0, 0), (10, 0, 0), (0, 10, 0)), None, 0)],
                          [dict(kind="SUN", direction=(0, 0, -1), color=(5.0,) * 3)], materials=mats, sky=sky)
    image = renderer.render(scene, camera, RASTER).image
    on_plane, _, _ = plane_hits(camera)
    np.testing.assert_allclose(image[on_plane][:, :3], np.broadcast_to([0.4, 0.2, 0.1], (on_plane.sum(), 3)), rtol=1e-5)


def test_orthographic_camera_sees_a_uniformly_lit_plane(renderer):
    camera = Camera(matrix_world=look_at((0, 0, 5), (0, 0.0001, 0)), width=40, height=30,
                    projection="ORTHO", ortho_scale=4.0)
    scene = diffuse_scene([(quad((0, 0, 0), (5, 0, 0), (0, 5, 0)), None, 0)],
                          [dict(kind="SUN", direction=(0, 0, -1), color=(1.0,) * 3)])
    image = renderer.render(scene, camera, RASTER).image
    np.testing.assert_allclose(image[..., 0], ALBEDO / np.pi, rtol=RADIANCE_RTOL)


def test_smooth_normals_shade_a_sphere_like_the_analytic_sphere(renderer):
    camera = Camera(matrix_world=look_at((0, -6, 0), (0, 0, 0)), width=64, height=64, lens=60)
    tris, normals = uv_sphere((0, 0, 0), 1.0, segments=64, rings=32)
    scene = diffuse_scene([(tris, normals, 0)], [dict(kind="SUN", direction=(0, 1, 0), color=(1.0,) * 3)])
    image = renderer.render(scene, camera, RASTER).image
    origins, dirs = camera.pixel_rays()
    # Exact sphere intersection: the smooth normal at the hit is the sphere normal.
    b = (origins * dirs).sum(-1)
    c = (origins ** 2).sum(-1) - 1.0
    disc = b * b - c
    inner = disc > 0.05  # away from the faceted silhouette
    t = -b - np.sqrt(np.maximum(disc, 0))
    n = origins + dirs * t[..., None]
    expected = ALBEDO / np.pi * np.maximum(n[..., 1] * -1.0, 0)
    assert np.abs(image[..., 0][inner] - expected[inner]).max() < 0.02


def test_empty_scene_renders_the_sky(renderer):
    camera = Camera(width=16, height=8)
    scene = SceneData(Geometry.empty(), MaterialTable.default(), Lights.empty(), Sky(color=(0.3, 0.2, 0.1)))
    result = renderer.render(scene, camera, RASTER)
    np.testing.assert_allclose(result.image[..., :3].reshape(-1, 3), np.broadcast_to([0.3, 0.2, 0.1], (128, 3)))
    assert result.counts["triangles_total"] == 0


def test_nan_and_degenerate_triangles_neither_crash_nor_poison_the_image(renderer):
    camera = Camera(matrix_world=look_at((0, -6, 4), (0, 0, 0)), width=48, height=32)
    good = quad((0, 0, 0), (5, 0, 0), (0, 5, 0))
    bad = np.array([[[np.nan, 0, 0], [1, 0, 0], [0, 1, 0]],
                    [[np.inf, 0, 1], [1, -np.inf, 0], [0, 1, 0]],
                    [[1, 1, 1], [1, 1, 1], [1, 1, 1]],          # zero area
                    [[0, 0, 1], [1, 1, 1], [2, 2, 1]]], np.float32)  # collinear
    bad_normals = np.full((4, 3, 3), np.nan, np.float32)
    sun = [dict(kind="SUN", direction=(0, 0, -1), color=(1.0,) * 3)]
    clean = renderer.render(diffuse_scene([(good, None, 0)], sun), camera, RASTER).image
    dirty_scene = diffuse_scene([(good, None, 0), (bad, bad_normals, 0)], sun)
    before = dirty_scene.geometry.triangles.copy()
    dirty = renderer.render(dirty_scene, camera, RASTER).image
    assert np.isfinite(dirty).all()
    np.testing.assert_array_equal(dirty, clean)
    np.testing.assert_array_equal(dirty_scene.geometry.triangles, before)  # input untouched


def test_timing_reports_every_pass_on_request_and_is_off_by_default(renderer):
    camera = Camera(width=16, height=16)
    scene = diffuse_scene([(quad((0, 0, -3), (1, 0, 0), (0, 1, 0)), None, 0)], [])
    timed = renderer.render(scene, camera, RASTER, timing=True)
    assert set(timed.passes) == {"upload", "instance_transform", "shadow_maps", "lighting", "primary_raster",
                                 "shade", "readback"}
    assert timed.timing_source.startswith("wall clock")
    assert sum(timed.passes.values()) <= timed.total_ms * 1.01
    untimed = renderer.render(scene, camera, RASTER)
    assert untimed.passes == {} and untimed.timing_source == "off"
    np.testing.assert_array_equal(timed.image, untimed.image)


def test_cancel_callback_stops_the_frame_and_the_next_frame_renders(renderer):
    from hybrid_engine.frame.renderer import RenderCancelled

    camera = Camera(width=16, height=16)
    scene = diffuse_scene([(quad((0, 0, -3), (1, 0, 0), (0, 1, 0)), None, 0)], [])
    with pytest.raises(RenderCancelled):
        renderer.render(scene, camera, RASTER, cancel=lambda: True)
    assert renderer.render(scene, camera, RASTER).image.shape == (16, 16, 4)


# -- per-triangle culling of the primary and shadow draws (SceneDrawer.draw_views) ----------

GBUFFER_TARGETS = ("depth", "normal_material", "albedo", "emission_scale", "color")


def frames_rendered(gl, frames, settings, cull: bool) -> dict:
    """Render ``frames`` in order with a fresh renderer whose raster passes cull per triangle
    or draw the object lists; the last frame's targets, shadow layers, counts and the
    culled batches' drawn triangles. The per-triangle culling is the ``vertices`` kernel's
    "cpu" shape (the "gpu" shape draws instanced, unculled), so it is pinned here: the
    renderer's own choice depends on the GL renderer."""
    from hybrid_engine.gpu import variants

    r = Renderer(gl)
    r.drawer.cull_triangles = cull
    variants.set_override("vertices=cpu")
    try:
        for scene, camera in frames:
            result = r.render(scene, camera, settings)
        static, dynamic = r.shadow_maps.atlas.read_layers()
        return {
            "targets": {name: getattr(r.gbuffer.primary, name).read() for name in GBUFFER_TARGETS},
            "static": static, "dynamic": dynamic, "counts": result.counts, "image": result.image,
            "drawn": {layer: [None if c is None else c.drawn() for c in batches]
                      for layer, batches in r.drawer.culled.items()},
        }
    finally:
        variants.set_override(None)
        r.release()


def assert_same_targets(a: dict, b: dict) -> None:
    for name in GBUFFER_TARGETS:
        same = np.frombuffer(a["targets"][name], np.uint8) == np.frombuffer(b["targets"][name], np.uint8)
        assert same.all(), f"{name}: {np.count_nonzero(~same)} bytes differ"
    np.testing.assert_array_equal(a["static"], b["static"])
    np.testing.assert_array_equal(a["dynamic"], b["dynamic"])
    np.testing.assert_array_equal(a["image"], b["image"])


def test_culled_primary_and_shadow_draws_equal_the_object_lists_on_moving_chess_frames(gl):
    """Two Chess frames (the second moves pieces, so both shadow layers are drawn, each with
    its include mask; seven shadow slots make two batches): the G-buffer, both shadow
    layers and the image are bit-identical to drawing the object lists, with the same
    triangles submitted, and most primary triangles never reach the rasterizer."""
    from benchmarks.scenes.chess import build_chess
    from hybrid_engine.passes.view_cull.view_cull import MAX_VIEWS

    frames = [build_chess(detail=0.05, frame=f, width=96, height=54) for f in (3, 4)]
    settings = RenderSettings(mode="RASTER", shadow_resolution=256)
    culled = frames_rendered(gl, frames, settings, cull=True)
    direct = frames_rendered(gl, frames, settings, cull=False)
    assert_same_targets(culled, direct)
    for key in ("triangles_primary_submitted", "shadow_triangles_submitted"):
        assert culled["counts"][key] == direct["counts"][key]
    assert culled["counts"]["shadow_static_rendered"] == 1
    assert all(b is None for batches in direct["drawn"].values() for b in batches)
    [[primary_drawn]] = culled["drawn"]["primary"]
    assert 0 < primary_drawn < 0.6 * culled["counts"]["triangles_primary_submitted"]
    for layer in ("shadow_static", "shadow_dynamic"):
        batches = culled["drawn"][layer]
        assert len(batches) == 2 and all(b is not None for b in batches), f"{layer}: {len(batches)} batches"
        assert len(batches[0]) == MAX_VIEWS and sum(map(sum, batches)) > 0


def test_a_dense_distant_mesh_reaches_the_rasterizer_as_a_few_triangles(gl):
    """A 40k-triangle sphere a few pixels wide: the culled draw keeps a small fraction of
    its triangles (those covering a pixel centre and facing the camera) and the G-buffer
    is unchanged."""
    ball, ball_n = uv_sphere((0, 0, 0), 1.0, 200, 100)
    scene = diffuse_scene([(quad((0, 0, -1), (8, 0, 0), (0, 8, 0)), None, 0), (ball, ball_n, 0)],
                          [dict(kind="SUN", direction=(0.2, 0.1, -1.0), color=(1.0,) * 3)])
    camera = Camera(matrix_world=look_at((0, -30, 6), (0, 0, 0)), width=64, height=48)
    culled = frames_rendered(gl, [(scene, camera)], RASTER, cull=True)
    direct = frames_rendered(gl, [(scene, camera)], RASTER, cull=False)
    assert_same_targets(culled, direct)
    [[primary_drawn]] = culled["drawn"]["primary"]
    assert primary_drawn < 0.05 * scene.geometry.triangle_count


def test_draws_past_the_storage_block_limit_fall_back_to_the_object_lists(gl):
    """An index buffer larger than one storage block is not built: the primary view, the
    shadow slots and the sun's cascades draw their object lists, with the same image."""
    from hybrid_engine.gpu.dispatch import forced_limits
    from benchmarks.scenes.chess import build_chess

    frames = [build_chess(detail=0.03, frame=0, width=48, height=27)]
    normal = frames_rendered(gl, frames, RASTER, cull=True)
    # Past every draw list's index buffer, within every mesh of the instance store.
    with forced_limits(max_block=96 * 1024):
        limited = frames_rendered(gl, frames, RASTER, cull=True)
    assert limited["drawn"] == {"primary": [None], "shadow_static": [None, None], "shadow_cascades_static": [None]}
    assert_same_targets(limited, normal)


# -- one pass, one module ---------------------------------------------------------------------

def test_a_hybrid_frame_enters_each_raster_pass_module_once(monkeypatch):
    """Following a frame through the code, the shadow, G-buffer and deferred-shading modules
    are each entered once per pass: the primary view and the six cube faces are one call
    each, and the shadow pass owns its cache and both layers."""
    from hybrid_engine.passes.shading import deferred_shade
    from hybrid_engine.passes.gbuffer import gbuffer
    from hybrid_engine.passes.shadow_maps import shadow_depth

    entries = {}
    for cls, name in ((shadow_depth.ShadowDepthPass, "render"), (gbuffer.GBufferPass, "render_primary"),
                      (gbuffer.GBufferPass, "render_cube_faces"), (deferred_shade.DeferredShadePass, "shade")):
        original = getattr(cls, name)

        def counted(self, *args, _original=original, _key=f"{cls.__module__}.{name}", **kwargs):
            entries[_key] = entries.get(_key, 0) + 1
            return _original(self, *args, **kwargs)

        monkeypatch.setattr(cls, name, counted)
    camera = Camera(matrix_world=look_at((0, -6, 4), (0, 0, 0)), width=32, height=24)
    scene = diffuse_scene([(quad((0, 0, 0), (5, 0, 0), (0, 5, 0)), None, 0), (box((-1, -1, 0), (1, 1, 2)), None, 0)],
                          [dict(kind="POINT", position=(2.0, -2.0, 4.0), color=(50.0, 50.0, 50.0))])
    r = Renderer()
    try:
        r.render(scene, camera, RenderSettings(mode="HYBRID", near_size=1.5, cube_resolution=32))
    finally:
        r.release()
    assert entries == {"hybrid_engine.passes.shadow_maps.shadow_depth.render": 1, "hybrid_engine.passes.gbuffer.gbuffer.render_primary": 1,
                       "hybrid_engine.passes.gbuffer.gbuffer.render_cube_faces": 1, "hybrid_engine.passes.shading.deferred_shade.shade": 1}
