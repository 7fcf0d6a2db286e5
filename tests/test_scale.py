# SPDX-License-Identifier: GPL-3.0-or-later
"""Scale-proof defaults (hybrid_engine/scene/scale.py, the texel shadow bias of
include/lighting.glsl, the scene-relative ray offset of include/scene_bounds.glsl, the
position keys of include/random.glsl in cells of the typical object size times a power of
two): one scene built at 1 mm, 1 m and 1 km, camera and lamp power scaled with it, is one
picture with the default traced and denoised diffuse light, one noise pattern in a single
sample, and one picture with soft lamps; the Automatic far clip follows a scene grown past
the old fixed 1000 m; shadows exist at 1 mm; the face resolution follows the output size
unless fixed."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from hybrid_engine import Camera, Geometry, Lights, MaterialTable, RenderSettings, SceneData, Sky
from hybrid_engine.frame.antialias import render_antialiased
from hybrid_engine.scene.camera import look_at
from hybrid_engine.frame.near_budget import NearCubeSizer
from hybrid_engine.scene.scale import NEAR_SIZE_PER_OBJECT, auto_cube_resolution, effective_values, near_limits, resolve
from scenes_analytic import box, quad, uv_sphere
from whitted_reference import flip_mean

SCALES = (1e-3, 1.0, 1e3)
SIZE = (96, 64)
# The settings of the test: small maps for speed, everything else the defaults: what follows
# the scene left Automatic, the World's and the bounced light traced by paths (diffuse_rays,
# four bounces), rendered as a final render renders them (render_samples samples, denoised).
DEFAULTS = RenderSettings(mode="HYBRID", shadow_resolution=512, cube_resolution_ratio=1.0, shadow_cascades=0)
# The World's light without occlusion, for the tests about lengths and shadows: their
# pictures need no noise.
LIGHT = dict(world_light="SCREEN", ao_distance=0.0)
SETTINGS = replace(DEFAULTS, **LIGHT)
# The fixed values these settings had before they followed the scene.
EARLIER = RenderSettings(mode="HYBRID", shadow_resolution=512, cube_resolution=96, shadow_cascades=0,
                         near_size=5.0, cube_far=1000.0, shadow_bias=0.005, shadow_bias_texels=0.5, **LIGHT)


def built(scale: float, width: int = SIZE[0], height: int = SIZE[1], box_too: bool = True, soft: bool = False
          ) -> tuple[SceneData, Camera]:
    """A floor, a diffuse box, a mirror ball and a glass ball under a sun and a point lamp
    (power as the square of ``scale``, so the light reaching the floor is the same), seen by
    a camera whose position and clipping planes scale too. Lamps without size (hard
    shadows, no sampled penumbra), or with ``soft``: a sun of some angle, a point lamp of
    some radius and a rectangular area lamp, whose penumbrae are sampled."""
    s = float(scale)
    ball, ball_n = uv_sphere((0.9 * s, 0.3 * s, 0.6 * s), 0.6 * s, 24, 12)
    glass, glass_n = uv_sphere((-1.0 * s, -0.6 * s, 0.5 * s), 0.5 * s, 24, 12)
    objects = [(quad((0, 0, 0), (4 * s, 0, 0), (0, 4 * s, 0)), None, 0),
               *([(box((-0.4 * s, 0.6 * s, 0), (0.2 * s, 1.2 * s, 1.0 * s)), None, 1)] if box_too else []),
               (ball, ball_n, 2), (glass, glass_n, 3)]
    materials = MaterialTable.from_rows([
        dict(base_color=(0.7, 0.7, 0.65)), dict(base_color=(0.8, 0.25, 0.2)),
        dict(base_color=(0.95, 0.95, 0.95), reflectivity=1.0, roughness=0.0),
        dict(base_color=(1.0, 1.0, 1.0), transmission=1.0, roughness=0.0, ior=1.45)])
    lamps = [dict(kind="SUN", direction=(0.4, 0.5, -1.0), color=(2.0, 2.0, 1.9)),
             dict(kind="POINT", position=(1.5 * s, -1.5 * s, 2.5 * s), color=(60.0 * s * s,) * 3)]
    if soft:
        lamps[0]["radius"], lamps[1]["radius"] = 0.1, 0.5 * s  # the sun's angle; the lamp's radius
        lamps.append(dict(kind="AREA", position=(-1.5 * s, 0.5 * s, 2.0 * s), direction=(0.5, 0.0, -1.0),
                          color=(30.0 * s * s,) * 3, radius=0.6 * s, area_size_y=0.3 * s))
    lights = Lights.from_rows(lamps)
    camera = Camera(matrix_world=look_at((0.5 * s, -5.0 * s, 2.5 * s), (0, 0, 0.5 * s)), width=width,
                    height=height, clip_start=0.05 * s, clip_end=100.0 * s)
    return SceneData(Geometry.from_objects(objects), materials, lights, Sky(color=(0.25, 0.3, 0.4))), camera


def _images(renderer, settings: RenderSettings, samples: int | None = None, denoise: bool | None = None
            ) -> dict[float, np.ndarray]:
    """The scene at each scale, rendered as a final render does (the settings' samples and
    denoiser unless told)."""
    samples = settings.render_samples if samples is None else samples
    denoise = settings.denoise_render if denoise is None else denoise
    out = {}
    for scale in SCALES:
        scene, camera = built(scale)
        out[scale] = render_antialiased(renderer, scene, camera, settings, samples,
                                        denoise=denoise).image[..., :3].copy()
    return out


def _errors(images: dict[float, np.ndarray]) -> dict[str, float]:
    """FLIP between each pair of scales."""
    return {f"{a:g}-{b:g}": flip_mean(images[a], images[b]) for a, b in ((1.0, 1e-3), (1.0, 1e3), (1e-3, 1e3))}


def test_one_scene_at_1mm_1m_and_1km_is_one_picture_in_hybrid(renderer):
    """With the defaults: traced diffuse light of four bounces, its samples denoised."""
    errors = _errors(_images(renderer, DEFAULTS))
    assert all(e <= 0.02 for e in errors.values()), errors


def test_the_noise_of_one_traced_sample_is_one_pattern_at_every_scale(renderer):
    """One sample, not denoised: the diffuse paths draw their numbers at the same points of
    the scene at every scale (random.glsl's position keys in the scene's typical object
    size), so even the noise is one picture."""
    errors = _errors(_images(renderer, DEFAULTS, samples=1, denoise=False))
    assert all(e <= 0.02 for e in errors.values()), errors


def test_soft_shadows_and_an_area_lamp_are_one_picture_at_every_scale(renderer):
    """Sampled penumbrae (a sun of some angle, a point lamp of some radius, a rectangular
    area lamp), one sample: the filter's rotations are drawn at the same points of the scene
    at every scale (include/lighting.glsl's position keys), and a lamp's shadow map spans the
    same share of its distances (shadow_depth.shadow_views: no near plane in scene units)."""
    images = {}
    for scale in SCALES:
        scene, camera = built(scale, soft=True)
        images[scale] = renderer.render(scene, camera, SETTINGS).image[..., :3]
    for scale in (1e-3, 1e3):
        assert flip_mean(images[1.0], images[scale]) <= 0.01, scale
        # One noise pattern: few pixels differ at all (keyed by float bits, a tenth did).
        differ = np.abs(images[scale] - images[1.0]).max(axis=2) > 0.01
        assert differ.mean() < 0.05, (scale, differ.mean())


def test_the_fixed_defaults_of_earlier_versions_did_not_hold_at_1mm_or_1km(renderer):
    """What the test above guards against: with the absolute lengths the settings had, the
    millimetre scene loses its shadows and the kilometre one its distant reflections."""
    images = _images(renderer, EARLIER, samples=1, denoise=False)
    errors = {scale: flip_mean(images[1.0], images[scale]) for scale in (1e-3, 1e3)}
    assert all(e > 0.02 for e in errors.values()), errors


def _box_shadow(renderer, scale: float) -> int:
    """Pixels the red box darkens without being red: its shadow, against the scene without it."""
    scene, camera = built(scale)
    with_box = renderer.render(scene, camera, SETTINGS).image[..., :3]
    without = renderer.render(built(scale, box_too=False)[0], camera, SETTINGS).image[..., :3]
    grey = with_box[..., 0] < 1.3 * with_box[..., 1]
    return int(((with_box.mean(axis=2) < 0.6 * without.mean(axis=2)) & grey).sum())


def test_shadows_exist_at_1mm(renderer):
    """The box's shadow on the floor, at 1 mm as at 1 m."""
    at_1m = _box_shadow(renderer, 1.0)
    assert at_1m >= 18  # a shadow, not a few stray pixels (FULL_BVH's picture holds 22)
    assert _box_shadow(renderer, 1e-3) >= 0.9 * at_1m


def test_the_far_clip_follows_a_scene_grown_beyond_1000_m():
    """A tower 3 km away: the Automatic far plane reaches past it; the fixed one stays put."""
    scene, camera = built(1.0)
    tower = box((-10.0, 3000.0, 0.0), (10.0, 3020.0, 50.0))
    grown = SceneData(Geometry.from_objects([(quad((0, 0, 0), (4, 0, 0), (0, 4, 0)), None, 0), (tower, None, 1)]),
                      scene.materials, scene.lights, scene.sky)
    eye = camera.position
    reach = float(np.linalg.norm(np.maximum(np.abs(np.array([-10.0, -4.0, 0.0]) - eye),
                                            np.abs(np.array([10.0, 3020.0, 50.0]) - eye))))
    auto = effective_values(RenderSettings(), grown, eye, *SIZE)
    assert reach < auto.cube_far < 1.1 * reach
    assert "cube_far" in auto.automatic
    fixed = effective_values(RenderSettings(cube_far=1000.0), grown, eye, *SIZE)
    assert fixed.cube_far == 1000.0 and "cube_far" not in fixed.automatic


def test_the_far_clip_reflects_a_distant_object_that_the_fixed_far_clip_drops(renderer):
    """In the picture: a tall red wall 1.5 km behind the camera shows in the mirror ball
    with the Automatic far clip and not with the fixed 1000 m of earlier versions."""
    scene, camera = built(1.0)
    wall = box((-2000.0, -1500.0, -10.0), (2000.0, -1490.0, 1500.0))
    objects = [(quad((0, 0, 0), (4, 0, 0), (0, 4, 0)), None, 0), (wall, None, 1)]
    ball, ball_n = uv_sphere((0.0, 0.0, 1.0), 1.0, 32, 16)
    objects.append((ball, ball_n, 2))
    far_scene = SceneData(Geometry.from_objects(objects), scene.materials, scene.lights, scene.sky)
    auto = renderer.render(far_scene, camera, SETTINGS).image[..., :3]
    fixed = renderer.render(far_scene, camera, replace(SETTINGS, cube_far=1000.0)).image[..., :3]
    red = lambda img: int(((img[..., 0] > 1.5 * img[..., 2]) & (img[..., 0] > 0.05)).sum())  # noqa: E731
    assert red(auto) > red(fixed) + 20, (red(auto), red(fixed))


def test_the_automatic_near_size_is_a_multiple_of_the_typical_object_size():
    for scale in SCALES:
        scene, camera = built(scale)
        settings, values = resolve(RenderSettings(), scene, camera.position, *SIZE)
        diagonals = np.linalg.norm(np.diff(scene.geometry.object_bounds, axis=1)[:, 0], axis=1)
        assert settings.near_size == pytest.approx(NEAR_SIZE_PER_OBJECT * float(np.median(diagonals)), rel=1e-5)
        assert settings.cube_far > settings.near_size
        assert resolve(RenderSettings(near_size=2.0), scene, camera.position, *SIZE)[0].near_size == 2.0


def test_many_instances_of_one_small_mesh_count_once_in_the_automatic_near_size():
    """A room (floor and walls), a ball and nine linked duplicates of a pebble: by object, the
    pebbles are the median and the near cube would shrink to a pebble's; by mesh, each
    distinct shape counts once (the scene's distinct sizes: the room's three planes, the
    ball, the pebble)."""
    from hybrid_engine.scene.geometry import InstancedGeometry
    from hybrid_engine.scene.meshes import Instances
    from scenes_instanced import grid_mesh, placed, sphere_mesh

    sphere, plane = sphere_mesh(), grid_mesh()
    rotate_x = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]])
    rooms = [placed(np.eye(3) * 4, (0, 0, 0)), placed(rotate_x * 4, (0, 4, 2)), placed(rotate_x.T * 4, (0, -4, 2))]
    pebbles = [placed(np.eye(3) * 0.1, (0.5 * k - 2.0, -1.0, 0.1)) for k in range(9)]
    matrices = rooms + [placed(np.eye(3) * 0.8, (0.5, 0.5, 0.8))] + pebbles
    mesh = np.array([1, 1, 1, 0] + [2] * 9)
    instances = Instances(meshes=[sphere, plane, sphere_mesh()], mesh=mesh,
                          matrices=np.array(matrices, np.float32), slot_materials=[np.int32([0, 0])] * len(mesh))
    scene = SceneData(geometry=InstancedGeometry(instances), materials=MaterialTable.from_rows([{}]))
    diagonals = np.linalg.norm(np.diff(scene.geometry.object_bounds, axis=1)[:, 0], axis=1)
    room, ball, pebble = diagonals[0], diagonals[3], diagonals[4]
    assert np.median(diagonals) == pytest.approx(pebble)  # by object, a pebble's
    eye = (0.0, -3.0, 1.5)
    settings, _values = resolve(RenderSettings(), scene, eye, *SIZE)
    # Three distinct meshes: the planes (one mesh, three instances), the ball, the pebbles.
    assert settings.near_size == pytest.approx(NEAR_SIZE_PER_OBJECT * ball, rel=1e-5)
    assert pebble < ball < room


def test_frame_budget_limits_follow_the_scene_scale_and_fixed_ones_win():
    budget = RenderSettings(near_cube_mode="BUDGET")
    limits = {}
    for scale in SCALES:
        scene, camera = built(scale)
        lo, hi = near_limits(budget, scene)
        near = resolve(RenderSettings(), scene, camera.position, *SIZE)[0].near_size
        assert lo < near < hi
        limits[scale] = (lo / scale, hi / scale)
        # The sizer searches within them, starting from the Automatic near size.
        sized = NearCubeSizer().settings_for_frame(budget, scene)
        assert (sized.near_min, sized.near_max) == (lo, hi)
        assert sized.near_size == pytest.approx(near)
        # The far clip lies beyond the largest cube the budget may grow.
        assert resolve(sized, scene, camera.position, *SIZE)[0].cube_far > hi
    assert limits[1e-3] == pytest.approx(limits[1.0], rel=1e-4)
    assert limits[1e3] == pytest.approx(limits[1.0], rel=1e-4)
    scene, _camera = built(1e3)
    assert near_limits(replace(budget, near_min=0.5, near_max=20.0), scene) == (0.5, 20.0)
    # A fixed minimum above the Automatic maximum lifts it rather than inverting the range.
    lo, hi = near_limits(replace(budget, near_min=1e5), built(1e-3)[0])
    assert lo == hi == 1e5


def test_the_cube_resolution_follows_the_output_size_and_a_fixed_one_wins():
    scene, camera = built(1.0)
    ratio = RenderSettings().cube_resolution_ratio
    sizes = {}
    for width, height in ((640, 360), (1280, 720), (1920, 1080)):
        values = effective_values(RenderSettings(), scene, camera.position, width, height)
        assert values.cube_resolution == auto_cube_resolution(ratio, width, height)
        assert abs(values.cube_resolution - ratio * width) <= 8
        sizes[width] = values.cube_resolution
        assert effective_values(RenderSettings(cube_resolution=512), scene, camera.position, width,
                                height).cube_resolution == 512
    assert sizes[640] < sizes[1280] < sizes[1920]
    # A small output keeps the floor's faces: fewer texels let diffuse rays slip past walls.
    assert effective_values(RenderSettings(), scene, camera.position, 320, 180).cube_resolution == 256
    assert effective_values(RenderSettings(cube_resolution_ratio=0.2), scene, camera.position, 1280,
                            720).cube_resolution == 256


def test_a_frame_reports_the_values_it_rendered_with(renderer):
    scene, camera = built(1.0)
    result = renderer.render(scene, camera, SETTINGS)
    assert result.effective.cube_resolution == auto_cube_resolution(1.0, *SIZE)
    assert result.near_size == pytest.approx(result.effective.near_size)
    assert set(result.effective.automatic) == {"near_size", "cube_far", "cube_resolution", "near_min", "near_max"}
    assert renderer.cube_map.resolution == result.effective.cube_resolution


def _blender_scene(bpy, scale: float):
    """A plane, a cube and a mirror ball under a sun and a point lamp (power as the square of
    ``scale``), camera scaled with them, built as an artist would in Blender."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    s = float(scale)

    def material(name, color, metallic=0.0, roughness=1.0):
        mat = bpy.data.materials.new(name)
        mat.use_nodes = True
        bsdf = mat.node_tree.nodes["Principled BSDF"]
        bsdf.inputs["Base Color"].default_value = (*color, 1.0)
        bsdf.inputs["Metallic"].default_value = metallic
        bsdf.inputs["Roughness"].default_value = roughness
        return mat

    bpy.ops.mesh.primitive_plane_add(size=8 * s)
    bpy.context.object.data.materials.append(material("floor", (0.7, 0.7, 0.65)))
    bpy.ops.mesh.primitive_cube_add(size=0.8 * s, location=(-0.4 * s, 0.8 * s, 0.4 * s))
    bpy.context.object.data.materials.append(material("box", (0.8, 0.25, 0.2)))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.6 * s, location=(0.9 * s, 0.0, 0.6 * s))
    bpy.context.object.data.materials.append(material("mirror", (0.95, 0.95, 0.95), 1.0, 0.0))
    for kind, energy, location in (("SUN", 2.0, (0.0, 0.0, 5.0 * s)), ("POINT", 600.0 * s * s, (1.5 * s, -1.5 * s, 2.5 * s))):
        lamp = bpy.data.lights.new(kind, kind)
        lamp.energy = energy
        lamp.shadow_soft_size = 0.0
        if kind == "SUN":
            lamp.angle = 0.0
        obj = bpy.data.objects.new(kind, lamp)
        obj.location = location
        obj.rotation_euler = (0.4, 0.3, 0.0)
        scene.collection.objects.link(obj)
    cam = bpy.data.cameras.new("cam")
    cam.clip_start, cam.clip_end = 0.05 * s, 100.0 * s
    cam_obj = bpy.data.objects.new("cam", cam)
    cam_obj.matrix_world = look_at_matrix(bpy, (0.5 * s, -5.0 * s, 2.5 * s), (0.0, 0.0, 0.5 * s))
    scene.collection.objects.link(cam_obj)
    scene.camera = cam_obj
    world = bpy.data.worlds.new("world")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.25, 0.3, 0.4, 1.0)
    scene.world = world
    scene.render.resolution_x, scene.render.resolution_y = SIZE
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.render.engine = "HYBRID_RT"
    settings = scene.hybrid_rt
    # The defaults (traced diffuse light, its samples denoised), small shadow maps for speed.
    settings.mode, settings.shadow_resolution, settings.shadow_cascades = "HYBRID", 512, 0
    return scene


def look_at_matrix(bpy, eye, target):
    from mathutils import Matrix

    return Matrix(look_at(eye, target).tolist())


def test_blenders_render_path_gives_one_picture_at_1mm_and_1m(addon, tmp_path):
    import bpy

    from test_engine import render_exr

    images = {}
    for scale in (1e-3, 1.0):
        scene = _blender_scene(bpy, scale)
        images[scale] = render_exr(bpy, scene, tmp_path / f"scale_{scale:g}.exr")[..., :3]
        frame = addon.blender_adapter.engine.last_frame
        assert set(frame.effective.automatic) == {"near_size", "cube_far", "cube_resolution", "near_min", "near_max"}
        assert addon.blender_adapter.effective_values.last() == frame.effective  # what the panel shows
    assert flip_mean(images[1.0], images[1e-3]) <= 0.02
