# SPDX-License-Identifier: GPL-3.0-or-later
"""The surface model (gpu_shaders/include/shading.glsl) as an artist sees it: glossy
dielectrics, rough metals, glass at the depth limit. Measured on small FULL_BVH frames,
whose rays see exactly the geometry (tracer oracles live in test_tracer.py)."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine.scene.camera import Camera, look_at
from hybrid_engine.frame.renderer import Renderer
from hybrid_engine.scene.geometry import Geometry
from hybrid_engine.scene.data import Lights, MaterialTable, SceneData, Sky
from hybrid_engine.scene.settings import RenderSettings
from scenes_analytic import quad, uv_sphere

W, H = 64, 48
EMITTER = 4.0


@pytest.fixture(scope="module")
def renderer(gl):
    r = Renderer(gl)
    yield r
    r.release()


def render(renderer, scene, camera, samples=1, **kw):
    settings = RenderSettings(mode="FULL_BVH", cube_resolution=64, shadow_resolution=256, ao_distance=0.0,
                              **{"world_light": "SCREEN", **kw})
    images = [renderer.render(scene, camera, settings, timing=False, sample=i).image[..., :3]
              for i in range(samples)]
    return np.mean(images, axis=0)


def floor_and_wall(floor_row):
    """A floor (material 0) at z = 0 and an emissive wall (material 1) standing at y = 6."""
    objects = [(quad((0, 0, 0), (20, 0, 0), (0, 20, 0)), None, 0),
               (quad((0, 6, 3), (20, 0, 0), (0, 0, 3)), None, 1)]
    mats = MaterialTable.from_rows([floor_row, dict(base_color=(0, 0, 0), emission=(EMITTER,) * 3)])
    return SceneData(Geometry.from_objects(objects), mats, sky=Sky(color=(0.0, 0.0, 0.0)))


def test_a_glossy_dielectric_floor_reflects_at_grazing_angles_and_hardly_at_normal_incidence(renderer):
    # A black dielectric floor: all it shows is its specular coat (f0 4 %, IOR 1.5).
    scene = floor_and_wall(dict(base_color=(0, 0, 0), roughness=0.05, specular=0.04))
    grazing = render(renderer, scene, Camera(matrix_world=look_at((0, -6, 0.4), (0, 0, 0)), width=W, height=H))
    # Under an emissive ceiling, looking straight down: the reflection at normal incidence.
    ceiling = [(quad((0, 0, 0), (20, 0, 0), (0, 20, 0)), None, 0), (quad((0, 0, 4), (20, 0, 0), (0, 20, 0)), None, 1)]
    lit_from_above = SceneData(Geometry.from_objects(ceiling), scene.materials, sky=scene.sky)
    above = render(renderer, lit_from_above, Camera(matrix_world=look_at((0, 0, 2.0), (0, 0, 0.0), up=(0, 1, 0)),
                                                    width=W, height=H))
    floor_rows = grazing[: H // 2]  # below the horizon: the floor
    reflected = floor_rows.max(axis=(0, 1)).mean()
    head_on = above[H // 2 - 4: H // 2 + 4, W // 2 - 4: W // 2 + 4].mean()
    assert reflected > 0.3 * EMITTER, reflected  # Fresnel rises towards 1 at grazing angles
    assert head_on == pytest.approx(0.04 * EMITTER, rel=0.25), head_on  # f0 at normal incidence


def test_a_rough_metal_blurs_its_reflection_more_as_roughness_grows(renderer):
    # A metal floor reflecting a wall of emissive stripes; the reflection's contrast falls
    # as the GGX lobe widens (each roughness averaged over the same samples).
    stripes = [(quad((x, 6, 2), (0.25, 0, 0), (0, 0, 2)), None, 1) for x in np.arange(-6.0, 6.5, 1.0)]
    objects = [(quad((0, 0, 0), (20, 0, 0), (0, 20, 0)), None, 0), *stripes]
    contrasts = []
    for roughness in (0.0, 0.15, 0.3, 0.45):
        mats = MaterialTable.from_rows([dict(base_color=(0.9, 0.9, 0.9), reflectivity=1.0, roughness=roughness),
                                        dict(base_color=(0, 0, 0), emission=(EMITTER,) * 3)])
        scene = SceneData(Geometry.from_objects(objects), mats, sky=Sky(color=(0.0, 0.0, 0.0)))
        camera = Camera(matrix_world=look_at((0, -2, 1.5), (0, 4, 0)), width=W, height=H)
        image = render(renderer, scene, camera, samples=16)
        band = image[4:12, :, :].mean(axis=2)  # rows of the floor reflecting the stripes
        contrasts.append(float(band.std(axis=1).mean()))
    assert all(b < a for a, b in zip(contrasts, contrasts[1:])), contrasts
    assert contrasts[-1] < 0.5 * contrasts[0], contrasts


def test_glass_at_the_depth_limit_shows_the_environment_not_black(renderer):
    tris, normals = uv_sphere((0, 0, 0), 1.0, segments=32, rings=16)
    mats = MaterialTable.from_rows([dict(base_color=(1, 1, 1), transmission=1.0, ior=1.5)])
    sky = Sky(color=(0.3, 0.5, 0.8))
    scene = SceneData(Geometry.from_objects([(tris, normals, 0)]), mats, sky=sky)
    camera = Camera(matrix_world=look_at((0, -4, 0), (0, 0, 0)), width=W, height=H)
    image = render(renderer, scene, camera, max_depth=1)
    ball = image[H // 2 - 4: H // 2 + 4, W // 2 - 4: W // 2 + 4]
    # Through the ball's centre nearly all light is transmitted: it shows the sky's colour.
    np.testing.assert_allclose(ball.mean(axis=(0, 1)), sky.color, rtol=0.15)


@pytest.mark.parametrize("mode", ["FULL_BVH", "HYBRID"])
def test_world_light_rays_darken_a_floor_under_a_distant_roof_that_screen_space_occlusion_misses(renderer, mode):
    # A floor under a black roof 6 m up (its underside out of view, beyond the occlusion's
    # reach, reflecting nothing), lit by a white World only: rays through the BVH (and, in
    # HYBRID, the cube map, which holds the roof beyond the near cube) find the roof; the
    # screen's depths cannot.
    objects = [(quad((0, 0, 0), (30, 0, 0), (0, 30, 0)), None, 0), (quad((0, 0, 6), (30, 0, 0), (0, 30, 0)), None, 1)]
    rows = [dict(base_color=(0.8, 0.8, 0.8)), dict(base_color=(0.0, 0.0, 0.0))]
    scene = SceneData(Geometry.from_objects(objects), MaterialTable.from_rows(rows), sky=Sky(color=(1.0, 1.0, 1.0)))
    camera = Camera(matrix_world=look_at((0, -4, 1.5), (0, 0, 0)), width=W, height=H)
    floor = (slice(0, H // 3), slice(W // 4, 3 * W // 4))
    images = {}
    for rays in (False, True):
        settings = RenderSettings(mode=mode, near_size=3.0, cube_resolution=128, shadow_resolution=256,
                                  world_light="RAYS" if rays else "SCREEN")
        images[rays] = np.mean([renderer.render(scene, camera, settings, timing=False, sample=i).image[..., :3]
                                for i in range(4)], axis=0)
    assert images[False][floor].mean() > 0.7  # the screen sees no roof: the whole sky (0.8)
    assert images[True][floor].mean() < 0.25 * images[False][floor].mean()


def test_world_light_rays_bring_the_light_of_the_surfaces_they_meet(renderer):
    # A white floor beside a red wall lit by a sun, no sky: without rays the floor gets only
    # the sun; with them, also the wall's red light (one bounce), as in a path tracer.
    objects = [(quad((0, 0, 0), (10, 0, 0), (0, 10, 0)), None, 0), (quad((0, 2, 2), (10, 0, 0), (0, 0, 2)), None, 1)]
    rows = [dict(base_color=(0.8, 0.8, 0.8)), dict(base_color=(0.9, 0.1, 0.1))]
    sun = dict(kind="SUN", direction=(0.0, 0.7, -0.7), color=(3.0, 3.0, 3.0), cast_shadow=False)
    scene = SceneData(Geometry.from_objects(objects), MaterialTable.from_rows(rows),
                      Lights.from_rows([sun]), Sky(color=(0.0, 0.0, 0.0)))
    camera = Camera(matrix_world=look_at((0, -5, 2.0), (0, 1, 0)), width=W, height=H)
    floor = (slice(0, H // 4), slice(W // 4, 3 * W // 4))
    images = {}
    for rays in (False, True):
        settings = RenderSettings(mode="FULL_BVH", shadow_resolution=256, world_light="RAYS" if rays else "SCREEN")
        images[rays] = np.mean([renderer.render(scene, camera, settings, timing=False, sample=i).image[..., :3]
                                for i in range(4)], axis=0)
    plain, bounced = images[False][floor].mean(axis=(0, 1)), images[True][floor].mean(axis=(0, 1))
    assert bounced[0] > plain[0] * 1.03  # red light from the wall
    assert bounced[0] - plain[0] > 3 * (bounced[2] - plain[2])  # and red, not white


def test_a_mirror_shows_a_sphere_lamp_as_a_disc_of_its_radiance_with_no_glow_around_it(renderer):
    # Looking straight down at a mirror with a black World: the only thing it shows is the
    # lamp, whose mirror image is a disc of the lamp's radiance (Blender's sphere lamp:
    # power / (4 pi^2 r^2)), as Cycles draws it; a widened GGX lobe would add a glow around.
    power, radius, height = 400.0, 0.3, 3.0
    mats = MaterialTable.from_rows([dict(base_color=(1.0, 1.0, 1.0), reflectivity=1.0, roughness=0.0)])
    scene = SceneData(Geometry.from_objects([(quad((0, 0, 0), (20, 0, 0), (0, 20, 0)), None, 0)]), mats,
                      Lights.from_rows([dict(kind="POINT", position=(0.0, 0.0, height), color=(power,) * 3,
                                             radius=radius)]), Sky(color=(0.0, 0.0, 0.0)))
    camera = Camera(matrix_world=look_at((0, 0, 2.0), (0, 0, 0.0), up=(0, 1, 0)), width=W, height=H)
    image = render(renderer, scene, camera).mean(axis=2)
    origins, dirs = camera.pixel_rays()
    points = origins + dirs * (-origins[..., 2:] / dirs[..., 2:])
    mirrored = dirs * np.array([1.0, 1.0, -1.0])
    to_lamp = np.array([0.0, 0.0, height]) - points
    miss = np.linalg.norm(np.cross(to_lamp, mirrored), axis=-1)  # the mirror ray's distance from the lamp
    radiance = power / (4.0 * np.pi ** 2 * radius ** 2)
    inside, outside = miss < 0.8 * radius, miss > 1.5 * radius
    assert inside.sum() > 30 and outside.sum() > 0.8 * image.size
    np.testing.assert_allclose(image[inside].mean(), radiance, rtol=0.25)
    assert image[outside].max() < 0.02 * radiance, image[outside].max() / radiance


def test_a_mirror_shows_the_floor_darker_where_a_wall_hides_its_sky(renderer):
    # Sky light only: a floor beside a tall wall, seen only in a vertical mirror. The floor's
    # points at the wall's foot see half the sky within AO Distance; their reflection must
    # be darker than the open floor's (an occlusion ray from the first bounce's hits).
    floor = quad((3, 0, 0), (3, 0, 0), (0, 6, 0))  # x in [0, 6]
    wall = quad((0, 0, 1.5), (0, 6, 0), (0, 0, 1.5))  # x = 0, facing both ways
    mirror = quad((3, 2, 1.0), (3, 0, 0), (0, 0, 1.0))  # y = 2
    mats = MaterialTable.from_rows([dict(base_color=(0.8, 0.8, 0.8)),
                                    dict(base_color=(1.0, 1.0, 1.0), reflectivity=1.0, roughness=0.0)])
    scene = SceneData(Geometry.from_objects([(floor, None, 0), (wall, None, 0), (mirror, None, 1)]), mats,
                      sky=Sky(color=(1.0, 1.0, 1.0)))
    camera = Camera(matrix_world=look_at((1.2, -0.5, 1.0), (1.2, 2.0, 0.4)), width=W, height=H)
    settings = RenderSettings(mode="FULL_BVH", cube_resolution=64, shadow_resolution=256, ao_distance=1.0, max_depth=1)
    image = np.mean([renderer.render(scene, camera, settings, timing=False, sample=i).image[..., :3]
                     for i in range(16)], axis=0).mean(axis=2)
    origins, dirs = camera.pixel_rays()
    to_mirror = (2.0 - origins[..., 1]) / dirs[..., 1]
    on_mirror = origins + dirs * to_mirror[..., None]
    seen_mirror = (to_mirror > 0) & (np.abs(on_mirror[..., 0] - 3) < 3) & (on_mirror[..., 2] > 0) & (on_mirror[..., 2] < 2)
    mirrored = dirs * np.array([1.0, -1.0, 1.0])
    to_floor = -on_mirror[..., 2] / np.where(mirrored[..., 2] < 0, mirrored[..., 2], -1.0)
    on_floor = on_mirror + mirrored * to_floor[..., None]
    floor_x = np.where(seen_mirror & (mirrored[..., 2] < 0), on_floor[..., 0], -1.0)
    at_foot, open_floor = (floor_x > 0.02) & (floor_x < 0.25), floor_x > 1.5
    assert at_foot.sum() > 20 and open_floor.sum() > 20
    ratio = image[at_foot].mean() / image[open_floor].mean()
    assert ratio < 0.85, ratio
