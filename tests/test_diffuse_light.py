# SPDX-License-Identifier: GPL-3.0-or-later
"""Diffuse light by traced paths (passes/diffuse_light/): occlusion at any distance, and
bounces that raise what the lamps and the sky do not reach directly."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from hybrid_engine.gpu import variants
from hybrid_engine.scene.camera import Camera, look_at
from hybrid_engine.scene.data import Lights, MaterialTable, SceneData, Sky
from hybrid_engine.scene.geometry import Geometry
from hybrid_engine.scene.settings import RenderSettings
from scenes_analytic import box, quad

W, H = 48, 36
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])  # Rec. 709, as Blender's scene-linear space
GREY, MIRROR, ROUGH_METAL = 0, 1, 2
ROOM_HALF = 3.0


def luminance(image: np.ndarray) -> np.ndarray:
    return image[..., :3] @ LUMINANCE


def mean_image(renderer, scene, camera, settings, samples) -> np.ndarray:
    return np.mean([renderer.render(scene, camera, settings, timing=False, sample=i).image[..., :3]
                    for i in range(samples)], axis=0)


# A rough metal panel on the far wall (y = +ROOM_HALF), facing into the room: x, z extents.
PANEL_X = (-2.9, -0.1)
PANEL_Z = (-2.9, 2.9)


def closed_room(lamp: dict | None = None, partition: bool = False, rough_metal: bool = False) -> SceneData:
    """A closed box (six walls facing in) under a white World of strength 1, with a mirror
    on the floor; ``partition``: a wall across the room, two thirds of its height;
    ``rough_metal``: a panel of rough metal (reflectivity 1, roughness 1: Sponza's curtains)
    over part of the far wall."""
    walls = box((-ROOM_HALF,) * 3, (ROOM_HALF,) * 3)[:, ::-1].copy()  # corners reversed: normals inward
    objects = [(walls, None, GREY), (quad((-1.5, 1.0, -ROOM_HALF + 0.01), (0.8, 0, 0), (0, 0.8, 0)), None, MIRROR)]
    if partition:
        objects.append((quad((0.0, 0.0, -1.0), (0, ROOM_HALF, 0), (0, 0, 2.0)), None, GREY))
    if rough_metal:
        objects.append((rough_metal_panel(ROOM_HALF - 0.01), None, ROUGH_METAL))
    rows = [dict(base_color=(0.8, 0.8, 0.8)), dict(base_color=(1.0, 1.0, 1.0), reflectivity=1.0, roughness=0.0),
            dict(base_color=(0.8, 0.8, 0.8), reflectivity=1.0, roughness=1.0)]
    lights = Lights.from_rows([lamp]) if lamp is not None else Lights.from_rows([])
    return SceneData(Geometry.from_objects(objects), MaterialTable.from_rows(rows), lights,
                     Sky(color=(1.0, 1.0, 1.0)))


def rough_metal_panel(y: float) -> np.ndarray:
    """The panel's two triangles in the plane at ``y``, facing -y."""
    return quad(((PANEL_X[0] + PANEL_X[1]) / 2, y, (PANEL_Z[0] + PANEL_Z[1]) / 2),
                ((PANEL_X[1] - PANEL_X[0]) / 2, 0, 0), (0, 0, (PANEL_Z[1] - PANEL_Z[0]) / 2))


def on_panel(origins: np.ndarray, dirs: np.ndarray, y: float) -> np.ndarray:
    """Which rays meet the panel's plane at ``y`` within its extents (ahead of them)."""
    t = (y - origins[..., 1]) / dirs[..., 1]
    hit = origins + dirs * t[..., None]
    margin = 0.2  # clear of the panel's edges, where a pixel sees the wall too
    return ((t > 0) & (hit[..., 0] > PANEL_X[0] + margin) & (hit[..., 0] < PANEL_X[1] - margin)
            & (hit[..., 2] > PANEL_Z[0] + margin) & (hit[..., 2] < PANEL_Z[1] - margin))


def room_settings(mode: str, **kw) -> RenderSettings:
    # HYBRID's near cube holds the camera's half of the room: the far walls are found in the
    # cube map, as are the mirror's reflections of them.
    return RenderSettings(mode=mode, near_size=2.0, shadow_resolution=512, **kw)


ROOM_CAMERA = dict(eye=(0.5, -2.0, 0.5), target=(-0.5, 1.0, -1.5))


@pytest.mark.parametrize("mode", ["HYBRID", "FULL_BVH"])
def test_a_closed_room_is_black_without_lamps_and_leaks_the_sky_when_occlusion_stops_at_a_distance(renderer, mode):
    # Six walls and no opening: no ray from inside reaches the sky, however far the walls
    # are. The mirror on the floor shows walls whose light is gathered too (the tracer's
    # first-bounce gather). Screen-space occlusion within a short AO Distance lets the sky in.
    scene = closed_room()
    camera = Camera(matrix_world=look_at(ROOM_CAMERA["eye"], ROOM_CAMERA["target"]), width=W, height=H)
    rays = mean_image(renderer, scene, camera, room_settings(mode), samples=2)
    leak = mean_image(renderer, scene, camera, room_settings(mode, world_light="SCREEN", ao_distance=0.5), samples=2)
    assert luminance(rays).mean() <= 0.01
    assert luminance(leak).mean() > 0.3


def test_a_closed_room_stays_black_with_the_camera_against_a_wall(renderer):
    # 5 cm from the wall behind it, the camera's near cube (2 m either side) reaches past the
    # wall: the cube map's faces, whose near planes lie outside the room, see the sky there,
    # and the wall, seen edge-on from the camera, is a sliver of texels in them that the
    # paths crossing it elsewhere slip through. The BVH holds the wall's whole triangles, and
    # they graze the near cube (passes/diffuse_light/grazing.py), so a path that leaves from
    # outside the near cube is tested against them too.
    scene = closed_room()
    eye = np.array([0.0, -ROOM_HALF + 0.05, 0.0])
    camera = Camera(matrix_world=look_at(eye, (0.0, 1.0, -1.5)), width=W, height=H)
    image = mean_image(renderer, scene, camera, room_settings("HYBRID", diffuse_bounces=0), samples=2)
    assert luminance(image).mean() <= 0.01, luminance(image).mean()


def test_the_mirrors_reflection_of_a_closed_room_is_black_too(renderer):
    # Only the mirror's pixels: its reflection rays meet walls in the BVH and the cube map,
    # whose diffuse light the first-bounce gather finds at any distance (AO Distance 0 would
    # give them the whole sky).
    scene = closed_room()
    camera = Camera(matrix_world=look_at((-1.5, 0.0, 0.0), (-1.5, 1.0, -ROOM_HALF)), width=W, height=H)
    settings = room_settings("HYBRID", ao_distance=0.0)
    image = luminance(mean_image(renderer, scene, camera, settings, samples=2))
    origins, dirs = camera.pixel_rays()
    t = (-ROOM_HALF + 0.01 - origins[..., 2]) / dirs[..., 2]
    hit = origins + dirs * t[..., None]
    on_mirror = (np.abs(hit[..., 0] + 1.5) < 0.7) & (np.abs(hit[..., 1] - 1.0) < 0.7)
    assert on_mirror.sum() > 50
    assert image[on_mirror].mean() <= 0.01


def test_a_lamp_lit_rooms_shadowed_half_is_lit_by_bounces(renderer):
    # A lamp low in one half of the closed room, a partition two thirds high: the other
    # half's floor never sees the lamp. Without bounces it is black; each bounce brings
    # more of the light the lit walls and ceiling send on.
    lamp = dict(kind="POINT", position=(-2.0, 0.0, -2.0), color=(400.0, 400.0, 400.0), radius=0.1)
    scene = closed_room(lamp, partition=True)
    camera = Camera(matrix_world=look_at((2.0, -2.0, 0.5), (2.0, 0.0, -ROOM_HALF)), width=W, height=H)
    means = [luminance(mean_image(renderer, scene, camera, room_settings("FULL_BVH", diffuse_bounces=b),
                                  samples=4)).mean()
             for b in (0, 1, 2)]
    assert means[0] < 0.01 * means[1], means
    assert means[2] > 1.05 * means[1], means


SHADOWED_LAMP = dict(kind="POINT", position=(-2.0, 0.0, -2.0), color=(400.0, 400.0, 400.0), radius=0.1)
SHADOWED_CAMERA = dict(eye=(2.0, -2.0, 0.5), target=(2.0, 0.0, -ROOM_HALF))


def denoised_frames(renderer, scene, camera, settings, frames: int) -> list[float]:
    """The mean luminance of consecutive denoised frames of one view (a still viewport)."""
    return [float(luminance(renderer.render(scene, camera, settings, sample=i, denoise=True).image).mean())
            for i in range(frames)]


def test_bounces_build_up_over_frames_through_last_frames_light_with_bounce_feedback(renderer):
    # With Bounce Feedback, a path past its last bounce that ends on a surface the last frame
    # saw takes that surface's light (the denoiser's history): every frame adds the bounces
    # its paths trace to those the last one held, so the shadowed half brightens over frames
    # and settles; an undenoised frame (no history) stays at the first frame's light. The
    # first denoised frame holds that light (the filter keeps the energy, below), so the gain
    # is only what the surfaces the camera sees (the shadowed half, dim) give back. The light
    # without it is the mean of undenoised frames: the first denoised frame, one estimate of
    # it, traces more paths than the others (a short history's) and its own noise would move
    # the baseline. The first frame has no history to take light from, and a still view's
    # blend is the plain mean of its first 1 / ALPHA_COLOR frames: that frame's share of the
    # mean fades only over them, so the gain is read after they have passed.
    scene = closed_room(SHADOWED_LAMP, partition=True)
    camera = Camera(matrix_world=look_at(SHADOWED_CAMERA["eye"], SHADOWED_CAMERA["target"]), width=W, height=H)
    settings = room_settings("FULL_BVH", diffuse_bounces=1, bounce_feedback=True)
    unfed = float(np.mean([luminance(renderer.render(scene, camera, settings, sample=i).image).mean()
                           for i in range(16)]))
    frames = denoised_frames(renderer, scene, camera, settings, 18)
    assert np.mean(frames[14:]) > 1.05 * unfed, (unfed, frames)
    assert abs(frames[17] - frames[14]) < 0.03 * frames[17], frames  # settled: the albedo damps it


def test_diffuse_bounces_count_every_bounce_by_default_so_denoised_frames_keep_the_first_frames_light(renderer):
    # Without Bounce Feedback the paths carry Diffuse Bounces bounces and no more, as Cycles
    # counts them: a still view's denoised frames hold the undenoised frames' light from the
    # first on, where the feedback would brighten them frame by frame past Cycles' level (a
    # final render by its samples, the viewport's first frames darker than its later ones).
    scene = closed_room(SHADOWED_LAMP, partition=True)
    camera = Camera(matrix_world=look_at(SHADOWED_CAMERA["eye"], SHADOWED_CAMERA["target"]), width=W, height=H)
    settings = room_settings("FULL_BVH", diffuse_bounces=1)
    assert not settings.bounce_feedback
    plain = float(np.mean([luminance(renderer.render(scene, camera, settings, sample=i).image).mean()
                           for i in range(16)]))
    frames = denoised_frames(renderer, scene, camera, settings, 12)
    assert abs(np.mean(frames[6:]) - plain) < 0.03 * plain, (plain, frames)


def test_the_denoiser_keeps_the_bounced_lights_energy(renderer):
    # Bounced light is skewed: most paths of the shadowed half find dim walls, a few the
    # lamp-lit ones. An edge-stopping filter whose stops differ between a pixel and its
    # neighbour (each its own variance) lets a bright pixel's light out of its own mean while
    # its neighbours keep it out of theirs, and the image darkens; with the stop shared by
    # the two pixels and wide enough for one frame's spread, a denoised frame holds the light
    # of the undenoised one. Each frame starts the history over (an undenoised frame
    # between), the most filtered case, and has no fed-back light.
    scene = closed_room(SHADOWED_LAMP, partition=True)
    camera = Camera(matrix_world=look_at(SHADOWED_CAMERA["eye"], SHADOWED_CAMERA["target"]), width=W, height=H)
    settings = room_settings("HYBRID")
    ratios = []
    for k in range(6):
        plain = luminance(renderer.render(scene, camera, settings, sample=k).image).mean()
        denoised = luminance(renderer.render(scene, camera, settings, sample=k, denoise=True).image).mean()
        ratios.append(float(denoised / plain))
    assert np.mean(ratios) > 0.95, np.round(ratios, 3)


def test_a_lamp_switched_off_leaves_its_fed_back_light_dying_away(renderer):
    camera = Camera(matrix_world=look_at(SHADOWED_CAMERA["eye"], SHADOWED_CAMERA["target"]), width=W, height=H)
    settings = room_settings("FULL_BVH", diffuse_bounces=1, bounce_feedback=True)
    # Nothing feeds the fed-back light once the lamp is off: it dies away frame by frame (at
    # the pace of the denoiser's temporal blend, which carries the last frames' light too).
    lit = denoised_frames(renderer, closed_room(SHADOWED_LAMP, partition=True), camera, settings, 8)
    dark = denoised_frames(renderer, closed_room(None, partition=True), camera, settings, 10)
    assert all(b < a for a, b in zip(dark, dark[1:])), dark
    assert dark[-1] < 0.5 * lit[-1], (lit, dark)


# -- a grey wall beside a grey floor under a white World ---------------------------------------
@pytest.mark.parametrize("mode", ["HYBRID", "FULL_BVH"])
def test_a_rough_metal_reflects_the_sky_in_the_open_and_nothing_in_a_closed_room(renderer, mode):
    # A reflection too rough to trace (Sponza's curtains: metallic, roughness 1) has no
    # diffuse layer whose rays could tell what hides the sky from it. Its traced World light
    # is gathered along its own lobe: in the closed room it is black like the walls (with
    # the prefiltered sky it showed the whole sky, 0.8), and alone under the white World it
    # reflects the sky, its albedo times 1, as a GGX lobe under a uniform sky does. (HYBRID's
    # gather rays at grazing angles slip between the cube map's texels at a few pixels: the
    # closed room's walls show the same few hundredths there.)
    camera = Camera(matrix_world=look_at(ROOM_CAMERA["eye"], (-1.5, ROOM_HALF, 0.0)), width=W, height=H)
    origins, dirs = camera.pixel_rays()
    panel = on_panel(origins, dirs, ROOM_HALF - 0.01)
    assert panel.sum() > 300
    closed = luminance(mean_image(renderer, closed_room(rough_metal=True), camera, room_settings(mode), samples=2))
    assert closed[panel].mean() <= 0.03, closed[panel].mean()
    rows = [dict(base_color=(0.8, 0.8, 0.8), reflectivity=1.0, roughness=1.0)]
    alone = SceneData(Geometry.from_objects([(rough_metal_panel(ROOM_HALF - 0.01), None, 0)]),
                      MaterialTable.from_rows(rows), Lights.from_rows([]), Sky(color=(1.0, 1.0, 1.0)))
    open_air = luminance(mean_image(renderer, alone, camera, room_settings(mode), samples=2))
    assert open_air[panel].mean() == pytest.approx(0.8, rel=0.03)


@pytest.fixture
def tracer_override():
    yield
    variants.set_override(None)


@pytest.mark.parametrize("tracer", ["cpu", "gpu"])
def test_a_mirrors_reflection_of_a_rough_metal_in_a_closed_room_is_black(renderer, tracer_override, tracer):
    # The tracer's first-bounce hits on a rough metal gather along its lobe too (one ray
    # of unlimited reach, as the diffuse hits' gather): seen in the mirror on the floor, the
    # panel on the far wall is as black as the closed room around it. The megakernel and
    # the wave tracer alike.
    variants.set_override(f"trace={tracer}")
    camera = Camera(matrix_world=look_at((-1.5, 0.0, 0.0), (-1.5, 1.0, -ROOM_HALF)), width=W, height=H)
    image = luminance(mean_image(renderer, closed_room(rough_metal=True), camera,
                                 room_settings("HYBRID", ao_distance=0.0), samples=2))
    origins, dirs = camera.pixel_rays()
    t = (-ROOM_HALF + 0.01 - origins[..., 2]) / dirs[..., 2]
    hit = origins + dirs * t[..., None]
    on_mirror = (np.abs(hit[..., 0] + 1.5) < 0.7) & (np.abs(hit[..., 1] - 1.0) < 0.7)
    reflected = dirs * np.array([1.0, 1.0, -1.0])
    sees_panel = on_mirror & on_panel(hit, reflected, ROOM_HALF - 0.01)
    assert sees_panel.sum() > 30
    assert image[sees_panel].mean() <= 0.01, image[sees_panel].mean()


FURNACE_ALBEDO = 0.7


def furnace_room() -> SceneData:
    """The closed room, every surface emitting radiance 1 (no World, no lamps): a diffuse
    floor and rough-metal walls and ceiling, all of albedo FURNACE_ALBEDO."""
    walls = box((-ROOM_HALF,) * 3, (ROOM_HALF,) * 3)[:, ::-1].copy()  # corners reversed: normals inward
    floor_rows = np.abs(walls.mean(axis=1)[:, 2] + ROOM_HALF) < 1e-3
    rows = [dict(base_color=(FURNACE_ALBEDO,) * 3, emission=(1.0,) * 3),
            dict(base_color=(FURNACE_ALBEDO,) * 3, emission=(1.0,) * 3, reflectivity=1.0, roughness=1.0)]
    return SceneData(Geometry.from_objects([(walls[floor_rows], None, 0), (walls[~floor_rows], None, 1)]),
                     MaterialTable.from_rows(rows), Lights.from_rows([]), Sky(color=(0.0, 0.0, 0.0)))


@pytest.mark.parametrize("bounces", [1, 2])
def test_a_furnace_of_rough_metal_walls_passes_the_floors_paths_on_as_a_path_tracer_does(renderer, bounces):
    # A furnace: in a closed room where every surface emits 1 and reflects a share a of what
    # it receives, whatever its BRDF, a path of b bounces brings 1 + a + ... + a^(b+1) to
    # a diffuse floor pixel (emission, then one term per vertex). Paths that meet the rough
    # metal walls go on along their lobe; were they to end there, the floor would take
    # 1 + a whatever the bounces.
    camera = Camera(matrix_world=look_at((0.0, -1.0, 0.5), (0.0, 1.0, -ROOM_HALF)), width=W, height=H)
    origins, dirs = camera.pixel_rays()
    t = (-ROOM_HALF - origins[..., 2]) / dirs[..., 2]
    hit = origins + dirs * t[..., None]
    floor = (t > 0) & (np.abs(hit[..., :2]) < ROOM_HALF - 0.3).all(axis=-1)
    assert floor.sum() > 300
    settings = RenderSettings(mode="FULL_BVH", shadow_resolution=256, diffuse_bounces=bounces)
    image = luminance(mean_image(renderer, furnace_room(), camera, settings, samples=8))
    expected = sum(FURNACE_ALBEDO ** k for k in range(bounces + 2))
    assert image[floor].mean() == pytest.approx(expected, rel=0.03), (image[floor].mean(), expected)


ALBEDO = 0.6
WALL_BAND = (0.3, 1.3)  # the wall's heights the comparison averages over


def wall_and_floor(floor_material: dict | None = None) -> SceneData:
    """The floor z = 0 in front of (y < 0) the wall y = 0, which faces -y: wide enough to be
    the two half-planes of the reference below. ``floor_material``: the floor's own row
    (else the wall's)."""
    size = 200.0
    floor = quad((0.0, -size / 2, 0.0), (size, 0, 0), (0, size / 2, 0))
    wall = quad((0.0, 0.0, size / 2), (size, 0, 0), (0, 0, size / 2))  # facing -y
    rows = [dict(base_color=(ALBEDO,) * 3, specular=0.0, roughness=1.0)]
    if floor_material is not None:
        rows.append(floor_material)
    return SceneData(Geometry.from_objects([(floor, None, len(rows) - 1), (wall, None, 0)]),
                     MaterialTable.from_rows(rows), sky=Sky(color=(1.0, 1.0, 1.0)))


def reference_wall_radiance(bounces: int, paths: int = 400_000, seed: int = 36) -> float:
    """The wall's mean radiance over WALL_BAND, by Monte Carlo in numpy over the two
    half-planes (floor z = 0, y < 0; wall y = 0, z > 0), paths built as the kernel builds
    them: cosine directions, the sky's radiance 1 where one escapes, at most ``bounces``
    bounces, the albedo per bounce; Lambertian surfaces, so radiance = albedo times the mean
    of what the paths bring back."""
    rng = np.random.default_rng(seed)
    p = np.stack([rng.uniform(-1, 1, paths), np.zeros(paths), rng.uniform(*WALL_BAND, paths)], axis=1)
    n = np.tile([0.0, -1.0, 0.0], (paths, 1))
    radiance = np.zeros(paths)
    throughput = np.ones(paths)
    alive = np.ones(paths, bool)
    for vertex in range(1, bounces + 2):
        d = cosine_directions(n, rng)
        with np.errstate(divide="ignore", invalid="ignore"):
            t_floor = np.where(d[:, 2] < 0, -p[:, 2] / d[:, 2], np.inf)
            t_wall = np.where(d[:, 1] > 0, -p[:, 1] / d[:, 1], np.inf)
        t = np.minimum(t_floor, t_wall)
        escaped = alive & ~np.isfinite(t)
        radiance[escaped] += throughput[escaped]
        alive &= np.isfinite(t)
        if vertex > bounces:
            break
        throughput *= ALBEDO
        p = np.where(alive[:, None], p + d * np.where(np.isfinite(t), t, 0.0)[:, None], p)
        n = np.where((t_floor < t_wall)[:, None], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0])
        p[:, 2] = np.where(t_floor < t_wall, 0.0, p[:, 2])  # exactly on the plane it met
        p[:, 1] = np.where(t_floor < t_wall, p[:, 1], 0.0)
    return float(ALBEDO * radiance.mean())


def cosine_directions(n: np.ndarray, rng) -> np.ndarray:
    """Cosine-distributed unit directions about each unit normal of ``n`` (axis-aligned)."""
    u1, u2 = rng.random(len(n)), rng.random(len(n))
    r, phi = np.sqrt(u1), 2 * np.pi * u2
    local = np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(1 - u1)], axis=1)
    helper = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    t = np.cross(helper, n)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    b = np.cross(n, t)
    return local[:, :1] * t + local[:, 1:2] * b + local[:, 2:] * n


def test_the_reference_of_the_vertical_wall_sees_half_the_sky_without_bounces():
    # A vertical face's cosine-weighted upper hemisphere is half of it: radiance albedo / 2.
    assert reference_wall_radiance(0) == pytest.approx(ALBEDO / 2, rel=0.01)


@pytest.mark.parametrize("mode", ["HYBRID", "FULL_BVH"])
def test_a_wall_beside_a_floor_gains_the_floors_bounce_as_a_path_tracer_does(renderer, mode):
    # The wall's lower hemisphere sees the floor, not the sky: without bounces it takes half
    # the sky; each bounce adds the floor's light (and the wall's light on the floor), and
    # the radiance follows an independent Monte-Carlo estimate of the same two planes.
    scene = wall_and_floor()
    camera = Camera(matrix_world=look_at((0.0, -4.0, 0.8), (0.0, 0.0, 0.8)), width=W, height=H)
    origins, dirs = camera.pixel_rays()
    hit = origins + dirs * (-origins[..., 1:2] / dirs[..., 1:2])
    band = (hit[..., 2] > WALL_BAND[0]) & (hit[..., 2] < WALL_BAND[1]) & (np.abs(hit[..., 0]) < 1.0)
    assert band.sum() > 200
    measured = []
    for bounces in (0, 1, 2):
        settings = RenderSettings(mode=mode, near_size=5.0, shadow_resolution=256, diffuse_bounces=bounces)
        # 32 paths a pixel: a path sees the sky or the floor, so the band's mean of 8 a pixel
        # strayed by 2.5 % (one standard deviation), too near the 4 % allowed below.
        measured.append(float(mean_image(renderer, scene, camera, settings, samples=32)[band].mean()))
    assert measured[0] < measured[1] < measured[2], measured
    assert measured[1] > 1.1 * measured[0], measured
    for bounces, value in enumerate(measured):
        assert value == pytest.approx(reference_wall_radiance(bounces), rel=0.04), (bounces, measured)


def test_neighbouring_pixels_interleave_their_first_directions_so_a_few_pixels_average_to_the_light(renderer):
    # The wall beside the floor sees the sky over half its hemisphere at every height: one
    # path a pixel without bounces sees the sky or the dark floor. Interleaved over the
    # screen (diffuse_gather.comp.glsl lattice_random), the first directions of 3x3 pixels
    # sample the hemisphere evenly between them, so their mean is nearer the half than that
    # of as many pixels each shifted by numbers of its own (PIXEL_SHIFTS_INDEPENDENT, a
    # measurement switch), in one sample and in the mean of four; each pixel converges to
    # the same light either way.
    from hybrid_engine.frame.renderer import Renderer
    from hybrid_engine.gpu import shader_loader

    scene = wall_and_floor()
    camera = Camera(matrix_world=look_at((0.0, -4.0, 0.8), (0.0, 0.0, 0.8)), width=W, height=H)
    origins, dirs = camera.pixel_rays()
    hit = origins + dirs * (-origins[..., 1:2] / dirs[..., 1:2])
    band = (hit[..., 2] > WALL_BAND[0]) & (hit[..., 2] < WALL_BAND[1]) & (np.abs(hit[..., 0]) < 1.0)
    rows, cols = np.nonzero(band)
    r0, c0 = rows.min(), cols.min()
    blocks_down, blocks_across = (rows.max() + 1 - r0) // 3, (cols.max() + 1 - c0) // 3
    assert blocks_down * blocks_across >= 30
    settings = RenderSettings(mode="FULL_BVH", shadow_resolution=256, diffuse_bounces=0, diffuse_rays=1)

    def block_error(image: np.ndarray, truth: float) -> float:
        patch = luminance(image)[r0:r0 + 3 * blocks_down, c0:c0 + 3 * blocks_across]
        means = patch.reshape(blocks_down, 3, blocks_across, 3).mean(axis=(1, 3))
        return float(np.sqrt(np.mean((means / truth - 1.0) ** 2)))

    errors, means = {}, {}
    for independent in (False, True):
        with shader_loader.compiled_with({"PIXEL_SHIFTS_INDEPENDENT": 1} if independent else {}):
            variant = Renderer(renderer.ctx)
            try:
                frames = [variant.render(scene, camera, settings, sample=i, timing=False).image[..., :3]
                          for i in range(16)]
            finally:
                variant.release()
        truth = float(luminance(np.mean(frames, axis=0))[band].mean())
        errors[independent] = (block_error(frames[0], truth), block_error(np.mean(frames[:4], axis=0), truth))
        means[independent] = truth
    assert errors[False][0] < 0.7 * errors[True][0], errors
    assert errors[False][1] < 0.6 * errors[True][1], errors
    assert abs(means[False] / means[True] - 1.0) < 0.02, means


def tiled_island_floor(albedo: float, tiles: int = 24) -> tuple[SceneData, SceneData]:
    """The wall and floor of ``wall_and_floor`` (a 24 m wide strip of floor, the width the
    paths from the wall's band reach), the floor made of 1 m squares each mapped onto one
    UV island: the image's left half, of ``albedo``, the right half black, as a baked or
    painted texture leaves the space between its islands. Returns the scene with
    that texture and the same scene with the floor's albedo a plain value."""
    xs = np.arange(tiles) - tiles / 2.0 + 0.5
    squares = np.concatenate([quad((x, -y - 0.5, 0.0), (0.5, 0, 0), (0, 0.5, 0)) for x in xs for y in range(tiles // 2)])
    corners = squares.reshape(-1, 3, 3)
    local = corners[..., :2] - np.floor(corners[..., :2].mean(axis=1, keepdims=True))  # each square's own [0, 1]^2
    uvs = (0.05 + 0.4 * local).astype(np.float32)  # inside the island u < 0.5, clear of its edge
    wall = quad((0.0, 0.0, 6.0), (tiles / 2.0, 0, 0), (0, 0, 6.0))  # facing -y
    image = np.zeros((16, 16, 4), np.float32)
    image[..., 3] = 1.0
    image[:, :8, :3] = 1.0  # the texture's factor: the row's base colour times it
    floor_row = dict(base_color=(albedo,) * 3, specular=0.0, roughness=1.0)
    rows = [dict(base_color=(ALBEDO,) * 3, specular=0.0, roughness=1.0), floor_row,
            {**floor_row, "base_color_texture": 0}]
    scenes = []
    for floor_material in (2, 1):
        geo = Geometry.from_objects([(corners, None, floor_material), (wall, None, 0)])
        geo = Geometry(geo.triangles, geo.normals, geo.material_ids, geo.object_ranges, geo.object_bounds,
                       geo.object_names, uvs=np.concatenate([uvs, np.zeros((len(wall), 3, 2), np.float32)]))
        scenes.append(SceneData(geo, MaterialTable.from_rows(rows, textures=[image]), sky=Sky(color=(1.0, 1.0, 1.0))))
    return scenes[0], scenes[1]


@pytest.mark.parametrize("mode", ["HYBRID", "FULL_BVH"])
def test_light_bounced_off_a_texture_takes_its_islands_colour_not_the_empty_space_around_them(renderer, mode):
    """A path's bounce off a textured floor reads the texture where the path meets it, not
    averaged over its whole cosine lobe: the lobe's cone read levels so coarse that they
    blended the black between the UV islands into the bounced light (Cycles filters no
    texture). The wall above the floor takes the same light whether the floor's albedo is
    the island's texture or the same plain value."""
    textured, plain = tiled_island_floor(albedo=0.8)
    camera = Camera(matrix_world=look_at((0.0, -4.0, 0.8), (0.0, 0.0, 0.8)), width=W, height=H)
    origins, dirs = camera.pixel_rays()
    hit = origins + dirs * (-origins[..., 1:2] / dirs[..., 1:2])
    band = (hit[..., 2] > 0.1) & (hit[..., 2] < 0.6) & (np.abs(hit[..., 0]) < 1.0)
    assert band.sum() > 100
    settings = RenderSettings(mode=mode, near_size=5.0, shadow_resolution=256, diffuse_bounces=1)
    with_texture = float(mean_image(renderer, textured, camera, settings, samples=16)[band].mean())
    with_value = float(mean_image(renderer, plain, camera, settings, samples=16)[band].mean())
    assert with_texture == pytest.approx(with_value, rel=0.03), (with_texture, with_value)


# -- emissive meshes as lights ---------------------------------------------------------------------
@pytest.mark.parametrize("mode", ["HYBRID", "FULL_BVH"])
def test_a_wall_beside_a_mirror_floor_sees_the_sky_in_it(renderer, mode):
    # The wall's lower hemisphere sees the mirror floor, and in it the sky's mirror image
    # (the wall cannot see itself there: rays going down and away from it keep going away):
    # with a bounce its radiance is the albedo times the whole white sky, not half of it.
    # A path that met the mirror went on along its lobe; had it ended there, the mirror
    # would add nothing.
    scene = wall_and_floor(floor_material=dict(base_color=(1.0, 1.0, 1.0), reflectivity=1.0, roughness=0.0))
    camera = Camera(matrix_world=look_at((0.0, -4.0, 0.8), (0.0, 0.0, 0.8)), width=W, height=H)
    origins, dirs = camera.pixel_rays()
    hit = origins + dirs * (-origins[..., 1:2] / dirs[..., 1:2])
    band = (hit[..., 2] > WALL_BAND[0]) & (hit[..., 2] < WALL_BAND[1]) & (np.abs(hit[..., 0]) < 1.0)
    measured = [float(luminance(mean_image(renderer, scene, camera,
                                           RenderSettings(mode=mode, near_size=5.0, shadow_resolution=256,
                                                          diffuse_bounces=bounces), samples=8))[band].mean())
                for bounces in (0, 1)]
    assert measured[0] == pytest.approx(ALBEDO / 2, rel=0.04), measured
    assert measured[1] == pytest.approx(ALBEDO, rel=0.04), measured


PANEL_HEIGHT = 1.0
PANEL_HALF = 0.25
PANEL_RADIANCE = 8.0
FLOOR_ALBEDO = 0.5


def panel_over_floor() -> SceneData:
    """A small emissive square facing down over a wide grey floor, a black World, no lamps:
    the floor is lit by the panel alone."""
    floor = quad((0.0, 0.0, 0.0), (6.0, 0, 0), (0, 6.0, 0))
    panel = quad((0.0, 0.0, PANEL_HEIGHT), (PANEL_HALF, 0, 0), (0, -PANEL_HALF, 0))
    # The floor is matte without a specular coat: its light is the diffuse gather alone.
    rows = [dict(base_color=(FLOOR_ALBEDO,) * 3, specular=0.0, roughness=1.0),
            dict(base_color=(0.0,) * 3, specular=0.0, emission=(PANEL_RADIANCE,) * 3)]
    return SceneData(Geometry.from_objects([(floor, None, 0), (panel, None, 1)]), MaterialTable.from_rows(rows),
                     Lights.from_rows([]), Sky(color=(0.0, 0.0, 0.0)))


def panel_irradiance(points: np.ndarray) -> np.ndarray:
    """Lambert's closed form for the panel's irradiance on the floor (normal +z) at points."""
    corners = np.array([[-PANEL_HALF, -PANEL_HALF], [PANEL_HALF, -PANEL_HALF], [PANEL_HALF, PANEL_HALF],
                        [-PANEL_HALF, PANEL_HALF]])
    out = []
    for p in points:
        v = np.column_stack([corners - p[:2], np.full(4, PANEL_HEIGHT - p[2])])
        v /= np.linalg.norm(v, axis=1, keepdims=True)
        total = 0.0
        for a, b in zip(v, np.roll(v, -1, axis=0)):
            c = np.cross(a, b)
            total += np.arctan2(np.linalg.norm(c), a @ b) * c[2] / np.linalg.norm(c)
        out.append(PANEL_RADIANCE * 0.5 * abs(total))
    return np.array(out)


@pytest.mark.parametrize("mode", ["HYBRID", "FULL_BVH"])
def test_an_emissive_panel_lights_the_floor_and_falls_off_as_lamberts_closed_form(renderer, mode):
    # Cycles' light from an emissive quad is this closed form: radiance times the projected
    # solid angle. The next-event estimate towards the panel makes a handful of samples enough.
    scene = panel_over_floor()
    camera = Camera(matrix_world=look_at((0.0, -3.0, 0.8), (0.0, 0.0, 0.0)), width=W, height=H)
    settings = RenderSettings(mode=mode, near_size=2.0, diffuse_bounces=0)
    image = luminance(mean_image(renderer, scene, camera, settings, samples=8))
    origins, dirs = camera.pixel_rays()
    t = -origins[..., 2] / np.minimum(dirs[..., 2], -1e-9)
    points = origins + t[..., None] * dirs
    radius = np.hypot(points[..., 0], points[..., 1])
    for lo, hi in [(0.0, 0.4), (0.8, 1.2), (1.6, 2.2)]:  # under the panel, and farther out
        ring = (dirs[..., 2] < 0) & (radius >= lo) & (radius < hi) & (np.abs(points[..., 0]) < 2.0)
        assert ring.sum() > 10
        expected = FLOOR_ALBEDO / np.pi * panel_irradiance(points[ring]).mean()
        assert image[ring].mean() == pytest.approx(expected, rel=0.1), (lo, hi)


def test_mirrors_and_glass_render_alike_whatever_the_diffuse_light(renderer):
    # The paper's traced paths (mirror and glass) are not the diffuse light's: a scene of
    # mirrors and glass alone, under a sky, is the same image with traced diffuse light at 0
    # bounces, at 2, and with the screen-space estimate.
    from scenes_analytic import uv_sphere

    mirror, mirror_normals = uv_sphere((-0.6, 0.0, 0.0), 0.5, 24, 12)
    glass, glass_normals = uv_sphere((0.6, 0.0, 0.0), 0.5, 24, 12)
    rows = [dict(base_color=(0.95, 0.9, 0.8), reflectivity=1.0, roughness=0.0),
            dict(base_color=(1.0, 1.0, 1.0), transmission=1.0, ior=1.5, roughness=0.0)]
    scene = SceneData(Geometry.from_objects([(mirror, mirror_normals, 0), (glass, glass_normals, 1)]),
                      MaterialTable.from_rows(rows), Lights.from_rows([]), Sky(color=(0.4, 0.6, 1.0)))
    camera = Camera(matrix_world=look_at((0.0, -3.0, 0.6), (0.0, 0.0, 0.0)), width=W, height=H)
    images = [renderer.render(scene, camera, RenderSettings(mode="HYBRID", near_size=2.0, **kw)).image
              for kw in (dict(diffuse_bounces=0), dict(diffuse_bounces=2), dict(world_light="SCREEN"))]
    sky = renderer.render(SceneData(Geometry.from_objects([]), MaterialTable.from_rows(rows), Lights.from_rows([]),
                                    Sky(color=(0.4, 0.6, 1.0))), camera, RenderSettings(mode="HYBRID")).image
    assert (np.abs(images[0] - sky).max(axis=-1) > 0.05).mean() > 0.1  # the spheres fill part of the view
    assert np.abs(images[0] - images[1]).max() == 0.0
    assert np.abs(images[0] - images[2]).max() < 1e-6


# -- the numbers the paths draw ---------------------------------------------------------------
def temporal_blend(renderer, scene, camera, settings, samples) -> np.ndarray:
    """The denoiser's temporal blend of the irradiance after one frame per entry of
    ``samples`` (the view's sample number of each redraw), from a fresh history."""
    renderer.render(scene, camera, settings, sample=0)  # a frame without the denoiser: it starts over
    for sample in samples:
        renderer.render(scene, camera, settings, sample=sample, reuse_world=True, denoise=True)
    return renderer.denoiser.history.read("color")[..., :3]


def test_redraws_that_restart_the_views_samples_still_blend_fresh_paths(renderer):
    # The viewport restarts its samples at 0 on every redraw where something moved (the
    # camera, or an object elsewhere while this view stays still). The denoiser's history
    # still gathers those frames: each must draw new paths, or the blend averages one
    # frame's noise with itself. Twelve redraws at sample 0 are as clean as twelve at
    # samples 0..11 (against a long blend), and much cleaner than one frame.
    scene = closed_room(SHADOWED_LAMP, partition=True)
    camera = Camera(matrix_world=look_at(SHADOWED_CAMERA["eye"], SHADOWED_CAMERA["target"]), width=W, height=H)
    settings = room_settings("FULL_BVH", diffuse_bounces=1)
    truth = temporal_blend(renderer, scene, camera, settings, range(100, 164))
    error = lambda blend: float(np.sqrt(np.mean((blend - truth) ** 2)))  # noqa: E731
    counted = error(temporal_blend(renderer, scene, camera, settings, range(12)))
    restarted = error(temporal_blend(renderer, scene, camera, settings, [0] * 12))
    single = error(temporal_blend(renderer, scene, camera, settings, [0]))
    assert restarted < 1.25 * counted and restarted < 0.6 * single, (restarted, counted, single)


def first_paths(renderer, scene, camera, settings, sample: int) -> int:
    """The diffuse paths one denoised frame started (its first rays, the gather's counters)."""
    result = renderer.render(scene, camera, settings, sample=sample, reuse_world=sample > 0, denoise=True)
    return int(dict(result.counts)["gather_rays_traced_bounce_1"])


def shadowed_camera(shift: float = 0.0) -> Camera:
    eye, target = (np.array(SHADOWED_CAMERA[k]) + (shift, 0.0, 0.0) for k in ("eye", "target"))
    return Camera(matrix_world=look_at(eye, target), width=W, height=H)


def test_a_denoised_view_traces_more_paths_until_its_history_holds_a_few_frames(renderer):
    # Every pixel sees a wall of the closed room. The denoiser's first frame has no history:
    # SHORT_HISTORY_PATHS times Diffuse Rays paths everywhere, then ceil(that / (frames + 1))
    # as each pixel's history grows, down to Diffuse Rays. (The radiance cache's short paths
    # come on top: tests/test_radiance_cache.py.)
    from hybrid_engine.passes.diffuse_light.diffuse_light import SHORT_HISTORY_PATHS

    scene, camera = closed_room(SHADOWED_LAMP, partition=True), shadowed_camera()
    settings = room_settings("HYBRID", diffuse_rays=2, radiance_cache=False)
    renderer.render(scene, camera, settings)  # an undenoised frame: the history starts over
    counts = [first_paths(renderer, scene, camera, settings, i) for i in range(6)]
    most = SHORT_HISTORY_PATHS
    assert most > 1
    assert counts == [W * H * 2 * max(1, -(-most // (n + 1))) for n in range(6)], counts


@pytest.mark.parametrize("rays,cap", [(4, 4), (8, 2), (16, 1)])
def test_no_frame_traces_more_paths_per_pixel_than_the_most_diffuse_rays(renderer, rays, cap):
    # Diffuse Rays' highest setting (16) bounds the paths of a short history too: `cap`
    # times the rays at most.
    from hybrid_engine.passes.diffuse_light.diffuse_light import SHORT_HISTORY_PATHS

    most = min(SHORT_HISTORY_PATHS, cap)
    scene, camera = closed_room(SHADOWED_LAMP, partition=True), shadowed_camera()
    settings = room_settings("HYBRID", diffuse_rays=rays, diffuse_bounces=1)
    renderer.render(scene, camera, settings)  # an undenoised frame: the history starts over
    assert first_paths(renderer, scene, camera, settings, 0) == W * H * rays * most


def test_a_moving_camera_traces_more_paths_only_where_it_uncovers_surfaces(renderer):
    # A camera that moves keeps the history of what it still sees (the denoiser's
    # reprojection): only the columns that enter the view, and what the partition uncovers,
    # start over and trace more paths. Starting the history over traces them everywhere.
    from hybrid_engine.passes.diffuse_light.diffuse_light import SHORT_HISTORY_PATHS

    scene, settings = closed_room(SHADOWED_LAMP, partition=True), room_settings("HYBRID", radiance_cache=False)
    renderer.render(scene, shadowed_camera(), settings)
    for i in range(SHORT_HISTORY_PATHS + 1):
        first_paths(renderer, scene, shadowed_camera(), settings, i)
    moved = first_paths(renderer, scene, shadowed_camera(0.1), settings, 0)
    uncovered = (moved - W * H) / (SHORT_HISTORY_PATHS - 1)  # pixels that started over
    assert 0 < uncovered < 0.15 * W * H, (moved, uncovered)
    renderer.render(scene, shadowed_camera(0.1), settings)  # an undenoised frame: the history starts over
    assert first_paths(renderer, scene, shadowed_camera(0.1), settings, 0) == SHORT_HISTORY_PATHS * W * H


def test_the_first_denoised_frames_are_cleaner_with_more_paths_where_the_history_is_short(renderer, monkeypatch):
    # Against a long blend of the view, the temporal blend after one, two and four frames
    # from a fresh history: more paths while the history is short is closer, frame by frame.
    import hybrid_engine.passes.diffuse_light.diffuse_light as diffuse_light

    scene, camera = closed_room(SHADOWED_LAMP, partition=True), shadowed_camera()
    settings = room_settings("FULL_BVH", diffuse_bounces=1)
    truth = temporal_blend(renderer, scene, camera, settings, range(100, 164))
    error = lambda blend: float(np.sqrt(np.mean((blend - truth) ** 2)))  # noqa: E731
    errors = {}
    for most in (1, diffuse_light.SHORT_HISTORY_PATHS):
        monkeypatch.setattr(diffuse_light, "SHORT_HISTORY_PATHS", most)
        errors[most] = [error(temporal_blend(renderer, scene, camera, settings, range(n))) for n in (1, 2, 4)]
    boosted, plain = errors[diffuse_light.SHORT_HISTORY_PATHS], errors[1]
    # The extra paths fall with the history's length, and so does their gain: twice the paths
    # first, about 1 / sqrt(2) of the error.
    assert diffuse_light.SHORT_HISTORY_PATHS == 2
    assert all(b < bound * p for b, p, bound in zip(boosted, plain, (0.8, 0.95, 0.99))), errors


def test_a_still_views_mean_of_eight_samples_beats_independent_paths(renderer):
    # A wall beside a floor, lit by the sky alone: a first ray sees the sky or the floor.
    # With independent numbers the error of a pixel's mean falls as one over the square root
    # of the count (8 samples: 0.35 of one's); the first directions of consecutive samples
    # follow one low-discrepancy sequence per point, which covers the hemisphere evenly and
    # falls faster.
    scene = wall_and_floor()
    camera = Camera(matrix_world=look_at((0.0, -4.0, 0.8), (0.0, 0.0, 0.8)), width=32, height=24)
    settings = RenderSettings(mode="FULL_BVH", near_size=5.0, shadow_resolution=256, diffuse_bounces=0)
    frames = [renderer.render(scene, camera, settings, sample=i).image[..., :3] for i in range(128)]
    truth = np.mean(frames, axis=0)
    error = lambda image: float(np.sqrt(np.mean((image - truth) ** 2)))  # noqa: E731
    one = np.mean([error(frames[i]) for i in range(0, 64, 8)])
    eight = np.mean([error(np.mean(frames[i:i + 8], axis=0)) for i in range(0, 64, 8)])
    assert eight < 0.25 * one, (eight / one, eight, one)


def half_partitioned_room() -> SceneData:
    """benchmarks/light_noise.py's room: closed, grey, a partition over half its depth and
    two thirds of its height, a point lamp behind it, a black World."""
    walls = box((-ROOM_HALF,) * 3, (ROOM_HALF,) * 3)[:, ::-1].copy()
    partition = quad((0.0, ROOM_HALF / 2, -1.0), (0, ROOM_HALF / 2, 0), (0, 0, 2.0))
    lamp = dict(kind="POINT", position=(1.5, 1.5, 0.0), color=(200.0, 200.0, 200.0), radius=0.1)
    return SceneData(Geometry.from_objects([(walls, None, GREY), (partition, None, GREY)]),
                     MaterialTable.from_rows([dict(base_color=(0.8, 0.8, 0.8), specular=0.0, roughness=1.0)]),
                     Lights.from_rows([lamp]), Sky(color=(0.0, 0.0, 0.0)))


def test_hybrids_bounced_light_behind_a_partition_matches_full_bvh(renderer):
    # The lamp lights the walls behind the partition, which the cube map's centre cannot
    # see. Paths that pass over the partition's edge into that space met the stretch of its
    # camera-facing, shadowed side, and paths from there met it again from behind
    # (cube_march.glsl "Hidden sides"); taking the wall where they leave the room, and the
    # partition's plane where the map holds it, brings HYBRID's bounced light to FULL_BVH's.
    scene = half_partitioned_room()
    eye = np.array([-2.0, -2.5, 0.5])
    camera = Camera(matrix_world=look_at(eye, eye + np.array([1.0, 3.0, -0.6])), width=W, height=H)
    hybrid, full = (luminance(mean_image(renderer, scene, camera, room_settings(mode, diffuse_bounces=4),
                                         samples=8)).mean() for mode in ("HYBRID", "FULL_BVH"))
    assert abs(hybrid / full - 1.0) < 0.05, (hybrid, full, hybrid / full)


def floor_with_low_walls() -> SceneData:
    """A floor under a white World with two low walls (0.24 high, 0.25 thick, as Chess's board
    frames) running away from the camera on either side of it."""
    floor = quad((0.0, 10.0, 0.0), (20.0, 0, 0), (0, 20.0, 0))
    walls = np.concatenate([box((x, 0.0, 0.0), (x + 0.25, 14.0, 0.24)) for x in LOW_WALLS_X])
    rows = [dict(base_color=(0.5, 0.5, 0.5), thickness=0.0), dict(base_color=(0.5, 0.5, 0.5), thickness=0.002)]
    return SceneData(Geometry.from_objects([(floor, None, 0), (walls, None, 1)]), MaterialTable.from_rows(rows),
                     Lights.from_rows([]), Sky(color=(1.0, 1.0, 1.0)))


LOW_WALLS_X = (-1.5, 1.25)  # the walls' sides at lowest x; the camera-facing sides at |x| = 1.25


def test_hybrids_paths_from_the_floor_meet_a_low_wall_seen_edge_on_as_full_bvhs_do(renderer):
    # Seen from the cube map's centre the walls recede nearly edge-on, a texel or so wide,
    # and their depth changes across a texel by more than the depth bias: a path from the
    # floor beside them that crosses a wall away from its texel's centre passed in front of
    # the stored depth in every texel and saw the sky (sky share 0.98 where FULL_BVH's is
    # 0.78). Following each texel's plane (cube_march.glsl "Surface footprints") finds the
    # wall there.
    from hybrid_engine.frame.film import FrameOutputs
    from hybrid_engine.passes.film.light_passes import LightPassRequest
    from scenes_analytic import ray_box, ray_plane_z

    scene = floor_with_low_walls()
    eye = np.array([0.0, -1.0, 2.0])
    camera = Camera(matrix_world=look_at(eye, (0.0, 6.0, 0.0)), width=64, height=48)
    outputs = FrameOutputs(light=LightPassRequest(flags=("use_pass_ambient_occlusion",)))
    sky = {}
    for mode in ("HYBRID", "FULL_BVH"):
        settings = RenderSettings(mode=mode, near_size=1.0, cube_resolution=64, cube_back_layer=True,
                                  diffuse_bounces=0, max_depth=0, diffuse_rays=4)
        sky[mode] = np.mean([renderer.render(scene, camera, settings, sample=k, outputs=outputs, timing=False)
                             .data_passes["Ambient Occlusion"][..., 0] for k in range(4)], axis=0)
    # The floor's pixels within 0.4 of a wall's camera-facing side, beyond the near cube.
    origins, dirs = camera.pixel_rays()
    t_floor = ray_plane_z(origins, dirs, 0.0)
    t_walls = np.minimum(*[ray_box(origins, dirs, (x, 0.0, 0.0), (x + 0.25, 14.0, 0.24)) for x in LOW_WALLS_X])
    p = origins + dirs * np.where(np.isfinite(t_floor), t_floor, 0.0)[..., None]
    beside = (np.isfinite(t_floor) & (t_floor < t_walls) & (np.abs(p - eye).max(axis=-1) > 1.1)
              & (np.abs(p[..., 0]) > 0.85) & (np.abs(p[..., 0]) < 1.25) & (p[..., 1] > 0.5) & (p[..., 1] < 13.0))
    assert beside.sum() > 200
    hybrid, full = sky["HYBRID"][beside].mean(), sky["FULL_BVH"][beside].mean()
    assert full < 0.9, full  # the walls hide a good part of these points' sky
    assert abs(hybrid - full) < 0.05, (hybrid, full)


@pytest.fixture
def gather_override():
    yield
    variants.set_override(None)


def frames_of(renderer, scene, camera, settings, frames: int) -> list:
    """Consecutive denoised frames of one view: the first without history (every pixel its
    short history's paths), then with last frame's light fed back."""
    return [renderer.render(scene, camera, settings, sample=i, denoise=True) for i in range(frames)]


@pytest.mark.parametrize("mode", ["HYBRID", "FULL_BVH"])
@pytest.mark.parametrize("lit_by", ["lamp", "panel"])
def test_the_persistent_gather_kernel_traces_each_pixels_paths_as_the_per_pixel_kernel_does(
        renderer, gather_override, mode, lit_by):
    from hybrid_engine.frame.renderer import Renderer

    # The GPU's shape of the gather (persistent invocations taking pixels from a counter,
    # diffuse_gather.comp.glsl PERSISTENT_PATHS) keys every number by the pixel's surface, so
    # it must give the per-pixel shape's image exactly: several paths per pixel (Diffuse Rays
    # 2, twice that without history), pixels without paths (the background, the mirror),
    # glass-free rooms lit by a lamp and bounces, an emitter's next-event estimate, the fed-back
    # light past the last bounce, and the radiance cache's short paths (from the third frame,
    # the second having filled the cells).
    if lit_by == "lamp":
        scene = closed_room(SHADOWED_LAMP, partition=True, rough_metal=True)
        camera = Camera(matrix_world=look_at(SHADOWED_CAMERA["eye"], SHADOWED_CAMERA["target"]), width=W, height=H)
    else:
        scene = panel_over_floor()
        camera = Camera(matrix_world=look_at((0.0, -4.0, 1.5), (0.0, 0.0, 0.3)), width=W, height=H)
    settings = room_settings(mode, diffuse_rays=2, diffuse_bounces=3, bounce_feedback=True)
    results = {}
    for shape in ("cpu", "gpu"):
        variants.set_override(f"gather={shape}")
        fresh = Renderer(renderer.ctx)  # each shape's own history from its first frame
        try:
            results[shape] = frames_of(fresh, scene, camera, settings, 4)
        finally:
            fresh.release()
    for per_pixel, persistent in zip(results["cpu"], results["gpu"]):
        assert per_pixel.counts["gather_rays_traced"] == persistent.counts["gather_rays_traced"]
        np.testing.assert_allclose(persistent.image, per_pixel.image, rtol=0, atol=1e-5)
    assert luminance(results["gpu"][-1].image).mean() > 0.01


@pytest.mark.parametrize("deform", [False, True])
def test_a_moved_objects_pixels_trace_more_paths_exactly_where_the_denoiser_starts_them_over(gl, monkeypatch, deform):
    # A pillar in the bounce-lit room jumps past its own width under a still camera, moved by
    # its matrix or by deforming its mesh (its rows of last frame kept). The
    # denoiser finds its pixels' history where the pillar stood (passes/surface_motion/), and
    # the gather's count of paths follows the same lookup: only the pixels the denoiser
    # starts over (what the pillar uncovered, what of it was out of view) trace more paths.
    # Without the move followed, every pixel of the pillar starts over in both.
    from benchmarks.light_noise import _viewport_settings, camera_at
    from benchmarks.moving_object_noise import BOX_MATERIAL, SlidingPillar
    from hybrid_engine.frame.renderer import Renderer
    from hybrid_engine.passes.diffuse_light.diffuse_light import SHORT_HISTORY_PATHS
    from hybrid_engine.passes.surface_motion import surface_motion

    # The radiance cache's short paths come on top (tests/test_radiance_cache.py); a moving
    # object's frames take none, but the still frames before it would.
    camera, settings = camera_at(0.0, W, H), replace(_viewport_settings(), radiance_cache=False)
    started_over = {}
    for follow in (True, False):
        monkeypatch.setattr(surface_motion, "FOLLOW_MOVES", follow)
        renderer = Renderer(gl)
        sliding = SlidingPillar(slide=0.8, deform=deform)
        try:
            for i in range(SHORT_HISTORY_PATHS + 2):
                assert first_paths(renderer, sliding.scene(0), camera, settings, i) == W * H or i < SHORT_HISTORY_PATHS
            moved = first_paths(renderer, sliding.scene(1), camera, settings, 0)
            lengths = renderer.denoiser.history.read("length")
        finally:
            renderer.release()
        pillar = int((lengths[..., 1] == BOX_MATERIAL + 1).sum())
        denoiser_over = int((lengths[..., 0] == 1).sum())
        started_over[follow] = (moved - W * H) / (SHORT_HISTORY_PATHS - 1)
        assert abs(started_over[follow] - denoiser_over) <= 3, (follow, started_over[follow], denoiser_over)
    assert pillar > 60
    assert started_over[False] - started_over[True] > 0.4 * pillar, (started_over, pillar)
