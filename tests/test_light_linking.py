# SPDX-License-Identifier: GPL-3.0-or-later
"""Light and shadow linking (hybrid_engine/scene/light_linking.py): Blender's light sets, a
lamp that lights only its receivers wherever a surface is shaded (the primary G-buffer, a
mirror's BVH hit, a cube-map hit), a shadow map that holds only its lamp's blockers, and no
new shader for a scene without linking."""
from __future__ import annotations

import math

import numpy as np
import pytest

from hybrid_engine import Camera, Geometry, Lights, MaterialTable, RenderSettings, SceneData, Sky
from hybrid_engine.gpu import shader_loader, variants
from hybrid_engine.scene.camera import look_at
from hybrid_engine.scene.data import ALL_LINK_SETS
from hybrid_engine.scene.light_linking import EXCLUDE, INCLUDE, is_linked, resolve
from scenes_analytic import quad, uv_sphere

ALL = int(ALL_LINK_SETS)
# The bar: a surface a linked lamp does not light is as dark as with the lamp off.
WITHIN = 0.01
SETTINGS = dict(cube_resolution=64, shadow_resolution=256, world_light="SCREEN", ao_distance=0.0)


# --- Blender's light sets -------------------------------------------------------------------

def test_an_include_collection_lights_only_its_objects_and_not_the_default_set():
    sets = resolve(["receivers", None], {"receivers": [("a", INCLUDE)]})
    assert sets.object_sets == {"a": 1}
    assert sets.emitter_masks[0] == 1 << 1  # set 1 only: objects in no entry (set 0) are left out
    assert sets.emitter_masks[1] == ALL  # a lamp without a collection lights every set


def test_an_exclude_only_collection_lights_everything_else():
    sets = resolve(["receivers"], {"receivers": [("b", EXCLUDE)]})
    assert sets.object_sets == {"b": 1}
    assert sets.emitter_masks[0] == ALL & ~(1 << 1)


def test_objects_with_the_same_linking_share_a_set_and_lamps_sharing_a_collection_share_a_mask():
    sets = resolve(["c", "c", "d"], {"c": [("a", INCLUDE), ("b", INCLUDE)], "d": [("a", EXCLUDE)]})
    assert sets.object_sets["b"] != sets.object_sets["a"]  # a is also excluded by d
    assert sets.emitter_masks[0] == sets.emitter_masks[1]
    a, b = 1 << sets.object_sets["a"], 1 << sets.object_sets["b"]
    assert sets.emitter_masks[0] == a | b
    assert sets.emitter_masks[2] == ALL & ~a


def test_a_later_entry_of_the_same_object_wins():
    sets = resolve(["c"], {"c": [("a", INCLUDE), ("a", EXCLUDE)]})
    assert sets.emitter_masks[0] == ALL & ~(1 << sets.object_sets["a"])


def test_past_64_sets_the_extra_objects_stay_in_the_default_set():
    members = {f"c{i}": [(f"o{i}", INCLUDE)] for i in range(70)}
    sets = resolve(list(members), members)
    assert sets.overflow
    assert len(set(sets.object_sets.values())) == 63  # sets 1..63; 0 is the default
    assert "o69" not in sets.object_sets and sets.object_sets["o0"] == 1
    assert resolve(["c0"], members).overflow is False


# --- Rendering -----------------------------------------------------------------------------
# Two spheres on a floor; the key lamp is linked to the left sphere only (its receiver set 1)
# and a fill lamp lights everything, so that a surface the key lamp skips is not black.

LEFT, RIGHT = (-3.0, 0.0, 0.8), (3.0, 0.0, 0.8)


@pytest.fixture(params=["cpu", "gpu"])
def kernels(request):
    """Every kernel in one shape (gpu/variants.py): the CPU driver's and the GPU's (the wave
    tracer, instanced shadow draws, a point lamp's six faces in one multi-draw)."""
    variants.set_override(f"*={request.param}")
    yield request.param
    variants.set_override(None)


def two_spheres(*, key: bool = True, light_linked: bool = False, shadow_linked: bool = False,
                mirror: bool = False, key_shadow: bool = True) -> SceneData:
    left, left_n = uv_sphere(LEFT, 0.8, 24, 12)
    right, right_n = uv_sphere(RIGHT, 0.8, 24, 12)
    floor = quad((0, 0, 0), (8, 0, 0), (0, 8, 0))
    rows = [dict(name="floor", base_color=(0.5, 0.5, 0.5), reflectivity=1.0 if mirror else 0.0),
            dict(name="left", base_color=(0.8, 0.3, 0.2), light_set=1 if light_linked else 0,
                 shadow_set=1 if shadow_linked else 0),
            dict(name="right", base_color=(0.2, 0.4, 0.8))]
    geometry = Geometry.from_objects([(floor, None, 0), (left, left_n, 1), (right, right_n, 2)])
    lamps = [dict(kind="POINT", position=(0.0, -1.0, 5.0), color=(600.0, 600.0, 600.0), radius=0.1,
                  name="fill")]
    if key:
        # Receivers: set 1 (the left sphere). Blockers: every set but 1 (the left sphere's
        # shadow is left out).
        lamps.append(dict(kind="POINT", position=(0.0, -3.0, 4.0), color=(1500.0, 1500.0, 1500.0), radius=0.1,
                          name="key", cast_shadow=key_shadow,
                          light_mask=(1 << 1) if light_linked else ALL,
                          shadow_mask=(ALL & ~(1 << 1)) if shadow_linked else ALL))
    return SceneData(geometry, MaterialTable.from_rows(rows), Lights.from_rows(lamps), Sky(color=(0.02, 0.02, 0.02)))


def looking_at(target, eye=(0.0, -9.0, 5.0), width=64, height=40) -> Camera:
    return Camera(matrix_world=look_at(eye, target), width=width, height=height)


def render(renderer, scene, camera, **settings):
    return renderer.render(scene, camera, RenderSettings(**{**SETTINGS, **settings})).image[..., :3].astype(np.float64)


def relative(a, b, where=None) -> float:
    """Mean absolute difference over the mean, on the pixels ``where`` selects."""
    where = np.ones(a.shape[:2], bool) if where is None else where
    return float(np.abs(a - b)[where].mean() / max(b[where].mean(), 1e-9))


def sphere_pixels(renderer, scene, camera) -> np.ndarray:
    """Where the right sphere is in view: the pixels that change when it turns black."""
    black = SceneData(scene.geometry, MaterialTable.from_rows(
        [dict(name="floor", base_color=(0.5, 0.5, 0.5), reflectivity=float(scene.materials.reflectivity[0])),
         dict(name="left", base_color=(0.8, 0.3, 0.2)), dict(name="right", base_color=(0.0, 0.0, 0.0))]),
        scene.lights, scene.sky)
    diff = np.abs(render(renderer, scene, camera, mode="RASTER") - render(renderer, black, camera, mode="RASTER"))
    return diff.sum(axis=-1) > 1e-3


@pytest.mark.parametrize("mode", ["RASTER", "HYBRID"])
def test_a_lamp_linked_to_one_sphere_leaves_the_other_as_dark_as_with_the_lamp_off(renderer, mode):
    camera = looking_at(RIGHT)
    linked = render(renderer, two_spheres(light_linked=True), camera, mode=mode)
    off = render(renderer, two_spheres(key=False), camera, mode=mode)
    on = render(renderer, two_spheres(), camera, mode=mode)
    right = sphere_pixels(renderer, two_spheres(), camera)
    assert right.sum() > 100
    assert relative(on, off, right) > 0.3  # the key lamp lights the right sphere when unlinked
    assert relative(linked, off, right) < WITHIN
    # The floor is in no collection: the key lamp (with INCLUDE entries) leaves it out too.
    assert relative(linked, off) < WITHIN


def test_the_linked_sphere_keeps_the_linked_lamps_light(renderer):
    camera = looking_at(LEFT)
    linked = render(renderer, two_spheres(light_linked=True), camera, mode="RASTER")
    on = render(renderer, two_spheres(), camera, mode="RASTER")
    off = render(renderer, two_spheres(key=False), camera, mode="RASTER")
    lit = np.abs(on - off).sum(axis=-1) > 0.05
    left = np.abs(linked - off).sum(axis=-1) > 0.05  # what the key lamp still lights: the left sphere
    assert left.sum() > 100
    assert relative(linked, on, left) < WITHIN
    assert (lit & ~left).sum() > left.sum()  # unlinked it lit the floor as well


@pytest.mark.parametrize("near_size", [30.0, 1.0], ids=["bvh_hit", "cube_map_hit"])
def test_a_mirror_shows_the_unlinked_sphere_as_dark_as_with_the_lamp_off(renderer, kernels, near_size):
    # The floor is a mirror; the camera sees the right sphere's reflection in it. With a near
    # cube of 30 m the reflected rays hit the sphere in the BVH; with 1 m, in the cube map.
    camera = looking_at((3.0, 0.0, -0.8), eye=(3.0, -6.0, 1.2))
    settings = dict(mode="HYBRID", near_size=near_size)
    linked = render(renderer, two_spheres(light_linked=True, mirror=True), camera, **settings)
    off = render(renderer, two_spheres(key=False, mirror=True), camera, **settings)
    on = render(renderer, two_spheres(mirror=True), camera, **settings)
    seen = np.abs(on - off).sum(axis=-1) > 0.02
    assert seen.sum() > 100 and relative(on, off, seen) > 0.3
    assert relative(linked, off, seen) < WITHIN


def test_the_lit_cube_map_leaves_the_unlinked_sphere_dark(renderer):
    camera = looking_at((3.0, 0.0, -0.8), eye=(3.0, -6.0, 1.2))
    # No gathered bounces (AO Distance 0): the left sphere's bounced light would rightly
    # differ between the linked lamp and no lamp.
    settings = dict(mode="HYBRID", near_size=1.0, lit_cube=True)
    linked = render(renderer, two_spheres(light_linked=True, mirror=True), camera, **settings)
    off = render(renderer, two_spheres(key=False, mirror=True), camera, **settings)
    on = render(renderer, two_spheres(mirror=True), camera, **settings)
    seen = np.abs(on - off).sum(axis=-1) > 0.02
    assert seen.sum() > 100 and relative(on, off, seen) > 0.3
    assert relative(linked, off, seen) < WITHIN


def test_a_shadow_map_holds_only_its_lamps_blockers(renderer, kernels):
    camera = looking_at((-3.0, 1.5, 0.0), eye=(-3.0, -4.0, 6.0))
    linked = render(renderer, two_spheres(shadow_linked=True), camera, mode="RASTER")
    unshadowed = render(renderer, two_spheres(key_shadow=False), camera, mode="RASTER")
    shadowed = render(renderer, two_spheres(), camera, mode="RASTER")
    floor = np.abs(shadowed - unshadowed).sum(axis=-1) > 0.05  # the left sphere's shadow
    assert floor.sum() > 50
    assert relative(linked, unshadowed, floor) < WITHIN
    # A blocker collection that includes the left sphere keeps its shadow.
    blocking = two_spheres(shadow_linked=True)
    blocking.lights.shadow_mask[1] = np.uint64(1 << 1)
    assert relative(render(renderer, blocking, camera, mode="RASTER"), shadowed, floor) < WITHIN


def test_editing_the_blockers_renders_the_shadow_map_again(renderer):
    camera = looking_at((-3.0, 1.5, 0.0), eye=(-3.0, -4.0, 6.0))
    shadowed = render(renderer, two_spheres(), camera, mode="RASTER")
    linked = render(renderer, two_spheres(shadow_linked=True), camera, mode="RASTER")  # same geometry
    assert relative(linked, shadowed) > 0.02


def test_a_scene_without_linking_compiles_no_linking_variant(renderer, monkeypatch):
    used: list[dict] = []  # the defines of every program a frame asks the loader for
    original = shader_loader._compile

    def recording(ctx, stages, defines):
        used.append(dict(defines or {}))
        return original(ctx, stages, defines)

    monkeypatch.setattr(shader_loader, "_compile", recording)
    camera = looking_at(RIGHT, width=24, height=16)
    plain = two_spheres()
    assert not is_linked(plain.materials, plain.lights)
    for mode in ("RASTER", "HYBRID"):
        render(renderer, plain, camera, mode=mode, lit_cube=True)
    assert used and not any("LIGHT_LINKING" in d for d in used)
    used.clear()
    render(renderer, two_spheres(light_linked=True), camera, mode="HYBRID", lit_cube=True)
    assert any("LIGHT_LINKING" in d for d in used)


# --- Through Blender's render path, against Cycles ------------------------------------------
# Two spheres on a dark floor, seen from the front: the left one in the image's left half,
# the right one in its right half. A key lamp above, a fill lamp so that nothing is black.

def _blender_scene(bpy):
    from test_engine import _diffuse_material

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=40)
    bpy.context.object.data.materials.append(_diffuse_material(bpy, (0.05, 0.05, 0.05)))
    spheres = []
    for name, x in (("left", -2.5), ("right", 2.5)):
        bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0, location=(x, 0.0, 1.0), segments=32, ring_count=16)
        sphere = bpy.context.object
        sphere.name = name
        bpy.ops.object.shade_smooth()
        sphere.data.materials.append(_diffuse_material(bpy, (0.8, 0.8, 0.8)))
        spheres.append(sphere)
    lamps = []
    for name, location, energy in (("key", (0.0, -2.0, 5.0), 1500.0), ("fill", (0.0, -8.0, 2.0), 300.0)):
        light = bpy.data.lights.new(name, "POINT")
        light.energy, light.shadow_soft_size = energy, 0.1
        lamp = bpy.data.objects.new(name, light)
        lamp.location = location
        scene.collection.objects.link(lamp)
        lamps.append(lamp)
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    camera.location = (0.0, -10.0, 3.0)
    camera.rotation_euler = (math.radians(80.0), 0.0, 0.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    world = bpy.data.worlds.new("world")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scene.world = world
    scene.render.resolution_x, scene.render.resolution_y = 96, 48
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.cycles.samples, scene.cycles.device = 64, "CPU"
    # No bounced light in our render: the lit sphere's bounce would rightly reach the other.
    scene.hybrid_rt.world_light = "SCREEN"
    return scene, spheres, lamps


def _both(bpy, scene, tmp_path, name):
    from test_engine import render_exr

    scene.render.engine = "CYCLES"
    cycles = render_exr(bpy, scene, tmp_path / f"{name}_cycles.exr")[..., :3].astype(np.float64)
    scene.render.engine = "HYBRID_RT"
    ours = render_exr(bpy, scene, tmp_path / f"{name}_ours.exr")[..., :3].astype(np.float64)
    return ours, cycles


def _linked_collection(bpy, name, objects, state="INCLUDE"):
    collection = bpy.data.collections.new(name)
    for obj in objects:
        collection.objects.link(obj)
    for entry in collection.collection_objects:
        entry.light_linking.link_state = state
    return collection


def test_receiver_linking_renders_as_cycles_renders_it(addon, tmp_path):
    import bpy

    scene, (left, right), (key, _fill) = _blender_scene(bpy)
    key.light_linking.receiver_collection = _linked_collection(bpy, "receivers", [left])
    ours, cycles = _both(bpy, scene, tmp_path, "linked")
    key.hide_render = True
    ours_off, cycles_off = _both(bpy, scene, tmp_path, "off")
    half = ours.shape[1] // 2
    # The right sphere's half: as dark as with the key lamp off (the bar), in Cycles too.
    assert relative(ours[:, half:], ours_off[:, half:]) < WITHIN
    # Cycles agrees: the key lamp adds to the right half only the left sphere's bounced light.
    assert (cycles - cycles_off)[:, half:].mean() < 0.05 * (cycles - cycles_off)[:, :half].mean()
    # The left sphere keeps the key lamp's light, as much of it as Cycles gives it.
    lit = np.abs(cycles - cycles_off).sum(axis=-1) > 0.05
    assert lit[:, :half].sum() > 100
    gain, gain_cycles = (ours - ours_off)[lit].mean(), (cycles - cycles_off)[lit].mean()
    assert abs(gain - gain_cycles) < 0.1 * gain_cycles, (gain, gain_cycles)


def test_blocker_linking_renders_as_cycles_renders_it(addon, tmp_path):
    import bpy

    scene, (left, right), (key, _fill) = _blender_scene(bpy)
    # The key lamp's shadow comes from the right sphere only: the left one casts none.
    ours_shadowed, cycles_shadowed = _both(bpy, scene, tmp_path, "shadowed")
    key.light_linking.blocker_collection = _linked_collection(bpy, "blockers", [right])
    ours, cycles = _both(bpy, scene, tmp_path, "linked")
    half = ours.shape[1] // 2
    shadow = (cycles - cycles_shadowed).sum(axis=-1) > 0.05  # what the left sphere's shadow took
    assert shadow[:, :half].sum() > 20
    gain, gain_cycles = (ours - ours_shadowed)[shadow].mean(), (cycles - cycles_shadowed)[shadow].mean()
    assert abs(gain - gain_cycles) < 0.15 * gain_cycles, (gain, gain_cycles)
    # The right sphere still shadows the floor from the key lamp: its half is unchanged.
    assert relative(ours[:, half:], ours_shadowed[:, half:]) < WITHIN
