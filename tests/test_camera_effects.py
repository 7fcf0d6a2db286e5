# SPDX-License-Identifier: GPL-3.0-or-later
"""Depth of field and motion blur (hybrid_engine/frame/camera_effects.py), rendered through
Blender's render path against Cycles in the same process: a thin lens blurs what lies off
the focus plane as wide as Cycles' does and leaves the focus plane sharp, and a moving
object streaks as long as Cycles' over the same shutter."""
from __future__ import annotations

import math

import numpy as np
import pytest

from test_engine import render_exr

from hybrid_engine import RenderSettings
from hybrid_engine.frame.antialias import jittered_camera, render_antialiased
from hybrid_engine.frame.camera_effects import CameraEffects, LensView, lens_camera
from hybrid_engine.scene.camera import Camera, look_at
from hybrid_engine.scene.motion import MotionSteps, interpolate, shutter_interval, step_times
from hybrid_engine.scene.thin_lens import ThinLens

WIDTH, HEIGHT = 128, 64


# -- the thin lens, without Blender --------------------------------------------------------------
def test_the_aperture_radius_is_cycles_focal_length_over_twice_the_f_stop_in_metres():
    assert ThinLens.from_blender(50.0, 2.8, 5.0).radius == pytest.approx(0.05 / 5.6)
    assert ThinLens.from_blender(50.0, 2.8, 5.0, orthographic=True).radius == pytest.approx(1 / 5.6)
    assert not ThinLens.from_blender(50.0, 1e9, 5.0).active or ThinLens.from_blender(50.0, 1e9, 5.0).radius < 1e-9


@pytest.mark.parametrize("blades", [3, 5, 6])
def test_a_bladed_aperture_is_the_polygon_cycles_samples(blades):
    rotation = 0.3
    lens = ThinLens(radius=2.0, focus_distance=1.0, blades=blades, rotation=rotation)
    u, v = np.meshgrid((np.arange(64) + 0.5) / 64, (np.arange(64) + 0.5) / 64)
    points = np.array([lens.aperture_point(a, b) for a, b in zip(u.ravel(), v.ravel())])
    radius = np.hypot(points[:, 0], points[:, 1])
    angle = np.arctan2(points[:, 1], points[:, 0])
    # Corners at rotation + pi/n + 2 pi k/n on the circle of the radius; edges' middles at
    # rotation + 2 pi k / n, cos(pi/n) of the radius away.
    to_edge = np.abs((angle - rotation + np.pi / blades) % (2 * np.pi / blades) - np.pi / blades)
    along = radius * np.cos(to_edge)  # distance along the nearest edge's normal
    assert along.max() <= 2.0 * np.cos(np.pi / blades) + 1e-9
    assert along.max() > 0.97 * 2.0 * np.cos(np.pi / blades)
    assert radius.max() > 0.9 * 2.0  # the corners are reached
    assert abs(points.mean(axis=0)).max() < 0.05  # uniform: centred


def test_a_disc_aperture_squeezed_by_the_ratio_stays_within_its_ellipse():
    lens = ThinLens(radius=1.0, focus_distance=1.0, ratio=2.0)
    points = np.array([lens.aperture_point(a, b) for a in np.linspace(0, 0.999, 40) for b in np.linspace(0, 0.999, 40)])
    assert np.abs(points[:, 0]).max() <= 0.5 + 1e-9 and np.abs(points[:, 1]).max() > 0.95


def _camera(width=64, height=32) -> Camera:
    return Camera(matrix_world=look_at((1.0, -6.0, 2.0), (0.0, 0.0, 0.5)), width=width, height=height,
                  clip_start=0.1, clip_end=100.0)


def _ndc(camera, point):
    clip = camera.view_projection() @ np.append(point, 1.0)
    return clip[:2] / clip[3]


def test_a_lens_sample_sees_the_focus_plane_where_the_pinhole_does_and_the_rest_moved():
    camera = jittered_camera(_camera(), 0.25, -0.3)
    lens = ThinLens(radius=0.2, focus_distance=4.0)
    sample = lens_camera(camera, lens, (0.15, -0.1))
    rotation = camera.rotation
    assert np.allclose(sample.position, camera.position + rotation @ np.array([0.15, -0.1, 0.0]))
    assert np.allclose(sample.center, camera.position)  # the near cube stays on the lens centre
    for x, y in [(0.0, 0.0), (0.7, 0.2), (-1.0, -0.4)]:
        on_plane = camera.position + rotation @ np.array([x, y, -4.0])
        off_plane = camera.position + rotation @ np.array([x, y, -12.0])
        assert np.allclose(_ndc(sample, on_plane), _ndc(camera, on_plane), atol=1e-9)
        assert not np.allclose(_ndc(sample, off_plane), _ndc(camera, off_plane), atol=1e-3)


def test_lens_samples_keep_the_cube_map_and_bvh_of_the_lens_centre(gl):
    from benchmarks.scenes.chess import build_chess
    from hybrid_engine.frame.renderer import Renderer

    scene, camera = build_chess(0.02, 0, 48, 27)
    settings = RenderSettings(mode="HYBRID", cube_resolution=64, shadow_resolution=256, near_size=3.5,
                              max_depth=2)
    lens = ThinLens(radius=0.05, focus_distance=6.0)
    renderer = Renderer(gl)
    try:
        renderer.render(scene, camera, settings, accumulate=True)
        kept = renderer.bvh
        sample = lens_camera(camera, lens, (0.04, 0.02))
        assert isinstance(sample, LensView)
        renderer.render(scene, sample, settings, accumulate=True, sample=1, reuse_world=True)
        assert renderer.bvh is kept
    finally:
        renderer.release()


# -- motion over the shutter, without Blender ---------------------------------------------------
def test_the_shutter_opens_at_closes_at_or_straddles_the_frame():
    assert shutter_interval(0.5, "START") == (0.0, 0.5)
    assert shutter_interval(0.5, "CENTER") == (-0.25, 0.25)
    assert shutter_interval(0.5, "END") == (-0.5, 0.0)
    assert list(step_times(1.0, "CENTER", 3)) == [-0.5, 0.0, 0.5]


def test_a_turning_object_sweeps_an_arc_and_keeps_its_scale():
    def turned(angle, scale=2.0):
        m = np.eye(4)
        c, s = math.cos(angle), math.sin(angle)
        m[:3, :3] = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) * scale
        m[:3, 3] = (1.0, 0.0, 0.0)
        return m

    middle = interpolate(turned(0.0)[None], turned(math.pi / 2)[None], 0.5)[0]
    np.testing.assert_allclose(middle, turned(math.pi / 4), atol=1e-12)


def test_only_moving_instances_get_new_matrices_and_still_ones_keep_theirs_bit_for_bit():
    from hybrid_engine.scene.data import MaterialTable, SceneData
    from hybrid_engine.scene.geometry import Geometry, InstancedGeometry
    from scenes_analytic import box

    flat = Geometry.from_objects([(box((0, 0, 0), (1, 1, 1)), None, 0), (box((3, 0, 0), (4, 1, 1)), None, 0)])
    geometry = InstancedGeometry.from_world(flat)
    still = geometry.instances.matrices.astype(np.float64)
    end = still.copy()
    end[1, 0, 3] += 2.0
    motion = MotionSteps(times=[0.0, 1.0], instances=np.stack([still, end]), camera=np.stack([np.eye(4)] * 2))
    effects = CameraEffects(motion=motion, opening=0.0, closing=1.0)
    scene = SceneData(geometry=geometry, materials=MaterialTable.default())
    times = [effects.time(i) for i in range(3)]
    for index, time in enumerate(times):
        moved = effects.scene(scene, index).geometry.instances.matrices
        assert moved[0].tobytes() == geometry.instances.matrices[0].tobytes()
        assert moved[1, 0, 3] == pytest.approx(still[1, 0, 3] + 2.0 * time, abs=1e-6)
    assert len(set(np.round(times, 6))) == 3 and all(0.0 <= t <= 1.0 for t in times)


def test_a_moving_box_streaks_across_the_samples(gl):
    from hybrid_engine.frame.renderer import Renderer
    from hybrid_engine.scene.data import Lights, MaterialTable, SceneData, Sky
    from hybrid_engine.scene.geometry import Geometry, InstancedGeometry
    from scenes_analytic import box

    flat = Geometry.from_objects([(box((-0.3, -0.3, -0.3), (0.3, 0.3, 0.3)), None, 0)])
    geometry = InstancedGeometry.from_world(flat)
    materials = MaterialTable.from_rows([{"base_color": (1, 1, 1), "emission": (1, 1, 1)}])
    scene = SceneData(geometry=geometry, materials=materials, lights=Lights.empty(), sky=Sky(color=(0, 0, 0)))
    camera = Camera(matrix_world=look_at((0.0, -6.0, 0.0), (0.0, 0.0, 0.0)), width=64, height=32)
    start = geometry.instances.matrices.astype(np.float64)
    end = start.copy()
    end[0, 0, 3] = 2.0
    motion = MotionSteps(times=[-0.5, 0.5], instances=np.stack([start, end]), camera=np.stack([camera.matrix_world] * 2))
    settings = RenderSettings(mode="RASTER", shadow_resolution=256)
    renderer = Renderer(gl)
    try:
        sharp = render_antialiased(renderer, scene, camera, settings, 8).image
        blurred = render_antialiased(renderer, scene, camera, settings, 8,
                                     effects=CameraEffects(motion=motion, opening=-0.5, closing=0.5)).image
    finally:
        renderer.release()

    def lit_columns(image):
        return int((image[..., :3].mean(axis=-1).max(axis=0) > 0.05).sum())

    assert lit_columns(blurred) > lit_columns(sharp) + 10


def _emitter(bpy, name: str, strength: float = 4.0):
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    nodes = material.node_tree.nodes
    nodes.clear()
    emission = nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = strength
    output = nodes.new("ShaderNodeOutputMaterial")
    material.node_tree.links.new(emission.outputs[0], output.inputs["Surface"])
    return material


def _box(bpy, scene, name, center, half, material):
    """An axis-aligned box of half-sizes ``half`` at ``center``."""
    cx, cy, cz = center
    hx, hy, hz = half
    corners = [(cx + sx * hx, cy + sy * hy, cz + sz * hz) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(corners, [], faces)
    mesh.materials.append(material)
    obj = bpy.data.objects.new(name, mesh)
    scene.collection.objects.link(obj)
    return obj


def _dark_scene(bpy):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    world = bpy.data.worlds.new("black")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scene.world = world
    scene.view_settings.view_transform = "Standard"
    scene.render.resolution_x, scene.render.resolution_y = WIDTH, HEIGHT
    scene.render.resolution_percentage = 100
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    camera.location = (0.0, 0.0, 0.0)
    camera.rotation_euler = (math.pi / 2, 0.0, 0.0)  # looks along +Y
    scene.collection.objects.link(camera)
    scene.camera = camera
    return scene, camera


def _render_both(bpy, scene, tmp_path, cycles_samples=64, hybrid_samples=64):
    scene.render.engine = "CYCLES"
    scene.cycles.samples, scene.cycles.device = cycles_samples, "CPU"
    cycles = render_exr(bpy, scene, tmp_path / "cycles.exr")
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.render_samples = hybrid_samples
    ours = render_exr(bpy, scene, tmp_path / "ours.exr")
    return cycles, ours


def _column_profile(image, x0, x1):
    """The mean luminance of each column of the image's middle rows between x0 and x1."""
    rows = image[HEIGHT // 4: 3 * HEIGHT // 4, x0:x1, :3].mean(axis=-1)
    return rows.mean(axis=0)


def _spread(profile) -> float:
    """The standard deviation, in pixels, of a profile's weight around its mean."""
    xs = np.arange(len(profile), dtype=np.float64)
    w = np.maximum(profile - profile.min(), 0.0)
    mean = (w * xs).sum() / w.sum()
    return float(math.sqrt((w * (xs - mean) ** 2).sum() / w.sum()))


# -- through Blender's render path, against Cycles ----------------------------------------------
@pytest.mark.parametrize("sensor_fit,blades", [("AUTO", 0), ("VERTICAL", 5)])
def test_depth_of_field_blurs_off_the_focus_plane_as_wide_as_cycles_and_keeps_it_sharp(addon, tmp_path, sensor_fit,
                                                                                        blades):
    import bpy

    scene, camera = _dark_scene(bpy)
    camera.data.sensor_fit = sensor_fit  # the circle of confusion in pixels follows the sensor
    camera.data.dof.aperture_blades = blades
    camera.data.dof.aperture_rotation = 0.4
    glow = _emitter(bpy, "glow")
    _box(bpy, scene, "in focus", (-1.0, 5.0, 0.0), (0.01, 0.01, 3.0), glow)  # at the focus distance
    _box(bpy, scene, "far", (6.0, 20.0, 0.0), (0.04, 0.04, 10.0), glow)  # 15 m behind it
    camera.data.dof.use_dof = True
    camera.data.dof.focus_distance = 5.0
    camera.data.dof.aperture_fstop = 0.1  # a 25 cm aperture radius: a blur of several pixels
    cycles, ours = _render_both(bpy, scene, tmp_path)
    far_cycles, far_ours = _spread(_column_profile(cycles, 64, 128)), _spread(_column_profile(ours, 64, 128))
    near_cycles, near_ours = _spread(_column_profile(cycles, 0, 64)), _spread(_column_profile(ours, 0, 64))
    assert far_cycles > 2.0  # the oracle blurs the far bar
    assert abs(far_ours - far_cycles) <= 0.15 * far_cycles, (far_ours, far_cycles)
    assert near_ours <= near_cycles + 0.25, (near_ours, near_cycles)  # the focus plane stays sharp


def test_motion_blur_streaks_a_moving_mirror_ball_as_long_as_cycles(addon, tmp_path):
    import bpy

    scene, _camera = _dark_scene(bpy)
    _box(bpy, scene, "light", (0.0, -3.0, 0.0), (8.0, 0.1, 8.0), _emitter(bpy, "light", 2.0))  # the ball mirrors it
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.5, location=(0.0, 8.0, 0.0), segments=48, ring_count=24)
    ball = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    mirror = bpy.data.materials.new("mirror")
    mirror.use_nodes = True
    principled = mirror.node_tree.nodes["Principled BSDF"]
    principled.inputs["Metallic"].default_value = 1.0
    principled.inputs["Roughness"].default_value = 0.0
    ball.data.materials.append(mirror)
    bpy.context.preferences.edit.keyframe_new_interpolation_type = "LINEAR"
    ball.location.x = -4.0
    ball.keyframe_insert("location", frame=0)
    ball.location.x = 4.0
    ball.keyframe_insert("location", frame=2)
    scene.frame_set(1)
    scene.render.use_motion_blur = True
    scene.render.motion_blur_shutter = 0.5  # x from -1 to 1: a streak three ball widths long
    cycles, ours = _render_both(bpy, scene, tmp_path, hybrid_samples=32)

    def streak(image) -> int:
        profile = image[HEIGHT // 2 - 4: HEIGHT // 2 + 4, :, :3].mean(axis=(0, 2))
        return int((profile > 0.2 * profile.max()).sum())

    ball_width = 0.5 * 2 / (8.0 * 36.0 / 50.0) * WIDTH  # pixels at rest
    assert streak(cycles) > 2.5 * ball_width  # the oracle streaks
    assert abs(streak(ours) - streak(cycles)) <= 0.10 * streak(cycles), (streak(ours), streak(cycles))
    assert ball.location.x == pytest.approx(0.0)  # the frame's own evaluation is back


def _principled(bpy, name, color, metallic=0.0, roughness=0.5, transmission=0.0):
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    bsdf = material.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*color, 1.0)
    bsdf.inputs["Metallic"].default_value = metallic
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["Transmission Weight"].default_value = transmission
    return material


def _focus_plane_scene(bpy):
    """A glass ball on the focus plane, a mirror ball just behind it, boxes before and beyond,
    a checkered floor running from the lens into the distance: what depth of field blurs, seen
    directly, through glass and in a mirror."""
    import mathutils

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    world = bpy.data.worlds.new("sky")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.4, 0.5, 0.7, 1.0)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.6
    scene.world = world
    scene.view_settings.view_transform = "Standard"
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 128, 72, 100

    def add(operator, material, **kwargs):
        operator(**kwargs)
        obj = bpy.context.active_object
        obj.data.materials.append(material)
        return obj

    floor = _principled(bpy, "floor", (0.6, 0.6, 0.6))
    checker = floor.node_tree.nodes.new("ShaderNodeTexChecker")
    checker.inputs["Scale"].default_value = 40.0
    checker.inputs["Color1"].default_value = (0.8, 0.8, 0.8, 1.0)
    checker.inputs["Color2"].default_value = (0.1, 0.1, 0.1, 1.0)
    floor.node_tree.links.new(checker.outputs["Color"], floor.node_tree.nodes["Principled BSDF"].inputs["Base Color"])
    add(bpy.ops.mesh.primitive_plane_add, floor, size=40, location=(0, 8, 0))
    add(bpy.ops.mesh.primitive_uv_sphere_add, _principled(bpy, "mirror", (0.9, 0.9, 0.9), 1.0, 0.0), radius=0.5,
        location=(1.5, 6.5, 0.5), segments=48, ring_count=24)
    bpy.ops.object.shade_smooth()
    glass = add(bpy.ops.mesh.primitive_uv_sphere_add, _principled(bpy, "glass", (1, 1, 1), 0.0, 0.0, 1.0),
                radius=0.6, location=(0, 5, 0.6), segments=48, ring_count=24)
    bpy.ops.object.shade_smooth()
    add(bpy.ops.mesh.primitive_cube_add, _principled(bpy, "red", (0.8, 0.1, 0.1)), size=0.6, location=(-1.2, 2.5, 0.3))
    add(bpy.ops.mesh.primitive_cube_add, _principled(bpy, "green", (0.1, 0.8, 0.1)), size=1.2, location=(2.0, 9, 0.6))
    add(bpy.ops.mesh.primitive_cube_add, _principled(bpy, "blue", (0.1, 0.1, 0.8)), size=0.8, location=(-2.0, 7, 0.4))
    sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
    sun.data.energy = 3.0
    sun.rotation_euler = (0.6, 0.2, 0.5)
    scene.collection.objects.link(sun)
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    camera.location = (0.3, -0.5, 1.6)
    camera.rotation_euler = (mathutils.Vector((0, 5, 0.6)) - camera.location).to_track_quat("-Z", "Y").to_euler()
    scene.collection.objects.link(camera)
    scene.camera = camera
    camera.data.dof.use_dof = True
    camera.data.dof.focus_object = glass  # the focus plane runs through the glass ball
    camera.data.dof.aperture_fstop = 0.25
    return scene


def _eevee_in_its_own_process(bpy, path):
    """EEVEE's render of the focus-plane scene, made by another Python: EEVEE leaves
    Blender's GPU context in a state that breaks the GL work of later tests in this process."""
    import subprocess
    import sys
    from pathlib import Path

    tests = Path(__file__).resolve().parent
    code = "\n".join([
        f"import sys; sys.path[:0] = [{str(tests)!r}, {str(tests.parent)!r}]",
        "import bpy",
        "from test_camera_effects import _focus_plane_scene",
        "scene = _focus_plane_scene(bpy)",
        "scene.render.engine = 'BLENDER_EEVEE'",
        "scene.eevee.taa_render_samples, scene.eevee.use_raytracing = 32, True",
        "scene.render.image_settings.file_format = 'OPEN_EXR'",
        f"scene.render.filepath = {str(path)!r}",
        "bpy.ops.render.render(write_still=True)",
    ])
    subprocess.run([sys.executable, "-c", code], check=True, timeout=900, capture_output=True)
    image = bpy.data.images.load(str(path))
    try:
        w, h = image.size
        pixels = np.empty(w * h * 4, np.float32)
        image.pixels.foreach_get(pixels)
        return pixels.reshape(h, w, 4)
    finally:
        bpy.data.images.remove(image)


def test_depth_of_field_through_glass_and_mirrors_is_nearer_cycles_than_eevee_is(addon, tmp_path):
    """The issue's bar: FLIP to Cycles no larger than EEVEE's on a focus plane through glass
    and mirrors (without the lens, the sharp image is further from Cycles than EEVEE's)."""
    import bpy
    from whitted_reference import flip_mean

    scene = _focus_plane_scene(bpy)
    scene.render.engine = "CYCLES"
    scene.cycles.samples, scene.cycles.device = 256, "CPU"
    cycles = render_exr(bpy, scene, tmp_path / "cycles.exr")
    eevee = _eevee_in_its_own_process(bpy, tmp_path / "eevee.exr")
    assert eevee[..., :3].any(), "EEVEE rendered nothing (no GPU backend?)"
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.render_samples = 64
    ours = render_exr(bpy, scene, tmp_path / "ours.exr")
    ours_flip, eevee_flip = flip_mean(cycles, ours), flip_mean(cycles, eevee)
    assert ours_flip <= eevee_flip, (ours_flip, eevee_flip)


def test_a_moving_camera_is_seen_from_its_place_at_each_samples_time_with_its_crop_kept():
    from hybrid_engine.frame.views import region_camera

    camera = region_camera(_camera(64, 32), (8, 4, 40, 28))  # a render region: a cropped projection
    start = camera.matrix_world.copy()
    end = start.copy()
    end[:3, 3] += (1.0, 0.0, 0.5)
    motion = MotionSteps(times=[0.0, 1.0], instances=np.zeros((2, 0, 4, 4)), camera=np.stack([start, end]))
    effects = CameraEffects(motion=motion, opening=0.0, closing=1.0)
    for index in range(4):
        time = effects.time(index)
        seen = effects.camera(camera, index)
        np.testing.assert_allclose(seen.position, start[:3, 3] + time * np.array([1.0, 0.0, 0.5]), atol=1e-9)
        np.testing.assert_allclose(seen.projection_matrix(), camera.projection_matrix(), atol=1e-12)


def test_a_mesh_that_deforms_during_the_shutter_streaks_as_long_as_cycles(addon, tmp_path):
    import bpy

    scene, _camera = _dark_scene(bpy)
    bar = _box(bpy, scene, "bar", (-2.0, 8.0, 0.0), (0.3, 0.3, 0.3), _emitter(bpy, "glow", 2.0))
    bar.shape_key_add(name="Basis")
    moved = bar.shape_key_add(name="moved")
    for vertex in moved.data:
        vertex.co.x += 4.0  # the shape key carries the box 4 m along x: deformation, not motion
    bpy.context.preferences.edit.keyframe_new_interpolation_type = "LINEAR"
    moved.value = 0.0
    moved.keyframe_insert("value", frame=0)
    moved.value = 1.0
    moved.keyframe_insert("value", frame=2)
    scene.frame_set(1)
    scene.render.use_motion_blur = True
    scene.render.motion_blur_shutter = 0.5
    cycles, ours = _render_both(bpy, scene, tmp_path, cycles_samples=32, hybrid_samples=16)

    def streak(image) -> int:
        profile = image[HEIGHT // 2 - 4: HEIGHT // 2 + 4, :, :3].mean(axis=(0, 2))
        return int((profile > 0.2 * profile.max()).sum())

    assert streak(cycles) > 2.5 * 0.6 / (8.0 * 36.0 / 50.0) * WIDTH  # the oracle streaks
    assert abs(streak(ours) - streak(cycles)) <= 0.10 * streak(cycles), (streak(ours), streak(cycles))


def test_a_mesh_whose_topology_changes_during_the_shutter_is_named_once_and_one_that_moves_is_not(addon, capfd):
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=False)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = 32, 16
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.mode = "RASTER"
    scene.hybrid_rt.render_samples = 2
    scene.render.use_motion_blur = True
    cube = bpy.data.objects["Cube"]
    bpy.context.preferences.edit.keyframe_new_interpolation_type = "LINEAR"
    cube.location.x = -1.0
    cube.keyframe_insert("location", frame=0)
    cube.location.x = 1.0
    cube.keyframe_insert("location", frame=2)
    scene.frame_set(1)
    capfd.readouterr()
    bpy.ops.render.render()
    assert "Motion Blur does not" not in capfd.readouterr().out
    subdivide = cube.modifiers.new("subdivide", "SUBSURF")
    subdivide.levels = subdivide.render_levels = 2
    build = cube.modifiers.new("build", "BUILD")  # faces appear frame by frame: a new topology
    build.frame_start, build.frame_duration = 0.0, 2.0
    scene.frame_set(1)
    bpy.ops.render.render()
    out = capfd.readouterr().out
    assert out.count("Motion Blur does not blur a change of topology yet ('Cube')") == 1, out


def test_the_viewport_in_camera_view_blurs_over_its_redraws_as_the_final_render_does(addon, fed_session, tmp_path):
    import bpy
    from dataclasses import replace

    from hybrid_engine.frame.viewport import RegionInput

    session, _reports = fed_session
    adapter = addon.blender_adapter
    scene, camera = _dark_scene(bpy)
    glow = _emitter(bpy, "glow")
    _box(bpy, scene, "in focus", (-1.0, 5.0, 0.0), (0.01, 0.01, 3.0), glow)
    _box(bpy, scene, "far", (6.0, 20.0, 0.0), (0.04, 0.04, 10.0), glow)
    camera.data.dof.use_dof = True
    camera.data.dof.focus_distance = 5.0
    camera.data.dof.aperture_fstop = 0.1
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.render_samples = 32
    scene.hybrid_rt.viewport_samples = 32
    final = render_exr(bpy, scene, tmp_path / "final.exr")
    depsgraph = bpy.context.evaluated_depsgraph_get()
    view = adapter.export.camera.camera_from_scene(scene, depsgraph)
    lens = adapter.export.camera.thin_lens_from_scene(scene, depsgraph)
    settings = replace(adapter.properties.settings_from_scene(scene), denoise_viewport=False, viewport_scale=1.0)

    def redraws(region):
        for _ in range(32):
            frame = session.frame(region, settings)
        assert frame.converged
        return np.array(frame.image)

    pinhole = RegionInput(view.view_matrix(), view.projection_matrix(), WIDTH, HEIGHT, perspective="CAMERA")
    sharp = redraws(pinhole)
    blurred = redraws(replace(pinhole, lens=lens))
    final_spread = _spread(_column_profile(final, 64, 128))
    assert _spread(_column_profile(sharp, 64, 128)) < 1.0
    assert abs(_spread(_column_profile(blurred, 64, 128)) - final_spread) <= 0.15 * final_spread
