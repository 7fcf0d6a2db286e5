# SPDX-License-Identifier: GPL-3.0-or-later
"""The Sky Texture's scattering models (include/nodes/tex_sky.glsl, sky_atmosphere.glsl,
sky_single.glsl), their transmittance tables (passes/lighting/sky_tables.py) and the sun
disc as a lamp (scene/sky_sun.py); against Cycles through Blender's render path at the end."""
from __future__ import annotations

import math

import numpy as np
import pytest

from hybrid_engine.passes.lighting.world_bake import WorldBake
from hybrid_engine.scene.data import Lights, SceneData, Sky
from hybrid_engine.scene.shader_graph import Link, ShaderGraph
from hybrid_engine.scene.sky_sun import disc_irradiance, sun_rows
from test_world_graph import _both, _world_scene, sky_scene

ELEVATIONS = (15.0, 45.0, 80.0)


def sky_graph(sky_type: str = "MULTIPLE_SCATTERING", strength: float = 1.0, **settings) -> ShaderGraph:
    """Background <- Sky Texture (``settings`` over Blender's defaults)."""
    graph = ShaderGraph()
    sky = graph.add("TEX_SKY", "Sky Texture", {"sky_type": sky_type, "sun_disc": True,
                                               "sun_elevation": math.radians(45.0), **settings})
    background = graph.add("BACKGROUND", Color=Link(sky, "Color"), Strength=strength)
    graph.surface = Link(background, "Background")
    return graph


def baked(ctx, graph: ShaderGraph) -> np.ndarray:
    bake = WorldBake(ctx, width=64)
    try:
        bake.update(graph)
        return np.frombuffer(bake.texture.read(), np.float32).reshape(32, 64, 4)[..., :3].copy()
    finally:
        bake.release()


@pytest.mark.parametrize("sky_type", ["MULTIPLE_SCATTERING", "SINGLE_SCATTERING"])
def test_a_scattering_sky_is_blue_overhead_and_follows_the_sun(ctx, sky_type):
    """Rayleigh scattering makes the zenith blue; the sky is brightest towards the sun (at
    rotation 0 it stands towards +Y, west of the bake's centre column), and more air scatters
    more light."""
    image = baked(ctx, sky_graph(sky_type))
    zenith = image[-1].mean(0)
    assert zenith[2] > zenith[1] > zenith[0] > 0.0
    row = image[20]  # 22.5 degrees up, all around
    toward_sun = row[16]  # u = 0.25 + half a texel: the direction +Y (sky.glsl equirect_uv)
    away = row[48]
    assert toward_sun.sum() > 1.5 * away.sum()
    thin = baked(ctx, sky_graph(sky_type, air_density=0.2, aerosol_density=0.2))
    assert thin[-1].mean(0)[2] < 0.5 * zenith[2]


def test_each_multiple_scattering_node_reads_its_own_transmittance_table(ctx):
    """Two skies of different air in one World, mixed: each shows its own atmosphere, as it
    does alone (a shared table would give the second the first one's light)."""
    def mixed(fac: float) -> ShaderGraph:
        graph = ShaderGraph()
        a = graph.add("TEX_SKY", "a", {"sky_type": "MULTIPLE_SCATTERING", "air_density": 1.0, "ozone_density": 1.0})
        b = graph.add("TEX_SKY", "b", {"sky_type": "MULTIPLE_SCATTERING", "air_density": 6.0, "ozone_density": 8.0})
        mix = graph.add("MIX", "mix", {"data_type": "RGBA"}, Factor_Float=fac, A_Color=Link(a, "Color"),
                        B_Color=Link(b, "Color"))
        background = graph.add("BACKGROUND", Color=Link(mix, "Result_Color"), Strength=1.0)
        graph.surface = Link(background, "Background")
        return graph

    alone_b = baked(ctx, sky_graph(air_density=6.0, ozone_density=8.0, sun_elevation=math.radians(15.0)))
    np.testing.assert_allclose(baked(ctx, mixed(1.0)), alone_b, rtol=1e-4, atol=1e-6)
    alone_a = baked(ctx, sky_graph(sun_elevation=math.radians(15.0)))
    np.testing.assert_allclose(baked(ctx, mixed(0.0)), alone_a, rtol=1e-4, atol=1e-6)


def test_the_transmittance_table_is_made_only_when_the_atmosphere_changes(ctx):
    bake = WorldBake(ctx, width=16)
    try:
        bake.update(sky_graph())
        assert bake.sky_tables.made == 1
        bake.update(sky_graph(sun_elevation=0.3))  # the sun moves: the sky is baked, the table kept
        assert bake.sky_tables.made == 1 and bake.bakes == 2
        bake.update(sky_graph(aerosol_density=3.0))
        assert bake.sky_tables.made == 2
    finally:
        bake.release()


@pytest.mark.parametrize("sky_type", ["MULTIPLE_SCATTERING", "SINGLE_SCATTERING"])
def test_the_sun_disc_is_a_sun_lamp_towards_the_sun_scaled_by_the_strength(sky_type):
    rows = sun_rows(sky_graph(sky_type, strength=2.0, sun_elevation=math.radians(30.0), sun_rotation=0.5))
    assert len(rows) == 1 and rows[0]["kind"] == "SUN"
    towards = -np.asarray(rows[0]["direction"])
    np.testing.assert_allclose(towards, (math.cos(math.radians(30)) * math.sin(0.5),
                                         math.cos(math.radians(30)) * math.cos(0.5), 0.5), atol=1e-6)
    one = sun_rows(sky_graph(sky_type, sun_elevation=math.radians(30.0), sun_rotation=0.5))[0]
    np.testing.assert_allclose(rows[0]["color"], 2.0 * np.asarray(one["color"]), rtol=1e-6)
    red, green, blue = one["color"]
    assert red > green > blue > 0.0  # sunlight reddened by the air it crossed


def test_a_low_sun_is_redder_and_dimmer_and_a_set_sun_gives_no_lamp():
    high = disc_irradiance(dict(sky_type="MULTIPLE_SCATTERING", sun_elevation=math.radians(60.0)))
    low = disc_irradiance(dict(sky_type="MULTIPLE_SCATTERING", sun_elevation=math.radians(2.0)))
    assert low.sum() < 0.5 * high.sum() and low[2] / low[0] < high[2] / high[0]
    assert not sun_rows(sky_graph(sun_elevation=math.radians(-5.0)))
    assert not sun_rows(sky_graph(sun_disc=False))


def test_only_a_disc_that_reaches_the_world_unchanged_becomes_a_lamp():
    """Through a Mix or along a linked Vector the disc's light is no longer the lamp's."""
    assert not sun_rows(sky_graph("PREETHAM"))
    graph = sky_graph()
    coords = graph.add("TEX_COORD")
    graph.nodes[0].inputs["Vector"] = Link(coords, "Generated")
    assert not sun_rows(graph)


def test_the_scene_lights_carry_the_sky_sun_lamp():
    scene = sky_scene(Sky(graph=sky_graph()))
    assert len(scene.lights) == 1 and scene.lights.names[0] == "Sky Texture (sun disc)"
    assert isinstance(scene.lights, Lights)
    assert len(sky_scene(Sky(color=(1.0, 1.0, 1.0))).lights) == 0
    # A scene made again from another's lights and sky (scene_buffers.py does) keeps one sun,
    # and the lamps it was given stay in front.
    lamp = Lights.from_rows([dict(kind="POINT", position=(0, 0, 2), color=(5, 5, 5), name="lamp")])
    first = SceneData(scene.geometry, scene.materials, lamp, scene.sky)
    again = SceneData(first.geometry, first.materials, first.lights, first.sky)
    assert again.lights.names == ["lamp", "Sky Texture (sun disc)"]
    assert SceneData(first.geometry, first.materials, first.lights, Sky()).lights.names == ["lamp"]


# -- against Cycles, through Blender's render path ------------------------------------------
def _sky_texture_world(tree, sky_type: str, elevation: float) -> None:
    sky = tree.nodes.new("ShaderNodeTexSky")
    sky.sky_type = sky_type
    sky.sun_elevation = math.radians(elevation)
    sky.sun_rotation = 0.7  # the sun off the test camera's view (it looks towards -Y)
    tree.links.new(sky.outputs["Color"], tree.nodes["Background"].inputs["Color"])


@pytest.mark.parametrize("elevation", ELEVATIONS)
@pytest.mark.parametrize("sky_type", ["MULTIPLE_SCATTERING", "SINGLE_SCATTERING"])
def test_a_scattering_sky_texture_world_is_within_5_percent_of_cycles(addon, tmp_path, sky_type, elevation):
    """The sky seen at the horizon (mean per channel and per pixel) and its light, sky and
    sun disc, on a white diffuse plane (the issue's bar)."""
    import bpy

    scene, tree = _world_scene(bpy, "SKY")
    _sky_texture_world(tree, sky_type, elevation)
    ours, cycles = _both(bpy, scene, tmp_path)
    print("sky", sky_type, elevation, ours.mean((0, 1)), cycles.mean((0, 1)))
    assert np.abs(ours - cycles).mean() <= 0.05 * cycles.mean()
    np.testing.assert_allclose(ours.mean((0, 1)), cycles.mean((0, 1)), rtol=0.05)
    scene, tree = _world_scene(bpy, "PLANE", 16)
    _sky_texture_world(tree, sky_type, elevation)
    scene.cycles.samples = 256
    ours, cycles = _both(bpy, scene, tmp_path)
    print("plane", sky_type, elevation, ours.mean((0, 1)), cycles.mean((0, 1)))
    np.testing.assert_allclose(ours.mean((0, 1)), cycles.mean((0, 1)), rtol=0.05)


def _hosek_world(tree, sun_direction, turbidity: float, albedo: float) -> None:
    sky = tree.nodes.new("ShaderNodeTexSky")
    sky.sky_type = "HOSEK_WILKIE"
    sky.sun_direction = sun_direction
    sky.turbidity = turbidity
    sky.ground_albedo = albedo
    tree.links.new(sky.outputs["Color"], tree.nodes["Background"].inputs["Color"])


@pytest.mark.parametrize("elevation", ELEVATIONS)
def test_a_hosek_wilkie_sky_texture_world_is_within_5_percent_of_cycles(addon, tmp_path, elevation):
    """The sky and its light on a white plane, with a turbidity and albedo between the
    dataset's grid points (so both blends are exercised); the model has no sun disc. The
    plane is lit as the default mode lights it (World light traced per direction): the
    nine-coefficient irradiance of RASTER rings on this model's bright circumsolar glow,
    which Cycles extends below the horizon, and lights a plane under a low sun too much."""
    import bpy
    from test_engine import render_exr

    e = math.radians(elevation)
    sun = (0.6 * math.cos(e), 0.8 * math.cos(e), math.sin(e))  # behind the camera, which looks along -Y
    scene, tree = _world_scene(bpy, "SKY")
    _hosek_world(tree, sun, 3.4, 0.3)
    ours, cycles = _both(bpy, scene, tmp_path)
    print("sky hosek", elevation, ours.mean((0, 1)), cycles.mean((0, 1)))
    assert np.abs(ours - cycles).mean() <= 0.05 * cycles.mean()
    np.testing.assert_allclose(ours.mean((0, 1)), cycles.mean((0, 1)), rtol=0.05)
    scene, tree = _world_scene(bpy, "PLANE", 16)
    _hosek_world(tree, sun, 3.4, 0.3)
    scene.cycles.samples = 256
    scene.render.engine = "CYCLES"
    cycles = render_exr(bpy, scene, tmp_path / "cycles.exr")[..., :3]
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.mode = "HYBRID"
    scene.hybrid_rt.render_samples = 16
    ours = render_exr(bpy, scene, tmp_path / "ours.exr")[..., :3]
    print("plane hosek", elevation, ours.mean((0, 1)), cycles.mean((0, 1)))
    np.testing.assert_allclose(ours.mean((0, 1)), cycles.mean((0, 1)), rtol=0.05)


def test_every_sky_model_is_evaluated_and_none_is_named(addon):
    import bpy

    messages = addon.blender_adapter.messages
    extract_sky = addon.blender_adapter.export.world.extract_sky
    _scene, tree = _world_scene(bpy, "SKY", 8)
    _sky_texture_world(tree, "HOSEK_WILKIE", 45.0)
    for sky_type in ("HOSEK_WILKIE", "PREETHAM", "SINGLE_SCATTERING", "MULTIPLE_SCATTERING"):
        tree.nodes[-1].sky_type = sky_type
        with messages.collecting() as told:
            extract_sky(bpy.context.scene.world)
        assert not [m for m in told if "sky model" in m], told


def test_a_sun_disc_that_cannot_be_a_lamp_is_named_to_the_artist(addon):
    """A Sky Texture through a Mix node: its disc's light is not the World's unchanged."""
    import bpy

    messages = addon.blender_adapter.messages
    extract_sky = addon.blender_adapter.export.world.extract_sky
    _scene, tree = _world_scene(bpy, "SKY", 8)
    _sky_texture_world(tree, "MULTIPLE_SCATTERING", 45.0)
    with messages.collecting() as told:
        extract_sky(bpy.context.scene.world)
    assert not [m for m in told if "sun disc" in m], told
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    socket_a = next(s for s in mix.inputs if s.identifier == "A_Color")
    result = next(s for s in mix.outputs if s.identifier == "Result_Color")
    tree.links.new(tree.nodes["Sky Texture"].outputs["Color"], socket_a)
    tree.links.new(result, tree.nodes["Background"].inputs["Color"])
    with messages.collecting() as told:
        sky = extract_sky(bpy.context.scene.world)
    assert [m for m in told if "sun disc" in m and "Sky Texture" in m], told
    assert not sun_rows(sky.graph)


def test_the_hosek_wilkie_state_is_the_dataset_at_its_grid_points():
    """At an integer turbidity, albedo 0 or 1 and the sun overhead (the Bezier curve's end) the
    state is the dataset's own last control point; halfway between turbidities, the mean."""
    from hybrid_engine.scene.sky_hosek import hosek_state
    from hybrid_engine.scene.sky_hosek_data import CONFIGURATIONS, RADIANCES

    config = np.asarray(CONFIGURATIONS).reshape(3, 2, 10, 6, 9)
    radiance = np.asarray(RADIANCES).reshape(3, 2, 10, 6)
    state = hosek_state((0.0, 0.0, 1.0), 3.0, 1.0)
    np.testing.assert_allclose(state[:27], config[:, 1, 2, 5].reshape(27), rtol=1e-12)
    np.testing.assert_allclose(state[27:], radiance[:, 1, 2, 5], rtol=1e-12)
    half = hosek_state((0.0, 0.0, 1.0), 3.5, 0.0)
    np.testing.assert_allclose(half[:27], 0.5 * (config[:, 0, 2, 5] + config[:, 0, 3, 5]).reshape(27), rtol=1e-12)


@pytest.mark.parametrize("sky_type", ["MULTIPLE_SCATTERING", "SINGLE_SCATTERING", "HOSEK_WILKIE"])
def test_moving_the_sun_rebakes_the_sky_without_a_shader_compile(ctx, sky_type):
    """A value edit (the sun's elevation, the air, the turbidity) is one bake and no compile:
    the model's code is compiled in with the first World that uses it."""
    from hybrid_engine.gpu import shader_loader

    bake = WorldBake(ctx, width=16)
    try:
        bake.update(sky_graph(sky_type, sun_elevation=0.2, sun_direction=(0.0, 0.5, 0.2)))
        first = np.frombuffer(bake.texture.read(), np.float32).copy()
        compiled = shader_loader.compiles
        bake.update(sky_graph(sky_type, sun_elevation=0.9, air_density=2.0, turbidity=5.0,
                              sun_direction=(0.0, 0.5, 0.9)))
        assert shader_loader.compiles == compiled and bake.bakes == 2
        assert not np.allclose(np.frombuffer(bake.texture.read(), np.float32), first, rtol=0.05)
    finally:
        bake.release()
