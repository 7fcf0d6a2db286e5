# SPDX-License-Identifier: GPL-3.0-or-later
"""The HYBRID_RT RenderEngine through Blender's own render path (bpy.ops.render.render).

Cycles, rendering the same scene in the same process, is the independent oracle for light
units and camera framing: a Lambertian plane lit by a sun or a point light must come out
with the same radiance from both engines.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

# Cycles is a Monte Carlo renderer; with 64 samples of direct light on a plane its noise is
# well below this. Our own error is float precision.
CYCLES_RTOL = 0.02


def _diffuse_material(bpy, color):
    mat = bpy.data.materials.new("diffuse")
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*color, 1.0)
    bsdf.inputs["Roughness"].default_value = 1.0
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    return mat


def build_plane_scene(bpy, light_kind="SUN", energy=2.0, size=16):
    """A white-ish plane filling an orthographic top view, lit by one light, black world."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=40)
    bpy.context.object.data.materials.append(_diffuse_material(bpy, (0.8, 0.6, 0.4)))
    light = bpy.data.lights.new("light", light_kind)
    light.energy = energy
    if light_kind != "SUN":
        light.shadow_soft_size = 0.0
    light_obj = bpy.data.objects.new("light", light)
    light_obj.location = (0.0, 0.0, 3.0)
    scene.collection.objects.link(light_obj)
    cam = bpy.data.cameras.new("cam")
    cam.type = "ORTHO"
    cam.ortho_scale = 1.0
    cam_obj = bpy.data.objects.new("cam", cam)
    cam_obj.location = (0.0, 0.0, 1.0)
    scene.collection.objects.link(cam_obj)
    scene.camera = cam_obj
    world = bpy.data.worlds.new("world")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scene.world = world
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    return scene


def render_exr(bpy, scene, path):
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(str(path))
    try:
        w, h = image.size
        pixels = np.empty(w * h * 4, np.float32)
        image.pixels.foreach_get(pixels)
        return pixels.reshape(h, w, 4)
    finally:
        bpy.data.images.remove(image)


@pytest.mark.parametrize("light_kind,energy", [("SUN", 2.0), ("POINT", 300.0)])
def test_raster_render_matches_cycles_radiance_of_a_lit_plane(addon, tmp_path, light_kind, energy):
    import bpy

    scene = build_plane_scene(bpy, light_kind, energy)
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 64
    scene.cycles.device = "CPU"
    cycles = render_exr(bpy, scene, tmp_path / "cycles.exr")
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.mode = "RASTER"
    ours = render_exr(bpy, scene, tmp_path / "ours.exr")
    assert ours.shape == cycles.shape == (16, 16, 4)
    np.testing.assert_allclose(ours[2:-2, 2:-2, :3].mean(axis=(0, 1)), cycles[2:-2, 2:-2, :3].mean(axis=(0, 1)),
                               rtol=CYCLES_RTOL)
    # Point light: the falloff across the image must match too, not just the mean. Cycles'
    # pixel filter darkens its outermost pixels, so compare the interior.
    inner = (slice(2, -2), slice(2, -2), 0)
    np.testing.assert_allclose(ours[inner], cycles[inner], rtol=CYCLES_RTOL * 3)


def test_render_reports_stats_and_keeps_the_frame_result(addon, tmp_path, monkeypatch):
    import bpy

    monkeypatch.setattr(addon.blender_adapter.engine, "time_final_renders", True)  # per-pass times
    scene = build_plane_scene(bpy, "SUN", 1.0, size=8)
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.mode = "RASTER"
    render_exr(bpy, scene, tmp_path / "frame.exr")
    frame = addon.blender_adapter.engine.last_frame
    assert frame is not None and frame.mode == "RASTER"
    assert {"extract", "upload", "primary_raster", "shade", "readback"} <= set(frame.passes)
    assert frame.counts["triangles_total"] == 2


def test_a_missing_image_reaches_the_artists_report_with_its_name(addon, tmp_path, capfd, caplog):
    """Blender's report (Info editor, status bar; in background mode a "Warning:" line)
    hears of a texture whose file is missing, named, on F12 and in the viewport, and the
    texture renders magenta, as in Blender's engines."""
    import bpy

    scene = build_plane_scene(bpy, "SUN", 1.0, size=8)
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.mode = "RASTER"
    material = bpy.data.materials.new("painted")
    image = bpy.data.images.new("lost texture", 4, 4)
    image.source, image.filepath = "FILE", str(tmp_path / "gone.png")  # no such file
    texture = material.node_tree.nodes.new("ShaderNodeTexImage")
    texture.image = image
    material.node_tree.links.new(texture.outputs["Color"],
                                 material.node_tree.nodes["Principled BSDF"].inputs["Base Color"])
    plane = next(obj for obj in scene.objects if obj.type == "MESH")
    plane.data.materials.clear()
    plane.data.materials.append(material)
    capfd.readouterr()
    with caplog.at_level("DEBUG"):
        pixels = render_exr(bpy, scene, tmp_path / "frame.exr")
    printed = capfd.readouterr()
    assert printed.out.count("Warning: Hybrid RT: image 'lost texture' has no pixels") == 1, printed
    # One console line per problem per render: Blender prints the report, so the log keeps
    # its copy below the warning level that Python prints to the console.
    logged = [r for r in caplog.records if "'lost texture' has no pixels" in r.getMessage()]
    assert logged and all(r.levelname == "DEBUG" for r in logged), logged
    # Magenta, as Blender renders it; the green is the Principled BSDF's white specular coat.
    red, green, blue = pixels[2:-2, 2:-2, :3].mean(axis=(0, 1))
    assert red > 0.1 and green < 0.2 * red and abs(blue - red) < 0.05 * red, (red, green, blue)

    reported = []

    class FakeEngine:
        def report(self, levels, text):
            reported.append((levels, text))

    viewport = addon.blender_adapter.viewport
    try:
        viewport.view_update(FakeEngine(), bpy.context, bpy.context.evaluated_depsgraph_get())
    finally:
        viewport.release_all()
    assert any(levels == {"WARNING"} and "'lost texture'" in text for levels, text in reported), reported


def test_hybrid_mode_renders_through_blenders_render_path(addon, tmp_path, monkeypatch):
    import bpy

    monkeypatch.setattr(addon.blender_adapter.engine, "time_final_renders", True)  # per-pass times
    scene = build_plane_scene(bpy, "SUN", 1.0, size=8)
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.mode = "HYBRID"
    image = render_exr(bpy, scene, tmp_path / "hybrid.exr")
    frame = addon.blender_adapter.engine.last_frame
    assert frame.mode == "HYBRID"
    assert {"cube_map_raster", "cull", "lbvh_build", "trace"} <= set(frame.passes)
    assert image[..., 0].mean() > 0.1


def test_a_diagnostic_view_keeps_its_legend_in_the_saved_render(addon, tmp_path):
    """The core hands the legend as data; F12 paints it into the Combined pass, so a saved
    render shows what its false colours mean."""
    import bpy

    scene = build_plane_scene(bpy, "SUN", 1.0, size=160)
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.mode = "BOUNCES"
    scene.hybrid_rt.render_samples = 1
    image = render_exr(bpy, scene, tmp_path / "bounces.exr")
    frame = addon.blender_adapter.engine.last_frame
    legend = addon.hybrid_engine.reports.diagnostic_legend
    assert frame.legend, "a diagnostic frame carries its legend"
    corner = image[::-1][:len(frame.legend) * 14 + 8, :120, :3].reshape(-1, 3)  # rows from the top
    for entry in frame.legend:
        assert np.isclose(corner, entry.colour, atol=1e-5).all(axis=1).any(), entry.label
    assert np.isclose(corner, legend.LEGEND_TEXT, atol=1e-5).all(axis=1).any()


def test_a_failing_frame_is_reported_and_leaves_the_scene_untouched(addon, tmp_path):
    import bpy

    scene = build_plane_scene(bpy, "SUN", 1.0, size=8)
    scene.render.engine = "HYBRID_RT"
    scene.camera = None  # no camera: a clear error, no crash
    before = [tuple(v.co) for v in bpy.data.objects["Plane"].data.vertices]
    scene.render.filepath = str(tmp_path / "nocam.png")
    with pytest.raises(RuntimeError, match="[Cc]amera"):
        bpy.ops.render.render(write_still=True)
    assert [tuple(v.co) for v in bpy.data.objects["Plane"].data.vertices] == before


# ---------------------------------------------------------------------------------------------
# The film: data passes, transparency and the render region, as a compositor receives them.

def build_film_scene(bpy, size=(24, 16)):
    """A perspective camera above two planes that leave part of the frame empty: a tilted one
    seen from its front, and a lower one turned over, seen from its back side."""
    import math

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=4, location=(-1.0, 0.0, 0.0), rotation=(math.radians(30), 0, 0))
    bpy.ops.mesh.primitive_plane_add(size=2, location=(1.6, 0.5, -1.0), rotation=(math.pi, 0, 0))
    bpy.ops.object.light_add(type="SUN", location=(0, 0, 5))
    cam = bpy.data.cameras.new("cam")
    cam_obj = bpy.data.objects.new("cam", cam)
    cam_obj.location = (0.5, -1.0, 6.0)
    scene.collection.objects.link(cam_obj)
    scene.camera = cam_obj
    scene.render.resolution_x, scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.hybrid_rt.render_samples = 1  # each pixel sampled at its centre, as Cycles is below
    return scene


def render_multilayer(bpy, scene, path) -> dict[str, np.ndarray]:
    """Render and save every pass to an uncompressed multilayer EXR, read back by channel."""
    from image_io import read_exr_channels

    settings = scene.render.image_settings
    settings.media_type = "MULTI_LAYER_IMAGE"
    settings.file_format = "OPEN_EXR_MULTILAYER"
    settings.exr_codec = "NONE"
    settings.color_depth = "32"
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    return read_exr_channels(path)


def test_depth_normal_and_transparent_alpha_reach_a_multilayer_exr_as_cycles_writes_them(addon, tmp_path):
    import bpy

    scene = build_film_scene(bpy)
    layer = scene.view_layers[0]
    layer.use_pass_z = layer.use_pass_normal = True
    scene.render.film_transparent = True
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 1
    scene.cycles.filter_width = 0.01  # one sample at each pixel's centre, like a rasterizer
    scene.cycles.device = "CPU"
    cycles = render_multilayer(bpy, scene, tmp_path / "cycles.exr")
    scene.render.engine = "HYBRID_RT"
    ours = render_multilayer(bpy, scene, tmp_path / "ours.exr")

    cycles_channels = {name for name in cycles if "Noisy" not in name}
    assert set(ours) == cycles_channels
    assert {"ViewLayer.Depth.Z", "ViewLayer.Normal.X"} <= set(ours)
    alpha = ours["ViewLayer.Combined.A"]
    assert ((alpha == 0) != (cycles["ViewLayer.Combined.A"] == 0)).sum() <= 2, "background masks differ"
    empty, hit = alpha == 0, alpha == 1
    assert empty.sum() > 20 and hit.sum() > 100 and (empty | hit).all()
    for channel in "RGB":
        assert (ours[f"ViewLayer.Combined.{channel}"][empty] == 0).all()
    both = hit & (cycles["ViewLayer.Combined.A"] == 1)
    np.testing.assert_allclose(ours["ViewLayer.Depth.Z"][both], cycles["ViewLayer.Depth.Z"][both], rtol=1e-4)
    assert (ours["ViewLayer.Depth.Z"][empty] == cycles["ViewLayer.Depth.Z"][empty & ~hit][0]).all()
    normal = np.stack([ours[f"ViewLayer.Normal.{c}"] for c in "XYZ"], axis=-1)
    cycles_normal = np.stack([cycles[f"ViewLayer.Normal.{c}"] for c in "XYZ"], axis=-1)
    np.testing.assert_allclose(normal[both], cycles_normal[both], atol=1e-5)
    # Both sides are in view: the flipped plane shows its back, whose normal points up too.
    assert (normal[both][:, 2] > 0.8).all()
    assert (normal[both][:, 1] < -0.4).sum() > 20 and (np.abs(normal[both][:, 1]) < 1e-3).sum() > 20

    layer.use_pass_z = layer.use_pass_normal = False
    assert set(render_multilayer(bpy, scene, tmp_path / "combined.exr")) == {
        f"ViewLayer.Combined.{c}" for c in "RGBA"}


def test_each_view_layer_gets_its_own_render_as_in_cycles(addon, tmp_path):
    import bpy

    scene = build_film_scene(bpy)
    scene.render.film_transparent = True
    # A second view layer without the tilted plane.
    hidden = bpy.data.collections.new("hidden")
    scene.collection.children.link(hidden)
    tilted = bpy.data.objects["Plane"]
    scene.collection.objects.unlink(tilted)
    hidden.objects.link(tilted)
    scene.view_layers.new("Second").layer_collection.children["hidden"].exclude = True
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 1
    scene.cycles.filter_width = 0.01
    scene.cycles.device = "CPU"
    cycles = render_multilayer(bpy, scene, tmp_path / "cycles.exr")
    scene.render.engine = "HYBRID_RT"
    ours = render_multilayer(bpy, scene, tmp_path / "ours.exr")
    covered = {}
    for layer in ("ViewLayer", "Second"):
        alpha, expected = ours[f"{layer}.Combined.A"], cycles[f"{layer}.Combined.A"]
        assert ((alpha > 0) != (expected > 0)).sum() <= 2, layer
        covered[layer] = int((alpha > 0).sum())
    assert covered["ViewLayer"] > covered["Second"] + 50 and covered["Second"] > 20


@pytest.mark.parametrize("crop", [False, True])
def test_render_region_renders_the_regions_pixels_of_the_whole_frame(addon, tmp_path, crop):
    import bpy

    scene = build_film_scene(bpy, size=(37, 23))
    scene.render.engine = "HYBRID_RT"
    # Ambient occlusion is screen-space, and the traced diffuse light is smoothed over
    # neighbouring pixels: in a region both see only the region's pixels.
    scene.hybrid_rt.ao_distance = 0.0
    scene.hybrid_rt.world_light = "SCREEN"
    whole = render_exr(bpy, scene, tmp_path / "whole.exr")
    render = scene.render
    render.use_border, render.use_crop_to_border = True, crop
    render.border_min_x, render.border_min_y, render.border_max_x, render.border_max_y = 0.13, 0.27, 0.71, 0.9
    region = render_exr(bpy, scene, tmp_path / "region.exr")
    x0, y0, x1, y1 = 4, 6, 26, 20  # Blender truncates fraction x resolution (test_film.py)
    if crop:
        assert region.shape == (y1 - y0, x1 - x0, 4)
        inside = region
    else:
        assert region.shape == whole.shape
        inside = region[y0:y1, x0:x1]
        outside = region.copy()
        outside[y0:y1, x0:x1] = 0
        assert (outside == 0).all(), "Blender leaves the frame outside the region empty"
    np.testing.assert_allclose(inside, whole[y0:y1, x0:x1], rtol=1e-4, atol=1e-5)


def test_a_resolution_percentage_that_float_arithmetic_gets_one_pixel_short_renders_every_pixel(addon, tmp_path):
    import bpy

    scene = build_plane_scene(bpy, "SUN", 1.0, size=100)
    scene.render.resolution_percentage = 29  # 100 * 0.29 = 28.999...; Blender renders 29 pixels
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.mode = "RASTER"
    image = render_exr(bpy, scene, tmp_path / "frame.exr")
    assert image.shape == (29, 29, 4)
    # The plane fills the frame: a frame one pixel short leaves a column Blender fills with 0.
    assert (image[..., 3] == 1).all() and (image[..., 0] > 0.1).all()


def test_render_samples_antialias_edges_and_keep_the_data_passes_at_pixel_centres(addon, tmp_path):
    import bpy

    scene = build_film_scene(bpy)
    scene.render.engine = "HYBRID_RT"
    scene.render.film_transparent = True
    layer = scene.view_layers[0]
    layer.use_pass_z = True
    one = render_multilayer(bpy, scene, tmp_path / "one.exr")
    scene.hybrid_rt.render_samples = 8
    eight = render_multilayer(bpy, scene, tmp_path / "eight.exr")
    assert set(np.unique(one["ViewLayer.Combined.A"])) == {0.0, 1.0}
    alpha = eight["ViewLayer.Combined.A"]
    partial = (alpha > 0) & (alpha < 1)
    assert partial.sum() >= 10, "edge pixels are partly covered"
    assert (np.round(alpha * 8) == alpha * 8).all(), "alpha is a count of covered samples out of 8"
    np.testing.assert_array_equal(eight["ViewLayer.Depth.Z"], one["ViewLayer.Depth.Z"])
    assert addon.blender_adapter.engine.last_frame.counts["samples"] == 8
    # Film > Pixel Filter spreads the samples: a wider filter softens the edges more.
    scene.render.filter_size = 6.0
    wide = render_multilayer(bpy, scene, tmp_path / "wide.exr")["ViewLayer.Combined.A"]
    assert ((wide > 0) & (wide < 1)).sum() > partial.sum()


def _render_both(bpy, scene, tmp_path, mode="RASTER"):
    """The scene rendered by Cycles (64 samples) and by this engine, as (H, W, 4) arrays."""
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 64
    scene.cycles.device = "CPU"
    cycles = render_exr(bpy, scene, tmp_path / "cycles.exr")
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.mode = mode
    ours = render_exr(bpy, scene, tmp_path / "ours.exr")
    return ours, cycles


def test_a_world_lit_plane_without_lamps_has_the_radiance_cycles_gives_it(addon, tmp_path):
    import bpy

    scene = build_plane_scene(bpy, "SUN", energy=0.0)
    background = scene.world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (0.5, 0.6, 0.7, 1.0)
    background.inputs["Strength"].default_value = 1.0
    ours, cycles = _render_both(bpy, scene, tmp_path)
    centre = (slice(2, -2), slice(2, -2), slice(0, 3))
    assert cycles[centre].mean() > 0.2  # the World really lights the plane
    np.testing.assert_allclose(ours[centre].mean(axis=(0, 1)), cycles[centre].mean(axis=(0, 1)), rtol=0.10)


def test_lamp_exposure_one_doubles_its_light_as_in_cycles(addon, tmp_path):
    import bpy

    scene = build_plane_scene(bpy, "SUN", energy=2.0)
    light = bpy.data.lights["light"]
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.mode = "RASTER"
    plain = render_exr(bpy, scene, tmp_path / "plain.exr")
    light.exposure = 1.0
    ours, cycles = _render_both(bpy, scene, tmp_path)
    centre = (slice(2, -2), slice(2, -2), slice(0, 3))
    np.testing.assert_allclose(ours[centre].mean(axis=(0, 1)), 2.0 * plain[centre].mean(axis=(0, 1)), rtol=0.02)
    np.testing.assert_allclose(ours[centre].mean(axis=(0, 1)), cycles[centre].mean(axis=(0, 1)), rtol=0.02)


@pytest.mark.parametrize("kelvin", [2500.0, 9000.0])
def test_lamp_temperature_gives_blenders_black_body_colour(addon, tmp_path, kelvin):
    import bpy

    scene = build_plane_scene(bpy, "SUN", energy=2.0)
    light = bpy.data.lights["light"]
    light.use_temperature = True
    light.temperature = kelvin
    ours, cycles = _render_both(bpy, scene, tmp_path)
    centre = (slice(2, -2), slice(2, -2), slice(0, 3))
    ours_rgb, cycles_rgb = ours[centre].mean(axis=(0, 1)), cycles[centre].mean(axis=(0, 1))
    # The colour, and the brightness with it, per channel within 2 %.
    np.testing.assert_allclose(ours_rgb, cycles_rgb, rtol=0.02)


def _penumbra_width(profile: np.ndarray, pixel_size: float) -> float:
    """Distance between the 10 % and 90 % crossings of a shadow edge's brightness profile."""
    p = (profile - profile.min()) / max(profile.max() - profile.min(), 1e-12)
    x = np.arange(len(p)) * pixel_size
    rising = p if p[-1] > p[0] else p[::-1]
    return float(np.interp(0.9, rising, x) - np.interp(0.1, rising, x))


def test_a_sun_with_an_angle_casts_a_penumbra_as_wide_as_cycles_does(addon, tmp_path):
    import bpy

    scene = build_plane_scene(bpy, "SUN", energy=3.0, size=96)
    scene.render.resolution_y = 8
    scene.camera.data.ortho_scale = 1.6  # 96 pixels across 1.6 m: 1/60 m a pixel
    light = bpy.data.lights["light"]
    light.angle = np.radians(10.0)
    # A slab 2 m above the floor covering x < 0: its edge's shadow on the floor is straight below.
    bpy.ops.mesh.primitive_cube_add(location=(-3.0, 0.0, 2.0), scale=(3.0, 3.0, 0.05))
    scene.hybrid_rt.shadow_resolution = 4096
    ours, cycles = _render_both(bpy, scene, tmp_path)
    pixel = 1.6 / 96
    widths = {name: _penumbra_width(image[2:-2, :, 1].mean(axis=0), pixel)
              for name, image in (("ours", ours), ("cycles", cycles))}
    expected = 2 * 1.95 * np.tan(np.radians(5.0))  # the sun's disc seen past the edge: about 0.34 m
    assert 0.5 * expected < widths["cycles"] < 1.5 * expected, widths  # the scene does what it should
    assert abs(widths["ours"] - widths["cycles"]) < 0.25 * widths["cycles"], widths


def test_a_tangent_space_normal_map_shades_a_plane_as_cycles_does(addon, tmp_path):
    import bpy

    scene = build_plane_scene(bpy, "SUN", energy=3.0)
    angle = np.radians(35.0)
    image = bpy.data.images.new("tilt", 4, 4, float_buffer=True)
    image.colorspace_settings.name = "Non-Color"
    texel = (np.sin(angle) * 0.5 + 0.5, 0.5, np.cos(angle) * 0.5 + 0.5, 1.0)
    image.pixels.foreach_set(np.tile(np.asarray(texel, np.float32), 16))
    material = bpy.data.objects["Plane"].data.materials[0]
    nodes, links = material.node_tree.nodes, material.node_tree.links
    tex, normal_map = nodes.new("ShaderNodeTexImage"), nodes.new("ShaderNodeNormalMap")
    tex.image = image
    links.new(tex.outputs["Color"], normal_map.inputs["Color"])
    links.new(normal_map.outputs["Normal"], nodes["Principled BSDF"].inputs["Normal"])
    ours, cycles = _render_both(bpy, scene, tmp_path)
    centre = (slice(2, -2), slice(2, -2), slice(0, 3))
    flat = 0.8 / np.pi * 3.0  # red channel without the map
    assert cycles[centre][..., 0].mean() < 0.95 * flat  # the map tilts Cycles' normal too
    np.testing.assert_allclose(ours[centre].mean(axis=(0, 1)), cycles[centre].mean(axis=(0, 1)), rtol=0.03)


def test_roughness_and_metallic_images_shade_as_in_cycles(addon, tmp_path):
    """A plane whose Metallic comes from a packed image's blue channel (through Separate
    Color, as glTF imports it) and whose Roughness from its green: half of it metal, half
    of it a rough dielectric, lit by a sun and a bright World; the two halves match Cycles."""
    import bpy

    scene = build_plane_scene(bpy, "SUN", energy=2.0, size=32)
    background = scene.world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (0.4, 0.5, 0.7, 1.0)
    background.inputs["Strength"].default_value = 1.0
    image = bpy.data.images.new("orm", 64, 32, float_buffer=True)
    image.colorspace_settings.name = "Non-Color"
    texels = np.zeros((32, 64, 4), np.float32)
    texels[:, :32] = (0.0, 0.3, 1.0, 1.0)  # left: metal, roughness 0.3
    texels[:, 32:] = (0.0, 0.9, 0.0, 1.0)  # right: a rough dielectric
    image.pixels.foreach_set(texels.ravel())
    material = bpy.data.objects["Plane"].data.materials[0]
    nodes, links = material.node_tree.nodes, material.node_tree.links
    bsdf = nodes["Principled BSDF"]
    bsdf.inputs["Specular IOR Level"].default_value = 0.5
    tex, split = nodes.new("ShaderNodeTexImage"), nodes.new("ShaderNodeSeparateColor")
    tex.image, tex.interpolation = image, "Closest"
    links.new(tex.outputs["Color"], split.inputs["Color"])
    links.new(split.outputs["Green"], bsdf.inputs["Roughness"])
    links.new(split.outputs["Blue"], bsdf.inputs["Metallic"])
    bpy.data.objects["Plane"].scale = (0.025, 0.025, 1.0)  # the image across the 1 m view
    ours, cycles = _render_both(bpy, scene, tmp_path, mode="FULL_BVH")
    halves = {"metal": (slice(4, -4), slice(3, 13)), "rough": (slice(4, -4), slice(19, 29))}
    got = {k: ours[v][..., :3].mean(axis=(0, 1)) for k, v in halves.items()}
    want = {k: cycles[v][..., :3].mean(axis=(0, 1)) for k, v in halves.items()}
    assert np.abs(want["metal"] - want["rough"]).max() > 0.05  # the image makes two surfaces
    for key in halves:
        np.testing.assert_allclose(got[key], want[key], rtol=0.1, err_msg=key)


@pytest.mark.parametrize("space", ["sRGB", "Linear Rec.709", "Non-Color", "ACEScg"])
def test_a_texture_in_each_colour_space_glows_as_in_cycles(addon, tmp_path, space):
    """A byte image in a colour space drives a plane's emission: converted to the working
    space by OpenColorIO with Blender's config, it matches Cycles within 2 %."""
    import bpy

    scene = build_plane_scene(bpy, "SUN", energy=0.0, size=8)
    image = bpy.data.images.new(f"tex {space}", 4, 4)  # 8 bits per channel
    image.colorspace_settings.name = space
    image.pixels.foreach_set(np.tile(np.array([0.8, 0.4, 0.2, 1.0], np.float32), 16))
    material = bpy.data.objects["Plane"].data.materials[0]
    nodes, links = material.node_tree.nodes, material.node_tree.links
    bsdf = nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    bsdf.inputs["Emission Strength"].default_value = 1.0
    texture = nodes.new("ShaderNodeTexImage")
    texture.image = image
    links.new(texture.outputs["Color"], bsdf.inputs["Emission Color"])
    ours, cycles = _render_both(bpy, scene, tmp_path)
    centre = (slice(2, -2), slice(2, -2), slice(0, 3))
    want = cycles[centre].mean(axis=(0, 1))
    np.testing.assert_allclose(ours[centre].mean(axis=(0, 1)), want, rtol=0.02, err_msg=space)
    if space == "ACEScg":  # a wider gamut: Rec.709 red comes out redder than the stored 0.8
        assert want[0] > 0.8 * 1.05


# ---------------------------------------------------------------------------------------------
# Denoising Data: the Denoising Albedo and Normal passes, and the compositor's Denoise node on them.

def test_denoising_data_passes_match_cycles_on_both_sides_of_a_plane(addon, tmp_path):
    """Cycles' own passes are the oracle: the same names, the normal in its camera space (the
    side the camera sees), the albedo of a diffuse surface its colour."""
    import bpy

    scene = build_film_scene(bpy)
    layer = scene.view_layers[0]
    layer.cycles.denoising_store_passes = True
    layer.hybrid_rt.denoising_store_passes = True
    scene.render.film_transparent = True
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 1
    scene.cycles.filter_width = 0.01  # one sample at each pixel's centre, like a rasterizer
    scene.cycles.device = "CPU"
    cycles = render_multilayer(bpy, scene, tmp_path / "cycles.exr")
    scene.render.engine = "HYBRID_RT"
    ours = render_multilayer(bpy, scene, tmp_path / "ours.exr")
    both = (ours["ViewLayer.Combined.A"] == 1) & (cycles["ViewLayer.Combined.A"] == 1)
    assert both.sum() > 100
    for name, channels, atol in (("Denoising Normal", "XYZ", 1e-4), ("Denoising Albedo", "RGB", 0.01)):
        mine = np.stack([ours[f"ViewLayer.{name}.{c}"] for c in channels], axis=-1)
        theirs = np.stack([cycles[f"ViewLayer.{name}.{c}"] for c in channels], axis=-1)
        np.testing.assert_allclose(mine[both], theirs[both], atol=atol, err_msg=name)
    normal_z = ours["ViewLayer.Denoising Normal.Z"][both]
    assert (normal_z < -0.1).all(), "every normal faces the camera (Cycles' z points into the view)"
    layer.hybrid_rt.denoising_store_passes = False
    assert not any("Denoising" in name for name in render_multilayer(bpy, scene, tmp_path / "off.exr"))


def test_the_denoising_data_switch_adds_and_removes_the_render_layers_nodes_sockets(addon):
    """As Cycles' switch does: a compositor setup made before the switch is turned on sees
    the passes at once (the property asks the engine for its passes again)."""
    import bpy

    scene = bpy.context.scene
    scene.render.engine = "HYBRID_RT"
    scene.compositing_node_group = tree = bpy.data.node_groups.new("Passes", "CompositorNodeTree")
    layers = tree.nodes.new("CompositorNodeRLayers")

    def shown():
        return {socket.name for socket in layers.outputs if socket.enabled}

    assert not shown() & {"Denoising Albedo", "Denoising Normal"}
    scene.view_layers[0].hybrid_rt.denoising_store_passes = True
    assert {"Denoising Albedo", "Denoising Normal"} <= shown()
    scene.view_layers[0].hybrid_rt.denoising_store_passes = False
    assert not shown() & {"Denoising Albedo", "Denoising Normal"}


def build_glossy_scene(bpy):
    """Three coloured cubes on a rough metal floor under a sun and a dim World, seen at an
    angle: at one sample per pixel the floor's sampled glossy reflections are noisy."""
    import math

    def material(name, color, metallic=0.0, roughness=0.5):
        mat = bpy.data.materials.new(name)
        bsdf = mat.node_tree.nodes["Principled BSDF"]
        bsdf.inputs["Base Color"].default_value = (*color, 1.0)
        bsdf.inputs["Metallic"].default_value = metallic
        bsdf.inputs["Roughness"].default_value = roughness
        return mat

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=12)
    bpy.context.object.data.materials.append(material("floor", GLOSSY_FLOOR, metallic=1.0, roughness=0.3))
    for i, (x, y, color) in enumerate([(-1.5, 1.0, (0.9, 0.1, 0.1)), (1.5, 1.5, (0.1, 0.8, 0.2)),
                                       (0.2, 2.5, (0.1, 0.2, 0.9))]):
        bpy.ops.mesh.primitive_cube_add(size=1.0, location=(x, y, 0.5))
        bpy.context.object.data.materials.append(material(f"cube{i}", color))
    bpy.ops.object.light_add(type="SUN", location=(0, 0, 5), rotation=(0.5, 0.3, 0))
    bpy.context.object.data.energy = 3.0
    bpy.context.object.data.angle = math.radians(10)
    cam_obj = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    cam_obj.location, cam_obj.rotation_euler = (0, -6, 4), (math.radians(58), 0, 0)
    scene.collection.objects.link(cam_obj)
    scene.camera = cam_obj
    scene.world = bpy.data.worlds.new("world")
    scene.world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.5
    scene.render.resolution_x, scene.render.resolution_y = 64, 48
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.mode = "HYBRID"
    return scene


GLOSSY_FLOOR = (0.8, 0.6, 0.4)


def denoise_in_compositor(bpy, scene):
    """Blender 5's compositor: Render Layers -> Denoise (Image, Albedo, Normal) -> Group Output."""
    tree = bpy.data.node_groups.new("Denoise", "CompositorNodeTree")
    scene.compositing_node_group = tree
    layers, denoise, output = (tree.nodes.new(kind) for kind in
                               ("CompositorNodeRLayers", "CompositorNodeDenoise", "NodeGroupOutput"))
    tree.interface.new_socket("Image", in_out="OUTPUT", socket_type="NodeSocketColor")
    tree.links.new(layers.outputs["Image"], denoise.inputs["Image"])
    tree.links.new(layers.outputs["Denoising Albedo"], denoise.inputs["Albedo"])
    tree.links.new(layers.outputs["Denoising Normal"], denoise.inputs["Normal"])
    tree.links.new(denoise.outputs["Image"], output.inputs["Image"])


def _rgb(channels, layer, name, components="RGB"):
    return np.stack([channels[f"{layer}.{name}.{c}"] for c in components], axis=-1)


def test_the_compositors_denoise_node_cleans_a_one_sample_render_with_our_denoising_data(addon, tmp_path):
    import bpy

    scene = build_glossy_scene(bpy)
    scene.view_layers[0].hybrid_rt.denoising_store_passes = True
    denoise_in_compositor(bpy, scene)  # fails here without the passes: no such sockets
    scene.hybrid_rt.render_samples = 1
    one = render_multilayer(bpy, scene, tmp_path / "one.exr")
    scene.hybrid_rt.render_samples = 32
    reference = _rgb(render_multilayer(bpy, scene, tmp_path / "many.exr"), "ViewLayer", "Combined")

    # The guides: the floor's colour and its face normal at the centre pixel, which sees the
    # floor at the origin.
    albedo = _rgb(one, "ViewLayer", "Denoising Albedo")
    normal = _rgb(one, "ViewLayer", "Denoising Normal", "XYZ")
    np.testing.assert_allclose(albedo[24, 32], GLOSSY_FLOOR, atol=2e-3)
    camera_axes = np.array(scene.camera.matrix_world.to_3x3())
    np.testing.assert_allclose(normal[24, 32], np.diag([1, 1, -1]) @ camera_axes.T @ (0, 0, 1), atol=1e-5)

    noisy, denoised = _rgb(one, "ViewLayer", "Combined"), _rgb(one, "Composite", "Combined")

    def rmse(a, b):
        return float(np.sqrt(np.mean((a - b) ** 2)))

    def local_variance(image):
        windows = np.lib.stride_tricks.sliding_window_view(image, (3, 3), axis=(0, 1))
        return float(windows.var(axis=(-2, -1)).mean())

    assert rmse(noisy, denoised) > 0.01, "the Denoise node changed the render"
    assert rmse(denoised, reference) < 0.7 * rmse(noisy, reference), "denoised is nearer the converged render"
    assert local_variance(denoised) < 0.8 * local_variance(noisy)


def test_a_clear_error_is_printed_once_and_without_a_traceback(addon, tmp_path, capfd):
    """A camera the engine cannot render stops F12 with its message, printed once; a
    traceback is for bugs, not for what the artist can change."""
    import bpy

    scene = build_plane_scene(bpy, "SUN", 1.0, size=8)
    scene.render.engine = "HYBRID_RT"
    scene.camera.data.type = "PANO"
    capfd.readouterr()
    with pytest.raises(RuntimeError, match="PANO"):
        render_exr(bpy, scene, tmp_path / "frame.exr")
    printed = capfd.readouterr()
    both = printed.out + printed.err
    assert "Traceback" not in both, both
    assert both.count("renders perspective and orthographic cameras only") == 1, both


def test_an_unexpected_error_keeps_its_traceback(addon, tmp_path, capfd, monkeypatch):
    import bpy

    def broken(*_args, **_kwargs):
        raise ZeroDivisionError("a bug")

    monkeypatch.setattr(addon.blender_adapter.engine, "render_depsgraph", broken)
    scene = build_plane_scene(bpy, "SUN", 1.0, size=8)
    scene.render.engine = "HYBRID_RT"
    capfd.readouterr()
    with pytest.raises(RuntimeError, match="a bug"):
        render_exr(bpy, scene, tmp_path / "frame.exr")
    printed = capfd.readouterr()
    assert "Traceback" in printed.out + printed.err


@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_a_non_finite_vertex_changes_nothing_but_its_own_triangles(addon, tmp_path, bad):
    """A mesh whose second triangle has a NaN or infinite corner renders bit for bit as the
    same mesh without that triangle: no scene bounds, sun shadow fit, shadow atlas slot, near
    cube or BVH is computed from the bad vertex (HYBRID runs every one of them)."""
    import bpy

    scene = build_plane_scene(bpy, "SUN", 3.0, size=24)
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.mode = "HYBRID"
    sun = next(obj for obj in scene.objects if obj.type == "LIGHT")
    sun.rotation_euler = (0.5, 0.3, 0.0)
    scene.camera.data.ortho_scale = 6.0

    def render_with(bad_triangle: bool) -> np.ndarray:
        for obj in [obj for obj in scene.objects if obj.name.startswith("card")]:
            bpy.data.objects.remove(obj)
        mesh = bpy.data.meshes.new("card")
        faces = [(0, 1, 2), (1, 2, 3)] if bad_triangle else [(0, 1, 2)]
        mesh.from_pydata([(0, 0, 0.5), (1, 0, 0.5), (0, 1, 1.0), (0.2, 0.2, 0.7)], [], faces)
        if bad_triangle:
            mesh.vertices[3].co = (bad, 0.0, 0.0)
        card = bpy.data.objects.new("card", mesh)
        scene.collection.objects.link(card)
        return render_exr(bpy, scene, tmp_path / f"card_{bad_triangle}.exr")

    clean = render_with(False)
    broken = render_with(True)
    assert clean[..., :3].std() > 0.01  # the card's shadow and the plane: a picture, not a blank
    np.testing.assert_array_equal(broken, clean)


def build_ball_beside_wall_scene(bpy):
    """A red ball beside a grey wall on a grey floor, lit by a sun from the wall's side of the
    ball and a grey World, seen from afar through a near cube that holds nothing (Near Size
    0.5): every traced path meets the scene in the cube map."""
    from mathutils import Vector

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=8.0)
    bpy.context.object.data.materials.append(_diffuse_material(bpy, (0.5, 0.5, 0.5)))
    bpy.ops.mesh.primitive_plane_add(size=8.0, location=(-3.0, 0.0, 2.0), rotation=(0.0, math.pi / 2, 0.0))
    bpy.context.object.data.materials.append(_diffuse_material(bpy, (0.7, 0.7, 0.7)))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.8, location=(0.4, 0.6, 0.8), segments=32, ring_count=16)
    bpy.ops.object.shade_smooth()
    bpy.context.object.data.materials.append(_diffuse_material(bpy, (0.8, 0.03, 0.03)))
    sun = bpy.data.lights.new("sun", "SUN")
    sun.energy = 3.0
    sun_obj = bpy.data.objects.new("sun", sun)
    sun_obj.rotation_mode = "QUATERNION"
    sun_obj.rotation_quaternion = Vector((0, 0, -1)).rotation_difference(Vector((0.4, 0.6, -0.7)))
    scene.collection.objects.link(sun_obj)
    world = bpy.data.worlds.new("grey")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.3, 0.32, 0.36, 1.0)
    scene.world = world
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    camera.data.lens = 24.0
    camera.location = (3.6, -4.6, 2.4)
    camera.rotation_euler = (Vector((-0.4, 0.6, 0.8)) - camera.location).to_track_quat("-Z", "Y").to_euler()
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.render.resolution_x, scene.render.resolution_y = 96, 54
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.near_size = 0.5
    return scene


def test_a_final_render_lights_a_wall_beside_a_sunlit_ball_as_the_full_bvh_does(addon, tmp_path):
    """The wall's paths that pass behind the ball as the camera sees it must not meet its
    sunlit, camera-facing side stretched behind it (engine.final_render_settings): the wall
    takes the ball's red as FULL_BVH's render, which traces the whole scene, gives it."""
    import bpy

    scene = build_ball_beside_wall_scene(bpy)
    images = {}
    for mode in ("FULL_BVH", "HYBRID"):
        scene.hybrid_rt.mode = mode
        images[mode] = render_exr(bpy, scene, tmp_path / f"{mode}.exr")[::-1]  # row 0 at the top
    wall = (slice(3, 25), slice(1, 30))  # the wall's upper left, beside and above the ball
    red_over_green = {mode: image[wall][..., 0].mean() / image[wall][..., 1].mean() for mode, image in images.items()}
    assert images["FULL_BVH"][wall][..., 1].mean() > 0.1  # the wall is lit
    assert abs(red_over_green["HYBRID"] - red_over_green["FULL_BVH"]) < 0.04, red_over_green
