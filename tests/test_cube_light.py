# SPDX-License-Identifier: GPL-3.0-or-later
"""The lit cube map (passes/cube_light/): the cube map's texels shaded once per frame, the
light bounced between them fed back from frame to frame, and the mip chain that rough
reflections of the map read."""
from __future__ import annotations

import numpy as np
import pytest

from conftest import save_failure_images
from hybrid_engine import Camera, Geometry, Lights, MaterialTable, RenderSettings, SceneData, Sky
from hybrid_engine.frame.renderer import Renderer, frame_steps
from hybrid_engine.gpu import variants
from hybrid_engine.passes.cube_light.cube_light import FADE_FRAMES
from hybrid_engine.scene.camera import look_at
from hybrid_engine.scene.shader_graph import Link, ShaderGraph
from scenes_analytic import box, quad
from whitted_reference import flip_mean

W, H = 64, 48
BASE = dict(cube_resolution=128, shadow_resolution=256, cube_far=200.0, ao_distance=0.0, near_size=1.0, lit_cube=True)


@pytest.fixture(scope="module")
def renderer(gl):
    r = Renderer(gl)
    yield r
    r.release()


@pytest.fixture
def both_tracers():
    yield
    variants.set_override(None)


def camera_at(eye, target, lens=30.0, up=(0, 0, 1)):
    return Camera(matrix_world=look_at(eye, target, up), width=W, height=H, lens=lens,
                  clip_start=0.05, clip_end=500.0)


def render(renderer, scene, camera, **kw):
    result = renderer.render(scene, camera, RenderSettings(**{**BASE, **kw}))
    assert np.isfinite(result.image).all()
    return result


def checker_wall(y: float, squares: int, size: float, first: int, second: int) -> list:
    """A wall at y facing -y made of squares x squares quads of two materials alternating."""
    objects = []
    step = size / squares
    for i in range(squares):
        for j in range(squares):
            centre = (-size / 2 + (i + 0.5) * step, y, -size / 2 + (j + 0.5) * step)
            objects.append((quad(centre, (0, 0, step / 2), (step / 2, 0, 0)), None, first if (i + j) % 2 else second))
    return objects


# -- rough reflections read a coarser level ----------------------------------------------------
MIRROR, WHITE, BLACK = range(3)


def mirror_scene(roughness: float) -> SceneData:
    """A mirror in front of the camera (inside the near cube: a primary surface), and behind
    the camera, beyond the near cube, a black and white checker wall lit by a sun: the mirror
    shows the wall through the cube map."""
    mats = MaterialTable.from_rows([
        dict(name="mirror", base_color=(0.9, 0.9, 0.9), reflectivity=1.0, roughness=roughness),
        dict(name="white", base_color=(0.8, 0.8, 0.8)),
        dict(name="black", base_color=(0.02, 0.02, 0.02)),
    ])
    objects = [(quad((0, 0.8, 0), (0, 0, 1.0), (1.0, 0, 0)), None, MIRROR)]
    objects += checker_wall(-6.0, 32, 24.0, WHITE, BLACK)
    lights = [dict(kind="SUN", direction=(0.0, -1.0, -0.3), color=(3.0, 3.0, 3.0), cast_shadow=False)]
    return SceneData(Geometry.from_objects(objects), mats, Lights.from_rows(lights), Sky(color=(0.3, 0.3, 0.3)))


def fine_contrast(image: np.ndarray) -> float:
    """Mean luminance difference of neighbouring pixels in the image's centre (the mirror)."""
    lum = image[H // 4:3 * H // 4, W // 4:3 * W // 4, :3].mean(axis=2)
    return float(np.mean(np.abs(np.diff(lum, axis=1))) + np.mean(np.abs(np.diff(lum, axis=0))))


@pytest.mark.parametrize("tracer", ["cpu", "gpu"])
def test_a_rough_mirror_reads_the_checker_wall_from_a_coarser_level(renderer, both_tracers, tracer):
    """A sharp mirror shows the wall's checker; at roughness 0.45 (still traced, one GGX
    direction per sample) the cube-map hits read the level the lobe spans, so one sample
    already shows the checker blurred to grey instead of a per-pixel scatter of black and
    white. The wave and the megakernel tracers alike."""
    variants.set_override(f"trace={tracer}")
    camera = camera_at((0, 0, 0), (0, 1, 0))
    sharp = render(renderer, mirror_scene(0.0), camera).image
    rough = render(renderer, mirror_scene(0.45), camera).image
    c_sharp, c_rough = fine_contrast(sharp), fine_contrast(rough)
    lum = rough[H // 4:3 * H // 4, W // 4:3 * W // 4, :3].mean(axis=2)
    if not c_rough < 0.35 * c_sharp:
        save_failure_images(f"cube_light_rough_{tracer}", sharp=sharp, rough=rough)
    assert c_sharp > 0.05, "the sharp mirror shows the checker"
    assert c_rough < 0.35 * c_sharp, (c_sharp, c_rough)
    # Blurred, not lost: the rough mirror shows the wall's mean, neither black nor white.
    assert 0.2 * lum.max() < np.median(lum)


# -- the stored light is the per-ray light -----------------------------------------------------
def shadowed_floor_scene() -> SceneData:
    """A mirror tilted to show a floor beyond the near cube on which a black block casts a
    sun's shadow; the sky is black and the block reflects nothing, so no light bounces: the
    stored light is the lamps' and nothing else."""
    mats = MaterialTable.from_rows([
        dict(name="mirror", base_color=(0.9, 0.9, 0.9), reflectivity=1.0, roughness=0.0),
        dict(name="floor", base_color=(0.7, 0.6, 0.5)),
        dict(name="block", base_color=(0.0, 0.0, 0.0), specular=0.0),
    ])
    objects = [(quad((0, 1.0, 0), (1.0, 0, 0), (0, -0.04, 0.8)), None, 0),
               (quad((0, 0, -2.0), (20, 0, 0), (0, 20, 0)), None, 1),
               (box((-1.0, -6.0, -2.0), (1.0, -5.0, 0.0)), None, 2)]
    lights = [dict(kind="SUN", direction=(0.3, -0.5, -1.0), color=(3.0, 3.0, 3.0))]
    return SceneData(Geometry.from_objects(objects), mats, Lights.from_rows(lights), Sky(color=(0.0, 0.0, 0.0)))


@pytest.mark.parametrize("tracer", ["cpu", "gpu"])
def test_cube_hits_read_the_light_they_would_be_shaded_with(renderer, both_tracers, tracer):
    """Where nothing bounces, a mirror's reflection of the cube map looks the same whether its
    hits are shaded per ray or read from the lit cube map: its light (lamp, shadow, albedo)
    is stored right."""
    variants.set_override(f"trace={tracer}")
    scene, camera = shadowed_floor_scene(), camera_at((0, 0, 0), (0, 1, -0.2))
    per_ray = render(renderer, scene, camera, lit_cube=False, cube_resolution=256).image
    stored = render(renderer, scene, camera, lit_cube=True, cube_resolution=256)
    assert stored.counts["rays_cube_hit"] > 0.5 * W * H
    centre = (slice(H // 4, 3 * H // 4), slice(W // 4, 3 * W // 4))
    a, b = per_ray[centre][..., :3], stored.image[centre][..., :3]
    shadowed = a.mean(axis=2) < 0.5 * a.mean()
    assert 0.05 < shadowed.mean() < 0.8, "the mirror shows the shadow and the lit floor"
    error = flip_mean(per_ray, stored.image)
    if error > 0.02 or np.abs(a - b).mean() > 0.02 * a.mean():
        save_failure_images(f"cube_light_stored_{tracer}", per_ray=per_ray, stored=stored.image)
    assert np.abs(a - b).mean() <= 0.02 * a.mean(), np.abs(a - b).mean() / a.mean()
    assert error <= 0.02, error


def checker_graph() -> ShaderGraph:
    """A Principled whose Base Color is a red and blue Checker Texture at object coordinates
    (squares of 5 m, so that the floor's plane lies inside a row of cells, not on the
    boundary between two): the row's own colour (grey) is nowhere in the picture."""
    graph = ShaderGraph()
    coords = graph.add("TEX_COORD")
    checker = graph.add("TEX_CHECKER", Vector=Link(coords, "Object"), Scale=0.2, Color1=(0.8, 0.05, 0.05, 1.0),
                        Color2=(0.05, 0.05, 0.8, 1.0))
    graph.surface = Link(graph.add("BSDF_PRINCIPLED", **{"Base Color": Link(checker, "Color")}), "BSDF")
    return graph


@pytest.mark.parametrize("tracer", ["cpu", "gpu"])
def test_a_node_graphs_colours_reach_the_stored_light(renderer, both_tracers, tracer):
    """A floor whose colour is a node graph's looks the same in the mirror whether its cube-map
    hits run the graph per ray or read the lit cube map: the map's texels run it too."""
    variants.set_override(f"trace={tracer}")
    base, camera = shadowed_floor_scene(), camera_at((0, 0, 0), (0, 1, -0.2))
    materials = MaterialTable.from_rows([dict(name="mirror", base_color=(0.9, 0.9, 0.9), reflectivity=1.0, roughness=0.0),
                                         dict(name="floor", base_color=(0.5, 0.5, 0.5)),
                                         dict(name="block", base_color=(0.0, 0.0, 0.0), specular=0.0)])
    materials.node_graphs = [None, checker_graph(), None]
    scene = SceneData(base.geometry, materials, base.lights, base.sky)
    per_ray = render(renderer, scene, camera, lit_cube=False, cube_resolution=256).image
    stored = render(renderer, scene, camera, lit_cube=True, cube_resolution=256)
    assert stored.counts["rays_cube_hit"] > 0.5 * W * H
    centre = (slice(H // 4, 3 * H // 4), slice(W // 4, 3 * W // 4))
    a, b = per_ray[centre][..., :3], stored.image[centre][..., :3]
    lit = a.sum(axis=2) > 0.5 * a.sum(axis=2).mean()
    assert (a[lit, 0] > 2.0 * a[lit, 1]).mean() > 0.2 and (a[lit, 2] > 2.0 * a[lit, 1]).mean() > 0.2, \
        "the mirror shows red and blue squares"
    # The squares' edges fall on whole texels of the map in one image and anywhere in the
    # other: a few pixels along each edge differ, the rest agree (FLIP 0.02 for a floor of
    # one colour, test_cube_hits_read_the_light_they_would_be_shaded_with).
    error = flip_mean(per_ray, stored.image)
    if error > 0.05:
        save_failure_images(f"cube_light_graph_{tracer}", per_ray=per_ray, stored=stored.image)
    colour_a, colour_b = a.mean(axis=(0, 1)), b.mean(axis=(0, 1))
    assert (np.abs(colour_a - colour_b) <= 0.04 * colour_a).all(), (colour_a, colour_b)  # red and blue, not grey
    assert np.abs(a - b).mean() <= 0.04 * a.mean(), np.abs(a - b).mean() / a.mean()
    assert error <= 0.05, error


# -- the feedback: a light that goes leaves nothing; energy stays bounded -------------------------
def room_scene(albedo: float, lamp: bool, closed: bool) -> SceneData:
    """A room of one albedo around the camera (near cube 0.5: all of it in the cube map), lit by
    one point lamp or none; open (a floor and two walls) or closed (six walls)."""
    mats = MaterialTable.from_rows([dict(name="wall", base_color=(albedo,) * 3, specular=0.0)])
    if closed:
        objects = [(box((-4.0, -4.0, -2.0), (4.0, 4.0, 3.0)), None, 0)]
    else:
        objects = [(quad((0, 0, -2.0), (4, 0, 0), (0, 4, 0)), None, 0),
                   (quad((0, 4.0, 0.5), (4, 0, 0), (0, 0, 2.5)), None, 0),
                   (quad((4.0, 0, 0.5), (0, 4, 0), (0, 0, 2.5)), None, 0)]
    lights = [dict(kind="POINT", position=(1.0, 1.0, 1.5), color=(400.0, 400.0, 400.0))] if lamp else []
    return SceneData(Geometry.from_objects(objects), mats, Lights.from_rows(lights), Sky(color=(0.0, 0.0, 0.0)))


ROOM = dict(near_size=0.5, cube_resolution=64, ao_distance=1.0)


def stored_mean(renderer) -> float:
    return float(renderer.cube_light.read_level(0)[..., :3].mean())


def test_a_light_switched_off_leaves_no_light_behind_after_fade_frames(renderer):
    """The lamp's direct light goes at once; what it bounced lingers in the feedback for a few
    frames and is gone (below 1 %) after FADE_FRAMES, in a room of albedo 1/2."""
    camera = camera_at((-1.0, -1.0, 0.0), (1.0, 1.0, -0.5))
    renderer.cube_light.forget() if renderer.cube_light is not None else None
    for _ in range(12):
        render(renderer, room_scene(0.5, True, False), camera, **ROOM)
    lit = stored_mean(renderer)
    after = []
    for _ in range(FADE_FRAMES):
        render(renderer, room_scene(0.5, False, False), camera, **ROOM)
        after.append(stored_mean(renderer))
    assert lit > 0.0
    assert after[0] > 0.01 * lit, "the bounced light outlives the lamp by a frame (the feedback)"
    assert after[-1] < 0.01 * lit, (lit, after)


def test_a_closed_white_room_converges_to_a_bounded_light(renderer):
    """A closed room of albedo 0.8 around one lamp: every bounce returns 80 % of the light, so
    the feedback adds bounces frame by frame and levels off near the direct light over
    (1 - albedo) (the room's multi-bounce sum), never growing past it."""
    camera = camera_at((-1.0, -1.0, 0.0), (1.0, 1.0, -0.5))
    scene = room_scene(0.8, True, True)
    render(renderer, scene, camera, **{**ROOM, "ao_distance": 0.0})  # no gather: direct light only
    direct = stored_mean(renderer)
    renderer.cube_light.forget()
    means = []
    for _ in range(40):
        render(renderer, scene, camera, **ROOM)
        means.append(stored_mean(renderer))
    means = np.array(means)
    assert means[-1] > 2.0 * direct, "the bounces add up"
    assert means.max() <= 1.2 * direct / (1.0 - 0.8), (direct, means)
    late, later = means[-20:-10].mean(), means[-10:].mean()
    assert abs(later - late) <= 0.05 * later, (late, later)


def test_the_lit_cube_map_is_a_step_of_its_own_after_the_cube_map(renderer):
    scene, camera = shadowed_floor_scene(), camera_at((0, 0, 0), (0, 1, -0.2))
    result = renderer.render(scene, camera, RenderSettings(**BASE), timing=True)
    assert tuple(result.passes) == frame_steps("HYBRID", lit_cube=True)
    assert frame_steps("HYBRID", lit_cube=True).index("cube_light") == frame_steps("HYBRID").index("cube_map_raster") + 1


# -- the texels hold no emission: a bright emitter's reflected light is not left to float16 ------
PANEL_EMISSION = 20.0  # float16 steps by 1/64 between 16 and 32


def sunlit_panel_over_floor(emission: float, sun: bool) -> SceneData:
    """A matte floor round the camera (inside the near cube: a primary surface, not in the
    map) under a square panel beyond the near cube (in the map) facing it; a sun from below,
    casting no shadow, lights the panel's underside and nothing of the floor's top, and the
    World is black. The panel reflects the sun's light (a few hundredths, not a multiple of
    float16's step at the emission), the floor's diffuse paths find it in the cube map."""
    mats = MaterialTable.from_rows([
        dict(name="floor", base_color=(0.8, 0.8, 0.8), specular=0.0, roughness=1.0),
        dict(name="panel", base_color=(0.8, 0.8, 0.8), specular=0.0, roughness=1.0,
             emission=(emission,) * 3),
    ])
    objects = [(quad((0.0, 0.0, 0.0), (0.9, 0, 0), (0, 0.9, 0)), None, 0),
               (quad((0.0, 0.0, 3.0), (1.5, 0, 0), (0, -1.5, 0)), None, 1)]
    lights = [dict(kind="SUN", direction=(0.0, 0.0, 1.0), color=(0.15, 0.15, 0.15), cast_shadow=False)] if sun else []
    return SceneData(Geometry.from_objects(objects), mats, Lights.from_rows(lights), Sky(color=(0.0, 0.0, 0.0)))


def test_the_light_a_bright_emitter_reflects_reaches_diffuse_paths_through_the_map_unrounded(renderer):
    """The floor's diffuse paths take the panel's emission by their next-event estimate and
    end on its texels in the lit cube map, where they take only the light it reflects. Light
    adds up: the sun's share of the floor's light (sun on minus sun off) is the same with the
    panel emitting 20 as with it dark. A texel holding the emission as well, taken off again
    by the path, would leave that share to float16's step at 20 (1/64), a good part of it."""
    camera = camera_at((0.0, -1.0, 1.0), (0.0, 0.0, 0.0))
    settings = dict(near_size=2.0, cube_resolution=64, ao_distance=10.0, diffuse_bounces=1,
                    denoise_viewport=False, denoise_render=False)

    def fresh(scene: SceneData) -> np.ndarray:
        """A render whose lit cube map starts over, drawing the same numbers as the others."""
        if renderer.cube_light is not None:
            renderer.cube_light.forget()
        return render(renderer, scene, camera, **settings).image[..., :3]

    emitting = fresh(sunlit_panel_over_floor(PANEL_EMISSION, True)) - fresh(sunlit_panel_over_floor(PANEL_EMISSION, False))
    dark = fresh(sunlit_panel_over_floor(0.0, True))
    floor = dark.sum(axis=-1) > 0.0
    assert floor.sum() > 0.5 * W * H, "the floor fills most of the view, lit by the panel's reflection"
    error = np.abs(emitting[floor] - dark[floor]).mean() / dark[floor].mean()
    if not error < 0.01:
        save_failure_images("cube_light_bright_emitter", emitting=emitting, dark=dark)
    assert error < 0.01, (error, emitting[floor].mean(), dark[floor].mean())
