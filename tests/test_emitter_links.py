# SPDX-License-Identifier: GPL-3.0-or-later
"""Light and shadow linking of emissive objects (hybrid_engine/passes/emitters/emitter_links.py):
an emissive object's receiver collection limits what its light reaches and its blocker
collection what shadows it, in the emitters' next-event estimate (emitter_light.glsl), as
Cycles links its mesh lights; a scene without such linking compiles and renders as before."""
from __future__ import annotations

import math

import numpy as np
import pytest

from emitter_probe import EmitterProbe
from hybrid_engine import Geometry, Lights, MaterialTable, RenderSettings, SceneData, Sky
from hybrid_engine.gpu import shader_loader, variants
from hybrid_engine.passes.emitters.emitter_links import link_rows
from hybrid_engine.scene.data import ALL_LINK_SETS
from hybrid_engine.scene.light_linking import emission_linked
from scenes_analytic import quad, uv_sphere
from test_light_linking import looking_at, relative

ALL = int(ALL_LINK_SETS)
# The bar: a surface a linked emitter does not light is as dark as with it off.
WITHIN = 0.01
RADIANCE = 3.0
SAMPLES = 4096
GREY, PANEL, BLOCKER = 0, 1, 2


# --- The masks ---------------------------------------------------------------------------

def test_only_an_emissive_row_with_a_partial_mask_counts_as_linked():
    rows = [dict(name="grey", emitter_light_mask=1 << 1), dict(name="lamp", emission=(1, 1, 1))]
    assert not emission_linked(MaterialTable.from_rows(rows))  # the masked row does not emit
    rows[1]["emitter_shadow_mask"] = ALL & ~(1 << 3)
    assert emission_linked(MaterialTable.from_rows(rows))


def test_the_link_rows_hold_each_mask_as_its_low_and_high_word():
    table = MaterialTable.from_rows([dict(emitter_light_mask=(1 << 40) | 2, emitter_shadow_mask=ALL & ~1)])
    assert link_rows(table).tolist() == [[2, 1 << 8, 0xFFFF_FFFE, 0xFFFF_FFFF]]


# --- The next-event estimate, through the probe kernel ---------------------------------------
# A 1 m panel at z = 2 above the origin; a receiver point below it; a blocker plane at z = 1.

def panel_scene(light_mask: int = ALL, shadow_mask: int = ALL, blockers: int = 0) -> SceneData:
    rows = [dict(name="grey"),
            dict(name="panel", emission=(RADIANCE,) * 3, emitter_light_mask=light_mask,
                 emitter_shadow_mask=shadow_mask),
            dict(name="blocker", shadow_set=2)]
    objects = [(quad((0, 0, 2.0), (0.5, 0, 0), (0, 0.5, 0)), None, PANEL)]
    objects += [(quad((0, 0, 1.0 - 0.2 * k), (5, 0, 0), (0, 5, 0)), None, BLOCKER) for k in range(blockers)]
    return SceneData(geometry=Geometry.from_objects(objects), materials=MaterialTable.from_rows(rows))


@pytest.fixture
def probe_of(gl):
    made = []

    def make(scene: SceneData) -> EmitterProbe:
        made.append(EmitterProbe(gl, scene))
        return made[-1]

    yield make
    for probe in made:
        probe.release()


def irradiance(probe: EmitterProbe, receiver_set: int = 0) -> float:
    estimate, _ = probe.irradiance([[0.1, 0.0, 0.0]], [[0, 0, 1]], SAMPLES, seed=3, receiver_set=receiver_set)
    return float(estimate[0, 0])


def test_a_panel_lights_only_the_receiver_sets_of_its_mask(probe_of):
    free = irradiance(probe_of(panel_scene()))
    assert free > 0.1
    linked = probe_of(panel_scene(light_mask=1 << 1))
    assert linked.links.linked
    assert irradiance(linked, receiver_set=1) == pytest.approx(free, rel=1e-6)
    assert irradiance(linked, receiver_set=0) == 0.0
    assert irradiance(linked, receiver_set=33) == 0.0  # the high word
    assert irradiance(probe_of(panel_scene(light_mask=1 << 33)), receiver_set=33) == pytest.approx(free, rel=1e-6)


@pytest.mark.parametrize("blockers", [1, 3])
def test_a_panels_shadow_rays_pass_through_surfaces_that_are_not_its_blockers(probe_of, blockers):
    free = irradiance(probe_of(panel_scene()))
    assert irradiance(probe_of(panel_scene(blockers=blockers))) == 0.0  # every blocker casts by default
    passed = irradiance(probe_of(panel_scene(shadow_mask=ALL & ~(1 << 2), blockers=blockers)))
    assert passed == pytest.approx(free, rel=1e-6)
    # A blocker collection that holds the plane's set keeps its shadow.
    assert irradiance(probe_of(panel_scene(shadow_mask=(1 << 2) | 1, blockers=blockers))) == 0.0


# --- Rendering ---------------------------------------------------------------------------
# Two spheres on a floor, an emissive panel above between them (out of view), a dim fill lamp. Receivers:
# set 1 (the left sphere). Diffuse bounces 0: the left sphere's bounced light would rightly
# reach the right one.

LEFT, RIGHT = (-3.0, 0.0, 0.8), (3.0, 0.0, 0.8)
SETTINGS = dict(cube_resolution=64, shadow_resolution=256, diffuse_bounces=0, mode="HYBRID")


@pytest.fixture(params=["cpu", "gpu"])
def kernels(request):
    """Every kernel in one shape (gpu/variants.py): the CPU driver's and the GPU's."""
    variants.set_override(f"*={request.param}")
    yield request.param
    variants.set_override(None)


def spheres_and_panel(*, emit: bool = True, linked: bool = False, light_mask: int | None = None,
                      shadow_mask: int = ALL, left_blocker_set: int = 0) -> SceneData:
    left, left_n = uv_sphere(LEFT, 0.8, 24, 12)
    right, right_n = uv_sphere(RIGHT, 0.8, 24, 12)
    rows = [dict(name="floor", base_color=(0.5, 0.5, 0.5)),
            dict(name="left", base_color=(0.8, 0.3, 0.2), light_set=1 if linked else 0,
                 shadow_set=left_blocker_set),
            dict(name="right", base_color=(0.2, 0.4, 0.8)),
            dict(name="panel", emission=(60.0,) * 3 if emit else (0.0,) * 3,
                 emitter_light_mask=(1 << 1) if linked else (ALL if light_mask is None else light_mask),
                 emitter_shadow_mask=shadow_mask)]
    geometry = Geometry.from_objects([(quad((0, 0, 0), (8, 0, 0), (0, 8, 0)), None, 0), (left, left_n, 1),
                                      (right, right_n, 2), (quad((0, 0.0, 5.5), (1, 0, 0), (0, 1, 0)), None, 3)])
    lamps = [dict(kind="POINT", position=(0.0, -1.0, 5.0), color=(300.0,) * 3, radius=0.1, name="fill")]
    return SceneData(geometry, MaterialTable.from_rows(rows), Lights.from_rows(lamps), Sky(color=(0.02, 0.02, 0.02)))


def render(renderer, scene, camera, samples: int = 2, **settings) -> np.ndarray:
    result = None
    for k in range(samples):
        result = renderer.render(scene, camera, RenderSettings(**{**SETTINGS, **settings}), accumulate=True,
                                 sample=k, read_image=k == samples - 1)
    return result.image[..., :3].astype(np.float64)


def test_a_panel_linked_to_one_sphere_leaves_the_other_as_dark_as_with_the_panel_off(renderer, kernels):
    camera = looking_at(RIGHT)
    on = render(renderer, spheres_and_panel(), camera)
    off = render(renderer, spheres_and_panel(emit=False), camera)
    linked = render(renderer, spheres_and_panel(linked=True), camera)
    lit = np.abs(on - off).sum(axis=-1) > 0.05  # what the panel lights: the right sphere, the floor
    assert lit.sum() > 500 and relative(on, off, lit) > 0.5
    assert relative(linked, off, lit) < WITHIN


def test_the_linked_sphere_keeps_the_panels_light(renderer):
    camera = looking_at(LEFT)
    on = render(renderer, spheres_and_panel(), camera)
    off = render(renderer, spheres_and_panel(emit=False), camera)
    linked = render(renderer, spheres_and_panel(linked=True), camera)
    left = np.abs(linked - off).sum(axis=-1) > 0.05  # what the panel still lights: the left sphere
    lit = np.abs(on - off).sum(axis=-1) > 0.05
    assert left.sum() > 100 and (lit & ~left).sum() > left.sum()  # unlinked it lit the floor too
    assert relative(linked, on, left) < WITHIN


def test_a_blocker_mask_without_the_spheres_set_takes_its_shadow_away(renderer):
    # Seen from above the left sphere: its shadow from the panel on the floor. The left
    # sphere is in blocker set 1.
    camera = looking_at((-3.0, 0.5, 0.0), eye=(-3.0, -3.0, 7.0))
    shadowed = render(renderer, spheres_and_panel(left_blocker_set=1), camera)
    left_out = render(renderer, spheres_and_panel(shadow_mask=ALL & ~(1 << 1), left_blocker_set=1), camera)
    kept = render(renderer, spheres_and_panel(shadow_mask=(1 << 1) | 1, left_blocker_set=1), camera)
    gained = (left_out - shadowed).sum(axis=-1) > 0.05  # where the sphere's shadow was
    assert gained.sum() > 50 and relative(left_out, shadowed, gained) > 0.3
    assert (left_out - shadowed).min() > -1e-3  # only light given back
    assert relative(kept, shadowed, gained) < WITHIN  # a mask with its set keeps the shadow


def mirror_and_panel(*, emit: bool = True, linked: bool = False, floor_receives: bool = False) -> SceneData:
    """A mirror floor reflecting a panel above it; the panel lights set 1 when linked, which
    the floor is in when it receives."""
    rows = [dict(name="mirror", base_color=(0.9, 0.9, 0.9), reflectivity=1.0, light_set=1 if floor_receives else 0),
            dict(name="panel", emission=(5.0,) * 3 if emit else (0.0,) * 3,
                 emitter_light_mask=(1 << 1) if linked else ALL),
            dict(name="receiver", light_set=1)]  # an object in set 1, so that the set exists
    geometry = Geometry.from_objects([(quad((0, 0, 0), (8, 0, 0), (0, 8, 0)), None, 0),
                                      (quad((0, 0.0, 1.5), (1, 0, 0), (0, 1, 0)), None, 1),
                                      (uv_sphere((5.0, 5.0, 1.0), 0.5, 12, 6)[0], None, 2)])
    lamps = [dict(kind="POINT", position=(0.0, -3.0, 4.0), color=(100.0,) * 3, radius=0.1, name="fill")]
    return SceneData(geometry, MaterialTable.from_rows(rows), Lights.from_rows(lamps), Sky(color=(0.02, 0.02, 0.02)))


@pytest.mark.parametrize("near_size,lit_cube", [(30.0, False), (1.0, False), (1.0, True)],
                         ids=["bvh_hit", "cube_map_hit", "lit_cube_map"])
def test_a_mirror_outside_the_receivers_does_not_show_the_linked_panel(renderer, kernels, near_size, lit_cube):
    # As Cycles: a reflection ray finds a linked emitter's emission only where it lights the
    # surface the ray left. The lit cube map is read filtered: a linked panel's emission kept
    # in its texels would spill into the texels beside its edge, which no material's emission
    # takes away.
    assert_the_floor_reflects_the_linked_panel_only_as_its_receiver(renderer, mirror_and_panel,
                                                                    near_size=near_size, lit_cube=lit_cube)


def assert_the_floor_reflects_the_linked_panel_only_as_its_receiver(renderer, scene_of, **settings) -> None:
    """The camera looks down at the floor of ``scene_of`` (mirror_and_panel's arguments), the
    panel's reflection in view: linked, the floor shows it only when it is a receiver."""
    camera = looking_at((0.0, 0.0, -1.5), eye=(0.0, -6.0, 1.2))
    on = render(renderer, scene_of(), camera, **settings)
    off = render(renderer, scene_of(emit=False), camera, **settings)
    seen = np.abs(on - off).sum(axis=-1) > 0.05
    assert seen.sum() > 100 and relative(on, off, seen) > 0.5
    linked = render(renderer, scene_of(linked=True), camera, **settings)
    assert relative(linked, off, seen) < WITHIN
    receiving = render(renderer, scene_of(linked=True, floor_receives=True), camera, **settings)
    assert relative(receiving, on, seen) < WITHIN


def rough_metal_and_panel(*, emit: bool = True, linked: bool = False, floor_receives: bool = False) -> SceneData:
    """mirror_and_panel with a rough metal floor, too rough for the tracer: what it reflects
    comes from the diffuse-light pass's paths along its lobe (diffuse_gather.comp.glsl)."""
    scene = mirror_and_panel(emit=emit, linked=linked, floor_receives=floor_receives)
    rows = [dict(name="metal", base_color=(0.9, 0.9, 0.9), reflectivity=1.0, roughness=0.7,
                 light_set=1 if floor_receives else 0),
            dict(name="panel", emission=(5.0,) * 3 if emit else (0.0,) * 3,
                 emitter_light_mask=(1 << 1) if linked else ALL),
            dict(name="receiver", light_set=1)]
    return SceneData(scene.geometry, MaterialTable.from_rows(rows), scene.lights, scene.sky)


@pytest.mark.parametrize("near_size", [30.0, 1.0], ids=["bvh_hit", "cube_map_hit"])
def test_a_rough_metal_outside_the_receivers_does_not_show_the_linked_panel(renderer, kernels, near_size):
    # The diffuse-light pass's paths along a rough metal's lobe meet the panel: its emission
    # counts only where it lights the surface the path left, as a reflection ray's does.
    assert_the_floor_reflects_the_linked_panel_only_as_its_receiver(renderer, rough_metal_and_panel,
                                                                    near_size=near_size)


def walled_panel(*, emit: bool = True, linked: bool = False) -> SceneData:
    """A mirror floor, a grey wall behind it, a panel in front of the wall lighting it; the
    panel lights only set 1 when linked, which neither the wall nor the floor is in."""
    rows = [dict(name="mirror", base_color=(0.9, 0.9, 0.9), reflectivity=1.0),
            dict(name="panel", emission=(20.0,) * 3 if emit else (0.0,) * 3,
                 emitter_light_mask=(1 << 1) if linked else ALL),
            dict(name="wall", base_color=(0.8, 0.8, 0.8)),
            dict(name="receiver", light_set=1)]
    geometry = Geometry.from_objects([(quad((0, 0, 0), (8, 0, 0), (0, 8, 0)), None, 0),
                                      (quad((0, 2.0, 1.0), (0.5, 0, 0), (0, 0, 0.5)), None, 1),
                                      (quad((0, 3.0, 1.5), (4, 0, 0), (0, 0, 1.5)), None, 2),
                                      (uv_sphere((5.0, -5.0, 1.0), 0.5, 12, 6)[0], None, 3)])
    lamps = [dict(kind="POINT", position=(0.0, -3.0, 4.0), color=(50.0,) * 3, radius=0.1, name="fill")]
    return SceneData(geometry, MaterialTable.from_rows(rows), Lights.from_rows(lamps), Sky(color=(0.02, 0.02, 0.02)))


def walled_panel_itself(renderer, camera) -> np.ndarray:
    """The pixels of walled_panel's panel, which the camera sees whatever its linking (RASTER
    draws no light from emitters, only their emission), and its edges' anti-aliasing."""
    panel = np.abs(render(renderer, walled_panel(), camera, mode="RASTER")
                   - render(renderer, walled_panel(emit=False), camera, mode="RASTER")).sum(axis=-1) > 1e-3
    panel = np.pad(panel, 1)
    return panel[1:-1, 1:-1] | panel[:-2, 1:-1] | panel[2:, 1:-1] | panel[1:-1, :-2] | panel[1:-1, 2:]


@pytest.mark.parametrize("near_size", [30.0, 1.0], ids=["bvh_hit", "cube_map_hit"])
def test_the_gather_rays_of_a_reflected_wall_find_a_linked_panel_only_for_its_receivers(renderer, kernels,
                                                                                         near_size):
    # The mirror floor reflects the wall; the wall's diffuse light in the reflection is one
    # gather ray per sample (the tracer's first bounce, trace_ray.glsl gather_light), which
    # meets the panel in front of it: its emission counts only for the receivers.
    camera = looking_at((0.0, 3.0, -1.0), eye=(0.0, -4.0, 0.6))
    settings = dict(near_size=near_size, lit_cube=False, ao_distance=10.0)
    on, off, linked = (render(renderer, walled_panel(**kw), camera, samples=6, **settings)
                       for kw in (dict(), dict(emit=False), dict(linked=True)))
    lit = (np.abs(on - off).sum(axis=-1) > 0.05) & ~walled_panel_itself(renderer, camera)
    assert lit.sum() > 100 and on[lit].mean() > 2 * off[lit].mean()
    assert relative(linked, off, lit) < WITHIN, (linked[lit].mean(), off[lit].mean())


def test_the_lit_cube_maps_bounces_carry_a_linked_panels_light_only_to_its_receivers(renderer, kernels):
    # Everything lies in the cube map (near cube 1 m); the camera sees the wall's reflection
    # in the mirror floor, lit by the panel only through the lit cube map's gathered bounces,
    # and the panel's own reflection, its emission where linked taken away.
    camera = looking_at((0.0, 3.0, -1.0), eye=(0.0, -4.0, 0.6))
    settings = dict(near_size=1.0, lit_cube=True, ao_distance=10.0)

    def fresh(scene: SceneData) -> np.ndarray:
        """A render whose lit cube map starts over: its bounces carry frame to frame, and its
        gather draws the same numbers as every other render that starts it over."""
        if renderer.cube_light is not None:
            renderer.cube_light.forget()
        return render(renderer, scene, camera, samples=6, **settings)

    on, off, linked = fresh(walled_panel()), fresh(walled_panel(emit=False)), fresh(walled_panel(linked=True))
    lit = (np.abs(on - off).sum(axis=-1) > 0.05) & ~walled_panel_itself(renderer, camera)
    assert lit.sum() > 100 and on[lit].mean() > 2 * off[lit].mean()
    # The same gathered rays as with the panel off: the panel lights set 1 only, so what the
    # wall and the panel reflect is what they reflect with it off (a linked emission kept in
    # the map's float16 texels and taken off again would leave the panel's reflected light
    # to their rounding).
    assert relative(linked, off, lit) < WITHIN, (linked[lit].mean(), off[lit].mean())


def test_a_scene_without_emitter_linking_compiles_none_and_renders_the_same_image(renderer, monkeypatch):
    used: list[dict] = []  # the defines of every program a frame asks the loader for
    original = shader_loader._compile

    def recording(ctx, stages, defines):
        used.append(dict(defines or {}))
        return original(ctx, stages, defines)

    camera = looking_at(RIGHT, width=32, height=20)
    plain = spheres_and_panel()
    first = render(renderer, plain, camera)
    monkeypatch.setattr(shader_loader, "_compile", recording)
    # Masks given as "every set" are no linking: the same programs, the same image bit for bit.
    explicit = render(renderer, spheres_and_panel(light_mask=ALL), camera)
    assert not any("EMITTER_LINKING" in d for d in used)
    assert np.array_equal(first, explicit)
    render(renderer, spheres_and_panel(linked=True), camera)
    assert any("EMITTER_LINKING" in d for d in used)


# --- Through Blender's render path, against Cycles ------------------------------------------
# test_light_linking's two spheres, the key lamp hidden; an emissive panel above lights them.
# Direct light only in both engines (Diffuse Bounces 0): the lit sphere's bounce would rightly
# reach the other. Default samples.

def _panel_scene(bpy):
    from test_light_linking import _blender_scene

    scene, spheres, (key, _fill) = _blender_scene(bpy)
    key.hide_render = True
    bpy.ops.mesh.primitive_plane_add(size=2.0, location=(0.0, -1.5, 4.5))
    panel = bpy.context.object
    panel.name = "panel"
    material = bpy.data.materials.new("glow")
    material.use_nodes = True
    bsdf = material.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    bsdf.inputs["Emission Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    bsdf.inputs["Emission Strength"].default_value = 60.0
    panel.data.materials.append(material)
    scene.hybrid_rt.world_light = "RAYS"
    scene.hybrid_rt.diffuse_bounces = 0
    scene.cycles.diffuse_bounces = 0
    return scene, spheres, panel, bsdf


def test_a_panels_receiver_linking_renders_as_cycles_renders_it(addon, tmp_path):
    import bpy
    from test_light_linking import _both, _linked_collection

    scene, (left, right), panel, bsdf = _panel_scene(bpy)
    panel.light_linking.receiver_collection = _linked_collection(bpy, "receivers", [left])
    ours, cycles = _both(bpy, scene, tmp_path, "linked")
    bsdf.inputs["Emission Strength"].default_value = 0.0
    ours_off, cycles_off = _both(bpy, scene, tmp_path, "off")
    half = ours.shape[1] // 2
    # The right sphere's half: as dark as with the panel's emission off (the bar);
    # Cycles agrees.
    assert relative(ours[:, half:], ours_off[:, half:]) < WITHIN
    assert relative(cycles[:, half:], cycles_off[:, half:]) < WITHIN
    # The left sphere keeps the panel's light, as much of it as Cycles gives it.
    lit = np.abs(cycles - cycles_off).sum(axis=-1) > 0.05
    assert lit[:, :half].sum() > 100
    gain, gain_cycles = (ours - ours_off)[lit].mean(), (cycles - cycles_off)[lit].mean()
    assert abs(gain - gain_cycles) < 0.05 * gain_cycles, (gain, gain_cycles)


def test_a_panels_blocker_linking_renders_as_cycles_renders_it(addon, tmp_path):
    import bpy
    from test_light_linking import _both, _linked_collection

    scene, (left, right), panel, _bsdf = _panel_scene(bpy)
    # Seen from above, on a lighter floor: a small bright panel in front casts each sphere's
    # shadow back onto the floor.
    scene.camera.location, scene.camera.rotation_euler = (0.0, -9.0, 8.0), (math.radians(48.0), 0.0, 0.0)
    panel.location, panel.scale = (0.0, -3.0, 5.0), (0.5, 0.5, 0.5)
    _bsdf.inputs["Emission Strength"].default_value = 200.0
    floor = bpy.data.objects["Plane"].data.materials[0].node_tree.nodes["Principled BSDF"]
    floor.inputs["Base Color"].default_value = (0.5, 0.5, 0.5, 1.0)
    ours_shadowed, cycles_shadowed = _both(bpy, scene, tmp_path, "shadowed")
    # Only the right sphere shadows the panel's light: the left one casts none.
    panel.light_linking.blocker_collection = _linked_collection(bpy, "blockers", [right])
    ours, cycles = _both(bpy, scene, tmp_path, "linked")
    half = ours.shape[1] // 2
    shadow = (cycles - cycles_shadowed).sum(axis=-1) > 0.05  # what the left sphere's shadow took
    assert shadow[:, :half].sum() > 100
    # The light given back, summed over the left half, as much as Cycles gives back.
    gain, gain_cycles = (ours - ours_shadowed)[:, :half].sum(), (cycles - cycles_shadowed)[:, :half].sum()
    assert abs(gain - gain_cycles) < 0.1 * gain_cycles, (gain, gain_cycles)
    # The floor where the shadow was, as bright as Cycles has it (means: Cycles' own noise
    # would dominate a pixel-wise difference). Its level also carries the floor's bounced
    # light, whose own error against Cycles is a few percent here; the linking itself is the
    # gain above.
    assert abs(ours[shadow].mean() - cycles[shadow].mean()) < 0.06 * cycles[shadow].mean()
    # The right sphere still shadows the floor from the panel: its half is unchanged.
    assert relative(ours[:, half:], ours_shadowed[:, half:]) < WITHIN
