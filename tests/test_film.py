# SPDX-License-Identifier: GPL-3.0-or-later
"""The film (hybrid_engine/frame/film.py) through the renderer: transparent background, the Depth
and Normal passes against analytic ray-plane intersections, and the render region's camera
against the crop of a whole frame. Blender's side (the passes in a multilayer EXR, Cycles'
conventions) is in test_engine.py."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine import Camera, Geometry, Lights, MaterialTable, RenderSettings, SceneData, Sky
from hybrid_engine.scene.camera import look_at
from hybrid_engine.frame.film import BACKGROUND_DEPTH, FilmError, FrameOutputs
from hybrid_engine.frame.views import border_pixels, region_camera
from scenes_analytic import quad, ray_plane_z
from test_scale import DEFAULTS, built

SMALL = dict(cube_resolution=32, shadow_resolution=128, near_size=2.0)
SKY = (0.2, 0.3, 0.5)
# The depth buffer holds 24 bits; the pass is exact up to that and float32.
DEPTH_RTOL = 1e-4


def floor_scene(mirror: bool = False) -> SceneData:
    """A 6 x 6 floor at z = 0 facing up (diffuse, or a mirror), a sun, a blue sky."""
    mats = MaterialTable.from_rows([dict(base_color=(0.8, 0.8, 0.8), reflectivity=1.0 if mirror else 0.0)])
    floor = quad((0, 0, 0), (3, 0, 0), (0, 3, 0))
    return SceneData(Geometry.from_objects([(floor, None, 0)]), mats,
                     Lights.from_rows([dict(kind="SUN", direction=(0.2, 0.3, -1), color=(2, 2, 2))]),
                     Sky(color=SKY))


def cameras() -> dict[str, Camera]:
    """Views that see the floor's edge against the sky: perspective (shifted, so the frustum
    is off-axis), orthographic, and one from below, which sees the floor's back side."""
    return {
        "persp": Camera(matrix_world=look_at((1.0, -5.0, 3.0), (0.5, 0.0, 0.0)), width=32, height=20,
                        lens=30.0, shift_x=0.1, shift_y=-0.05),
        "ortho": Camera(matrix_world=look_at((0.5, -4.0, 4.0), (1.5, 0.0, 0.0)), width=32, height=20,
                        projection="ORTHO", ortho_scale=8.0),
        "below": Camera(matrix_world=look_at((0.5, -4.0, -2.0), (0.0, 1.0, 0.0)), width=32, height=20,
                        lens=28.0),
    }


def analytic_floor(camera: Camera) -> tuple[np.ndarray, np.ndarray]:
    """(hit mask, planar depth) of the floor quad at every pixel centre: rays through the
    camera's pixels meet z = 0 inside |x|, |y| <= 3, depth along the view axis."""
    origins, dirs = camera.pixel_rays()
    t = ray_plane_z(origins.reshape(-1, 3), dirs.reshape(-1, 3)).reshape(origins.shape[:2])
    points = origins + dirs * np.where(np.isfinite(t), t, 0.0)[..., None]
    hit = np.isfinite(t) & (t > 0) & (np.abs(points[..., 0]) <= 3) & (np.abs(points[..., 1]) <= 3)
    depth = (points - camera.position) @ camera.forward
    return hit, depth


@pytest.mark.parametrize("name", ["persp", "ortho", "below"])
def test_depth_pass_is_the_distance_along_the_view_axis_and_1e10_on_the_background(renderer, name):
    camera = cameras()[name]
    result = renderer.render(floor_scene(), camera, RenderSettings(mode="RASTER", **SMALL),
                             outputs=FrameOutputs(depth=True))
    depth = result.data_passes["depth"]
    assert depth.shape == (20, 32) and depth.dtype == np.float32
    hit, expected = analytic_floor(camera)
    # Pixels whose centre lies within a hair of the quad's edge may go either way.
    agree = (depth < BACKGROUND_DEPTH) == hit
    assert (~agree).sum() <= 2, f"{(~agree).sum()} pixels disagree on hit/background"
    both = hit & (depth < BACKGROUND_DEPTH)
    assert both.sum() > 100 and (~hit).sum() > 20, "the view must show floor and background"
    np.testing.assert_allclose(depth[both], expected[both], rtol=DEPTH_RTOL)
    assert (depth[~hit & agree] == BACKGROUND_DEPTH).all()


def test_normal_pass_faces_the_camera_on_both_sides_of_a_surface(renderer):
    views = cameras()
    for name, expected_z in (("persp", 1.0), ("below", -1.0)):
        result = renderer.render(floor_scene(), views[name], RenderSettings(mode="RASTER", **SMALL),
                                 outputs=FrameOutputs(normal=True))
        normal = result.data_passes["normal"]
        hit, _ = analytic_floor(views[name])
        inside = hit & (normal != 0).any(axis=-1)
        assert inside.sum() > 100
        np.testing.assert_allclose(normal[inside], np.broadcast_to((0.0, 0.0, expected_z), normal[inside].shape),
                                   atol=1e-6, err_msg=name)
        assert (normal[~hit & ~(normal != 0).any(axis=-1)] == 0).all()


def test_normal_pass_normalises_and_uses_the_back_side_flag(ctx):
    """The GPU pass on a hand-made G-buffer: an unnormalised front side, a back side
    (negative material code) reported flipped, and the background 0."""
    from hybrid_engine.passes.film.data_passes import DataPassesPass, read_data_passes

    nm = np.zeros((1, 3, 4), np.float32)
    nm[0, 0] = (0.0, 0.0, 2.0, 3.0)  # front side, unnormalised
    nm[0, 1] = (0.0, 0.6, 0.8, -1.0)  # back side: reported flipped
    normal_material = ctx.texture((3, 1), 4, nm.tobytes(), dtype="f4")
    depth = ctx.depth_texture((3, 1), np.array([0.5, 0.5, 1.0], np.float32).tobytes())
    data_passes = DataPassesPass(ctx)
    try:
        textures = data_passes.compute(depth, normal_material, Camera(width=3, height=1))
        out = read_data_passes(textures, ("depth", "normal"))
    finally:
        data_passes.release()
        normal_material.release()
        depth.release()
    np.testing.assert_allclose(out["normal"][0], [[0, 0, 1], [0, -0.6, -0.8], [0, 0, 0]], atol=1e-7)
    assert out["depth"][0, 2] == BACKGROUND_DEPTH and 0 < out["depth"][0, 0] < BACKGROUND_DEPTH


def test_frames_without_data_passes_carry_none(renderer):
    result = renderer.render(floor_scene(), cameras()["persp"], RenderSettings(mode="RASTER", **SMALL))
    assert result.data_passes == {}


@pytest.mark.parametrize("mode", ["RASTER", "HYBRID", "FULL_BVH"])
def test_transparent_film_clears_the_background_and_mirrors_still_see_the_sky(renderer, mode):
    camera = cameras()["persp"]
    settings = RenderSettings(mode=mode, **SMALL)
    opaque = renderer.render(floor_scene(mirror=True), camera, settings).image
    clear = renderer.render(floor_scene(mirror=True), camera, settings, outputs=FrameOutputs(transparent=True)).image
    hit, _ = analytic_floor(camera)
    background = clear[..., 3] == 0
    assert abs(int(background.sum()) - int((~hit).sum())) <= 2
    assert (clear[background] == 0).all(), "transparent pixels are premultiplied: colour 0"
    assert (opaque[..., 3] == 1).all()
    # The mirror floor reflects the sky (the sun's highlight aside, the floor is a mirror):
    # the same colour with and without the transparent background.
    np.testing.assert_allclose(clear[~background], opaque[~background], rtol=1e-6, atol=1e-7)
    assert (clear[~background][:, 3] == 1).all()
    assert np.allclose(clear[~background][:, :3].mean(axis=0), np.multiply(SKY, 0.8), rtol=0.05)


def test_border_pixels_truncate_like_blenders_pipeline():
    # 0.13 * 37 = 4.81 -> 4, 0.71 * 37 = 26.27 -> 26; 0.27 * 23 = 6.21 -> 6, 0.9 * 23 = 20.7 -> 20.
    assert border_pixels(37, 23, (0.13, 0.27), (0.71, 0.9)) == (4, 6, 26, 20)
    assert border_pixels(40, 20, (0.0, 0.0), (1.0, 1.0)) == (0, 0, 40, 20)
    with pytest.raises(FilmError, match="covers no pixel"):
        border_pixels(40, 20, (0.5, 0.2), (0.51, 0.8))


@pytest.mark.parametrize("name", ["persp", "ortho"])
def test_region_camera_renders_exactly_the_regions_pixels_of_the_whole_frame(renderer, name):
    camera = cameras()[name]
    settings = RenderSettings(mode="HYBRID", **SMALL)
    outputs = FrameOutputs(depth=True)
    whole = renderer.render(floor_scene(mirror=True), camera, settings, outputs=outputs)
    rect = border_pixels(camera.width, camera.height, (0.13, 0.27), (0.71, 0.9))
    x0, y0, x1, y1 = rect
    part = renderer.render(floor_scene(mirror=True), region_camera(camera, rect), settings, outputs=outputs)
    assert part.image.shape == (y1 - y0, x1 - x0, 4)
    np.testing.assert_allclose(part.image, whole.image[y0:y1, x0:x1], rtol=1e-4, atol=1e-5)
    np.testing.assert_allclose(part.data_passes["depth"], whole.data_passes["depth"][y0:y1, x0:x1], rtol=DEPTH_RTOL)
    assert region_camera(camera, (0, 0, camera.width, camera.height)) is camera


def test_a_region_draws_the_whole_frames_numbers_for_its_traced_diffuse_light(renderer):
    """One sample of traced diffuse light, not denoised: its noise is keyed by the surface
    points (random.glsl's position keys), in cells sized by the whole view's pixel, and its
    first directions by the whole frame's pixel (Camera.pixel_origin), so a render region
    shows the same noise as the frame. Only the points whose read-back position crosses a
    cell's boundary draw other numbers (with cells of 1/4096 m, a tenth of the pixels and
    more did)."""
    scene, camera = built(1.0)
    whole = renderer.render(scene, camera, DEFAULTS).image[..., :3]
    for rect in ((60, 30, 96, 64), (0, 0, 40, 30), (20, 10, 70, 50)):
        x0, y0, x1, y1 = rect
        part = renderer.render(scene, region_camera(camera, rect), DEFAULTS).image[..., :3]
        differ = np.abs(part - whole[y0:y1, x0:x1]).max(axis=2) > 1e-3
        assert differ.mean() < 0.03, (rect, differ.mean())


# ---------------------------------------------------------------------------------------------
# The Denoising Albedo and Normal (Cycles' Denoising Data passes, the Denoise node's guides).

# Patches lying on the diffuse floor, z = PATCH_Z, each (x centre, material row, its expected
# Denoising Albedo): Cycles' rule splits closures at GGX alpha 0.075 (roughness 0.274) and
# writes a surface's diffuse-like albedo when more than a quarter of it is diffuse-like, its
# specular tint otherwise (gpu_shaders/film/data_passes.comp.glsl).
PATCH_Z = 0.01
FLOOR_COLOR = (0.8, 0.5, 0.2)
PATCHES = (
    (-2.0, dict(base_color=(0.9, 0.7, 0.6), reflectivity=1.0, roughness=0.0), (0.9, 0.7, 0.6)),  # mirror: tint
    (-1.0, dict(base_color=(0.3, 0.6, 0.9), reflectivity=1.0, roughness=0.6), (0.3, 0.6, 0.9)),  # rough metal
    (0.0, dict(base_color=(0.2, 0.9, 0.4), reflectivity=0.5, roughness=0.1), (0.1, 0.45, 0.2)),  # half smooth metal
    (1.0, dict(base_color=(0.95, 0.9, 1.0), transmission=1.0, roughness=0.0, ior=1.5), (0.95, 0.9, 1.0)),  # glass
    (2.0, dict(base_color=(0.9, 0.7, 0.6), reflectivity=0.8, roughness=0.2), (0.72, 0.56, 0.48)),  # smooth metal
)
PATCH_HALF = 0.4
# The G-buffer stores the albedo in half floats.
ALBEDO_ATOL = 2e-3


def patches_scene() -> SceneData:
    rows = [dict(base_color=FLOOR_COLOR, roughness=0.5)] + [row for _, row, _ in PATCHES]
    objects = [(quad((0, 0, 0), (3, 0, 0), (0, 3, 0)), None, 0)]
    objects += [(quad((x, 0.0, PATCH_Z), (PATCH_HALF, 0, 0), (0, PATCH_HALF, 0)), None, i + 1)
                for i, (x, _, _) in enumerate(PATCHES)]
    return SceneData(Geometry.from_objects(objects), MaterialTable.from_rows(rows),
                     Lights.from_rows([dict(kind="SUN", direction=(0.2, 0.3, -1), color=(2, 2, 2))]), Sky(color=SKY))


def cycles_camera_normal(camera: Camera, world_normal) -> np.ndarray:
    """A world direction in Cycles' camera space: Blender's camera axes with z into the view."""
    return np.diag([1.0, 1.0, -1.0]) @ camera.rotation.T @ np.asarray(world_normal, np.float64)


def expected_albedo(camera: Camera, margin: float = 0.03) -> tuple[np.ndarray, np.ndarray]:
    """(pixels safely inside one surface, the Denoising Albedo there) from the pixel rays: a
    patch where a ray meets z = PATCH_Z inside it, else the floor, else nothing."""
    origins, dirs = camera.pixel_rays()
    albedo = np.zeros(origins.shape, np.float64)
    known = np.zeros(origins.shape[:2], bool)
    hit_floor, _ = analytic_floor(camera)
    t = ray_plane_z(origins.reshape(-1, 3) - (0, 0, PATCH_Z), dirs.reshape(-1, 3)).reshape(origins.shape[:2])
    p = origins + dirs * np.where(np.isfinite(t), t, 0.0)[..., None]
    near_edge = np.zeros_like(known)
    on_patch = np.zeros_like(known)
    for x, _, colour in PATCHES:
        dx, dy = np.abs(p[..., 0] - x), np.abs(p[..., 1])
        inside = (dx <= PATCH_HALF - margin) & (dy <= PATCH_HALF - margin)
        near_edge |= (dx <= PATCH_HALF + margin) & (dy <= PATCH_HALF + margin) & ~inside
        albedo[inside] = colour
        on_patch |= inside
    inner_floor = hit_floor & (np.abs(p[..., 0]) < 3 - margin) & (np.abs(p[..., 1]) < 3 - margin)
    albedo[inner_floor & ~on_patch & ~near_edge] = FLOOR_COLOR
    known = (on_patch | (inner_floor & ~near_edge)) | (~hit_floor & ~near_edge & ~(np.abs(p[..., :2]) < 3 + margin).all(-1))
    return known, albedo


def test_denoising_albedo_is_the_diffuse_colour_or_a_specular_surfaces_tint_and_the_normal_is_in_cycles_camera_space(
        renderer):
    camera = Camera(matrix_world=look_at((0.0, -4.5, 3.5), (0.0, 0.3, 0.0)), width=64, height=48, lens=30.0)
    result = renderer.render(patches_scene(), camera, RenderSettings(mode="RASTER", **SMALL),
                             outputs=FrameOutputs(denoising=True))
    albedo, normal = result.data_passes["denoising_albedo"], result.data_passes["denoising_normal"]
    assert albedo.shape == normal.shape == (48, 64, 3) and albedo.dtype == np.float32
    known, expected = expected_albedo(camera)
    assert known.sum() > 0.8 * known.size
    np.testing.assert_allclose(albedo[known], expected[known], atol=ALBEDO_ATOL)
    for x, _, colour in PATCHES:  # every patch is in view
        assert (np.abs(albedo[known] - colour).max(axis=-1) < ALBEDO_ATOL).sum() > 20, colour
    surface = known & (expected != 0).any(axis=-1)
    np.testing.assert_allclose(normal[surface], np.broadcast_to(cycles_camera_normal(camera, (0, 0, 1)),
                                                                normal[surface].shape), atol=1e-5)
    assert (normal[~(expected != 0).any(axis=-1) & known] == 0).all(), "nothing on the background"
    assert (albedo[~(expected != 0).any(axis=-1) & known] == 0).all()


def test_denoising_normal_faces_the_camera_seeing_a_back_side(renderer):
    camera = cameras()["below"]
    result = renderer.render(floor_scene(), camera, RenderSettings(mode="RASTER", **SMALL),
                             outputs=FrameOutputs(denoising=True))
    normal = result.data_passes["denoising_normal"]
    hit, _ = analytic_floor(camera)
    inside = hit & (normal != 0).any(axis=-1)
    assert inside.sum() > 100
    toward = cycles_camera_normal(camera, (0, 0, -1))
    assert toward[2] < 0, "a normal facing the camera points against Cycles' view axis"
    np.testing.assert_allclose(normal[inside], np.broadcast_to(toward, normal[inside].shape), atol=1e-5)


def test_denoising_passes_are_the_mean_over_a_final_renders_samples_like_its_colour(renderer):
    """Edge pixels: the floor covers a fraction of each (the transparent film's alpha, the
    mean of the samples' coverage), and the guides are that fraction of the surface's."""
    from hybrid_engine.frame.antialias import render_antialiased

    camera = cameras()["persp"]
    outputs = FrameOutputs(transparent=True, depth=True, denoising=True)
    result = render_antialiased(renderer, floor_scene(), camera, RenderSettings(mode="RASTER", **SMALL), 8,
                                outputs=outputs)
    alpha = result.image[..., 3]
    partial = (alpha > 0.05) & (alpha < 0.95)
    assert partial.sum() >= 10, "the view has edge pixels"
    np.testing.assert_allclose(result.data_passes["denoising_albedo"],
                               np.repeat(alpha[..., None] * np.float32(0.8), 3, axis=-1), atol=ALBEDO_ATOL)
    np.testing.assert_allclose(result.data_passes["denoising_normal"],
                               alpha[..., None] * cycles_camera_normal(camera, (0, 0, 1)), atol=1e-5)
    # The Depth stays the first sample's, at the pixels' centres.
    single = renderer.render(floor_scene(), camera, RenderSettings(mode="RASTER", **SMALL),
                             outputs=FrameOutputs(depth=True))
    np.testing.assert_array_equal(result.data_passes["depth"], single.data_passes["depth"])


def test_denoising_means_refuse_a_sample_that_does_not_follow_the_last(renderer):
    from hybrid_engine.passes.film.accumulate import AccumulationError

    camera, settings = cameras()["persp"], RenderSettings(mode="RASTER", **SMALL)
    renderer.render(floor_scene(), camera, settings, outputs=FrameOutputs(denoising=True), sample=0)
    with pytest.raises(AccumulationError, match="denoising sample 2"):
        renderer.render(floor_scene(), camera, settings, outputs=FrameOutputs(denoising=True), sample=2)


def test_denoising_albedo_is_the_base_colour_times_its_image_texture(renderer):
    """A uniform image (so that filtering cannot blur it) multiplies the base colour."""
    image = np.ones((4, 4, 4), np.float32)
    image[..., :3] = (0.5, 0.25, 1.0)
    table = MaterialTable.from_rows([dict(base_color=(0.8, 0.6, 0.4), base_color_texture=image)])
    floor = quad((0, 0, 0), (3, 0, 0), (0, 3, 0))
    scene = SceneData(Geometry.from_objects([(floor, None, 0)]), table, Lights.from_rows([]), Sky(color=SKY))
    camera = cameras()["persp"]
    result = renderer.render(scene, camera, RenderSettings(mode="RASTER", **SMALL), outputs=FrameOutputs(denoising=True))
    albedo = result.data_passes["denoising_albedo"]
    hit, _ = analytic_floor(camera)
    inside = hit & (albedo != 0).any(axis=-1)
    assert inside.sum() > 100
    np.testing.assert_allclose(albedo[inside], np.broadcast_to((0.4, 0.15, 0.4), albedo[inside].shape),
                               atol=ALBEDO_ATOL)
