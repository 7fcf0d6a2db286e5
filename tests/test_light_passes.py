# SPDX-License-Identifier: GPL-3.0-or-later
"""Cycles' light passes and Mist (hybrid_engine/passes/film/light_passes.py): written by the
shading and the tracer, recombined into Combined as Cycles documents, under Cycles' names
through Blender's render path and its compositor, and absent (the image unchanged bit for
bit) when no view layer asks for them."""
from __future__ import annotations

import math

import numpy as np
import pytest

from hybrid_engine import Camera, Geometry, Lights, MaterialTable, RenderSettings, SceneData, Sky
from hybrid_engine.frame.film import FrameOutputs
from hybrid_engine.gpu import variants
from hybrid_engine.passes.film.light_passes import PASSES, LightPassRequest
from hybrid_engine.scene.camera import look_at
from scenes_analytic import quad, uv_sphere

SMALL = dict(cube_resolution=32, shadow_resolution=128, near_size=2.0)
ALL = LightPassRequest(tuple(PASSES), mist_start=3.0, mist_depth=4.0, mist_falloff="LINEAR")
LOBES = ("Diffuse", "Glossy", "Transmission")


def scene() -> SceneData:
    """A mirror ball and a glass ball on a diffuse floor under a sun and a blue sky."""
    mirror, mirror_normals = uv_sphere((-1.1, 0, 0), 1.0, 16, 8)
    glass, glass_normals = uv_sphere((1.1, 0, 0), 1.0, 16, 8)
    mats = MaterialTable.from_rows([dict(base_color=(0.9, 0.9, 0.9), reflectivity=1.0),
                                    dict(base_color=(0.6, 0.5, 0.4)),
                                    dict(base_color=(1.0, 1.0, 1.0), transmission=1.0, ior=1.45)])
    floor = quad((0, 0, -1), (5, 0, 0), (0, 5, 0))
    return SceneData(Geometry.from_objects([(mirror, mirror_normals, 0), (glass, glass_normals, 2), (floor, None, 1)]),
                     mats, Lights.from_rows([dict(kind="SUN", direction=(0, 0.3, -1), color=(2, 2, 2))]),
                     Sky(color=(0.2, 0.3, 0.5)))


CAMERA = Camera(matrix_world=look_at((0, -5, 1.5), (0, 0, 0)), width=40, height=28)


def render(renderer, mode: str, light: LightPassRequest | None, samples: int = 3):
    """A final render's samples of ``scene()`` with (or without) the light passes."""
    settings = RenderSettings(mode=mode, **SMALL)
    result = None
    for sample in range(samples):
        result = renderer.render(scene(), CAMERA, settings, outputs=FrameOutputs(light=light), sample=sample,
                                 accumulate=True, read_image=sample == samples - 1)
    return result


def recombined(passes: dict[str, np.ndarray]) -> np.ndarray:
    """Combined as Cycles' manual recombines it from the light passes."""
    return (sum((passes[f"{lobe} Direct"] + passes[f"{lobe} Indirect"]) * passes[f"{lobe} Color"] for lobe in LOBES)
            + passes["Emission"] + passes["Environment"])


@pytest.mark.parametrize("mode", ["RASTER", "HYBRID", "FULL_BVH"])
def test_the_light_passes_recombine_into_the_combined_image(renderer, mode):
    result = render(renderer, mode, ALL)
    passes = result.data_passes
    assert set(passes) == {name for name, *_ in PASSES.values()}
    combined = result.image[..., :3]
    error = np.abs(recombined(passes) - combined).mean() / combined.mean()
    assert error < 1e-4, error
    # Every lobe carries light somewhere: the floor is diffuse, one ball a mirror, one glass.
    for lobe in LOBES:
        assert (passes[f"{lobe} Color"] > 0.05).any(axis=-1).sum() > 20, lobe
    assert (passes["Environment"] > 0).any(axis=-1).sum() > 20
    assert passes["Transmission Direct"].max() == 0.0


@pytest.mark.parametrize("mode", ["RASTER", "HYBRID"])
def test_asking_for_the_light_passes_leaves_the_image_bit_for_bit_the_same(renderer, mode):
    variants.set_override("trace=cpu")  # the megakernel, which writes the passes
    try:
        on = render(renderer, mode, ALL).image
        off = render(renderer, mode, None).image
    finally:
        variants.set_override(None)
    np.testing.assert_array_equal(on, off)


def test_the_gpu_shaped_trace_still_recombines_with_light_passes(renderer):
    """The wave tracer keeps no lobe per ray: a frame with light passes traces with the
    megakernel, so the passes hold whichever kernel the variants choose."""
    variants.set_override("trace=gpu")
    try:
        result = render(renderer, "HYBRID", ALL)
    finally:
        variants.set_override(None)
    combined = result.image[..., :3]
    assert np.abs(recombined(result.data_passes) - combined).mean() / combined.mean() < 1e-4
    assert (result.data_passes["Glossy Indirect"] > 0.05).any(axis=-1).sum() > 20


def test_environment_holds_the_world_behind_transparent_film_as_in_cycles(renderer):
    """Transparent film clears the background of Combined, not of the Environment pass: a
    compositor puts the World back from it (Cycles does the same)."""
    result = renderer.render(scene(), CAMERA, RenderSettings(mode="RASTER", **SMALL),
                             outputs=FrameOutputs(light=ALL, transparent=True))
    background = result.image[..., 3] == 0
    assert background.sum() > 20
    np.testing.assert_allclose(result.data_passes["Environment"][background], np.broadcast_to(
        Sky(color=(0.2, 0.3, 0.5)).color, (int(background.sum()), 3)), rtol=1e-3)
    assert (result.data_passes["Mist"][background] == 1.0).all()


def test_a_frame_without_light_passes_plans_and_binds_none(renderer):
    settings = RenderSettings(mode="HYBRID", **SMALL)
    with_light = renderer.passes(settings, accumulate=True, light=True)
    without = renderer.passes(settings, accumulate=True)
    assert "light_passes" in [p.name for p in with_light]
    assert "light_passes" not in [p.name for p in without]
    for frame_pass in without:
        io = frame_pass.io(settings)
        assert "light_samples" not in io.reads + io.writes, frame_pass.name


@pytest.mark.parametrize(("falloff", "shape"), [("LINEAR", lambda m: m), ("QUADRATIC", lambda m: m * m),
                                                ("INVERSE_QUADRATIC", np.sqrt)])
def test_mist_follows_the_worlds_start_depth_and_falloff_along_the_primary_ray(renderer, falloff, shape):
    """A floor seen from above: each pixel's distance to the camera is known exactly."""
    floor = SceneData(Geometry.from_objects([(quad((0, 0, 0), (40, 0, 0), (0, 40, 0)), None, 0)]),
                      MaterialTable.from_rows([dict(base_color=(0.5, 0.5, 0.5))]), Lights.from_rows([]),
                      Sky(color=(0.2, 0.3, 0.5)))
    eye = np.array([0.0, -6.0, 3.0])
    camera = Camera(matrix_world=look_at(tuple(eye), (0, 0, 2.0)), width=32, height=24)
    request = LightPassRequest(("use_pass_mist",), mist_start=6.0, mist_depth=8.0, mist_falloff=falloff)
    result = renderer.render(floor, camera, RenderSettings(mode="RASTER", **SMALL),
                             outputs=FrameOutputs(light=request, depth=True))
    mist = result.data_passes["Mist"][..., 0]
    depth = result.data_passes["depth"]
    hit = depth < 1e9
    # The planar depth and the pixel's ray give the distance along the ray.
    ys, xs = np.nonzero(hit)
    ndc = np.stack([(xs + 0.5) / 32 * 2 - 1, (ys + 0.5) / 24 * 2 - 1], axis=-1)
    inverse = np.linalg.inv(camera.projection_matrix())
    rays = np.c_[ndc, -np.ones(len(ndc)), np.ones(len(ndc))] @ inverse.T
    rays = rays[:, :3] / rays[:, 3:]
    distance = depth[hit] * np.linalg.norm(rays, axis=-1) / -rays[:, 2]
    expected = shape(np.clip((distance - 6.0) / 8.0, 0.0, 1.0))
    assert hit.sum() > 100 and (~hit).sum() > 20
    np.testing.assert_allclose(mist[hit], expected, atol=2e-3)
    assert (mist[~hit] == 1.0).all()
    assert 0.0 < expected.min() < 0.5 < expected.max()


# ---------------------------------------------------------------------------------------------
# Through Blender: the render result, a multilayer EXR, the compositor, and Cycles beside us.

LIGHT_FLAGS = tuple(PASSES)


def build_lobes_scene(bpy):
    """A diffuse floor, a mirror ball and a glass ball under a sun and a blue World, with
    every light pass and Mist asked for."""
    def material(name, color, metallic=0.0, roughness=0.5, transmission=0.0):
        mat = bpy.data.materials.new(name)
        bsdf = mat.node_tree.nodes["Principled BSDF"]
        bsdf.inputs["Base Color"].default_value = (*color, 1.0)
        bsdf.inputs["Metallic"].default_value = metallic
        bsdf.inputs["Roughness"].default_value = roughness
        bsdf.inputs["Transmission Weight"].default_value = transmission
        return mat

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=12)
    bpy.context.object.data.materials.append(material("floor", (0.6, 0.5, 0.4)))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0, location=(-1.2, 0, 1))
    bpy.context.object.data.materials.append(material("mirror", (0.9, 0.9, 0.9), metallic=1.0, roughness=0.0))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0, location=(1.2, 0, 1))
    bpy.context.object.data.materials.append(material("glass", (1, 1, 1), roughness=0.0, transmission=1.0))
    bpy.ops.object.light_add(type="SUN", location=(0, 0, 5), rotation=(0.5, 0.3, 0))
    bpy.context.object.data.energy = 3.0
    cam_obj = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    cam_obj.location, cam_obj.rotation_euler = (0, -7, 3), (math.radians(70), 0, 0)
    scene.collection.objects.link(cam_obj)
    scene.camera = cam_obj
    scene.world = bpy.data.worlds.new("world")
    scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.3, 0.4, 0.6, 1)
    scene.world.mist_settings.start, scene.world.mist_settings.depth = 3.0, 10.0
    scene.world.mist_settings.falloff = "LINEAR"
    scene.render.resolution_x, scene.render.resolution_y = 64, 48
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.mode = "HYBRID"
    scene.hybrid_rt.render_samples = 2
    for flag in LIGHT_FLAGS:
        setattr(scene.view_layers[0], flag, True)
    return scene


def _rgb(channels, layer, name):
    return np.stack([channels[f"{layer}.{name}.{c}"] for c in "RGB"], axis=-1)


def test_each_pass_is_written_under_cycles_name_and_recombines_into_combined(addon, tmp_path):
    import bpy
    from test_engine import render_multilayer

    scene = build_lobes_scene(bpy)
    ours = render_multilayer(bpy, scene, tmp_path / "ours.exr")
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 1
    scene.cycles.device = "CPU"
    cycles = render_multilayer(bpy, scene, tmp_path / "cycles.exr")
    assert set(ours) == {name for name in cycles if "Noisy" not in name}
    assert {f"ViewLayer.{name}" for name, *_ in PASSES.values()} <= {c.rpartition(".")[0] for c in ours}

    passes = {name: _rgb(ours, "ViewLayer", name) for name in
              [f"{lobe} {kind}" for lobe in LOBES for kind in ("Direct", "Indirect", "Color")]
              + ["Emission", "Environment"]}
    combined = _rgb(ours, "ViewLayer", "Combined")
    assert np.abs(recombined(passes) - combined).mean() / combined.mean() < 0.01


def test_the_compositor_recombines_the_light_passes_into_combined(addon, tmp_path):
    """A Cycles-style node tree (Add and Multiply Mix nodes on the Render Layers sockets)
    rebuilds Combined from our passes within 1 % mean."""
    import bpy
    from test_engine import render_multilayer

    scene = build_lobes_scene(bpy)
    tree = bpy.data.node_groups.new("Recombine", "CompositorNodeTree")
    scene.compositing_node_group = tree
    tree.interface.new_socket("Image", in_out="OUTPUT", socket_type="NodeSocketColor")
    layers, output = tree.nodes.new("CompositorNodeRLayers"), tree.nodes.new("NodeGroupOutput")

    def mix(blend, a, b):
        node = tree.nodes.new("ShaderNodeMix")
        node.data_type, node.blend_type, node.clamp_result = "RGBA", blend, False
        node.inputs["Factor"].default_value = 1.0
        tree.links.new(a, node.inputs[6])  # the colour A and B sockets
        tree.links.new(b, node.inputs[7])
        return node.outputs[2]

    total = mix("ADD", layers.outputs["Emission"], layers.outputs["Environment"])
    for lobe in LOBES:
        light = mix("ADD", layers.outputs[f"{lobe} Direct"], layers.outputs[f"{lobe} Indirect"])
        total = mix("ADD", total, mix("MULTIPLY", light, layers.outputs[f"{lobe} Color"]))
    tree.links.new(total, output.inputs["Image"])

    channels = render_multilayer(bpy, scene, tmp_path / "recombined.exr")
    combined = _rgb(channels, "ViewLayer", "Combined")
    composite = _rgb(channels, "Composite", "Combined")
    assert combined.mean() > 0.05
    assert np.abs(composite - combined).mean() / combined.mean() < 0.01


def test_mist_matches_cycles_mist_pass(addon, tmp_path):
    import bpy
    from test_engine import render_multilayer

    scene = build_lobes_scene(bpy)
    for flag in LIGHT_FLAGS:
        setattr(scene.view_layers[0], flag, flag == "use_pass_mist")
    scene.world.mist_settings.falloff = "QUADRATIC"
    scene.hybrid_rt.render_samples = 8
    ours = render_multilayer(bpy, scene, tmp_path / "ours.exr")["ViewLayer.Mist.Z"]
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 16
    scene.cycles.device = "CPU"
    cycles = render_multilayer(bpy, scene, tmp_path / "cycles.exr")["ViewLayer.Mist.Z"]
    assert 0.05 < cycles.mean() < 0.95 and cycles.std() > 0.1
    assert abs(ours.mean() - cycles.mean()) / cycles.mean() < 0.01
    assert np.abs(ours - cycles).mean() / cycles.mean() < 0.02


def test_a_light_pass_switch_adds_and_removes_the_render_layers_socket(addon):
    import bpy

    scene = bpy.context.scene
    scene.render.engine = "HYBRID_RT"
    scene.compositing_node_group = tree = bpy.data.node_groups.new("Passes", "CompositorNodeTree")
    layers = tree.nodes.new("CompositorNodeRLayers")

    def shown():
        return {socket.name for socket in layers.outputs if socket.enabled}

    layer = scene.view_layers[0]
    for flag, (name, *_rest) in PASSES.items():
        assert name not in shown(), name
        setattr(layer, flag, True)
        assert name in shown(), name
        setattr(layer, flag, False)


def test_the_passes_panel_offers_every_light_pass_and_the_worlds_mist(addon):
    """The View Layer's Passes panel (ui/panels.py) lists the light passes the engine writes,
    and the World's Mist panel shows for it: the settings the Mist pass follows."""
    import bpy
    from test_properties import RecordingLayout

    drawn: list[str] = []

    class FakeContext:
        scene = bpy.context.scene
        view_layer = bpy.context.view_layer

    class FakePanel:
        layout = RecordingLayout(drawn)

    addon.ui.panels.VIEWLAYER_PT_hybrid_rt_passes.draw(FakePanel(), FakeContext)
    assert set(PASSES) <= set(drawn)
    assert "HYBRID_RT" in bpy.types.EEVEE_WORLD_PT_mist.COMPAT_ENGINES


def test_light_passes_honour_light_linking_and_leave_a_linked_image_the_same(renderer):
    """The passes' shading (light_passes.glsl) skips a lamp for the surfaces it does not link,
    as the image's shading does: the image stays bit for bit and the passes still add up."""
    from test_light_linking import looking_at, two_spheres

    scene_linked, camera = two_spheres(light_linked=True), looking_at((0.0, 0.0, 0.8))
    settings = RenderSettings(mode="RASTER", **SMALL)
    variants.set_override("trace=cpu")
    try:
        images = {}
        for name, light in (("on", ALL), ("off", None)):
            images[name] = renderer.render(scene_linked, camera, settings, outputs=FrameOutputs(light=light))
    finally:
        variants.set_override(None)
    np.testing.assert_array_equal(images["on"].image, images["off"].image)
    combined = images["on"].image[..., :3]
    error = np.abs(recombined(images["on"].data_passes) - combined).mean() / combined.mean()
    assert error < 1e-4, error
