# SPDX-License-Identifier: GPL-3.0-or-later
"""Alpha as Blender defines it (gpu_shaders/include/alpha.glsl): a leaf card's holes are
holes in the G-buffer, the shadow maps, the BVH's any-hit traversal and the cube map; a
plane of Alpha 0.3 covers 30 % of its pixels over samples; an opaque scene compiles none of
it. The Cycles comparisons through Blender's render path are at the end."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine import Camera, Geometry, Lights, MaterialTable, RenderSettings, SceneData, Sky
from hybrid_engine.gpu import shader_loader
from hybrid_engine.scene.camera import look_at
from test_textures import textured_quad

SMALL = dict(cube_resolution=64, shadow_resolution=2048, near_size=4.0, shadow_cascades=0)
DISC_RADIUS = 0.35  # in UV units, around the UV square's centre


def disc_image(size: int = 64) -> np.ndarray:
    """White RGBA whose alpha is 1 inside a disc around the centre and 0 elsewhere."""
    centres = (np.arange(size) + 0.5) / size - 0.5
    x, y = np.meshgrid(centres, centres)
    image = np.ones((size, size, 4), np.float32)
    image[..., 3] = (x * x + y * y <= DISC_RADIUS ** 2).astype(np.float32)
    return image


def card_scene(card_row: dict, floor_emission: float = 0.25, lights=(), floor_z: float = -1.0) -> SceneData:
    """A 2 x 2 card at z = 0 (material 0, UVs over [0, 1]^2) above a wide floor."""
    card, card_uv = textured_quad((-1, -1, 0), (2, 0, 0), (0, 2, 0), (0, 0), (1, 1))
    floor, floor_uv = textured_quad((-6, -6, floor_z), (12, 0, 0), (0, 12, 0), (0, 0), (1, 1))
    geo = Geometry.from_objects([(card, None, 0), (floor, None, 1)])
    geo = Geometry(geo.triangles, geo.normals, geo.material_ids, geo.object_ranges, geo.object_bounds,
                   geo.object_names, uvs=np.concatenate([card_uv, floor_uv]))
    floor_row = dict(base_color=(0.0, 0.0, 0.0), emission=(floor_emission,) * 3) if not lights else \
        dict(base_color=(0.8, 0.8, 0.8), specular=0.0)
    rows = [card_row, floor_row]
    return SceneData(geo, MaterialTable.from_rows(rows), Lights.from_rows(list(lights)), Sky(color=(0.0, 0.0, 0.0)))


def top_camera(size: int = 64) -> Camera:
    return Camera(matrix_world=look_at((0, 0, 5), (0, 0, 0), up=(0, 1, 0)), width=size, height=size,
                  projection="ORTHO", ortho_scale=2.0)


def disc_mask(size: int = 64) -> np.ndarray:
    """Where the card's pixel centres (the top view of top_camera) lie inside the disc."""
    centres = (np.arange(size) + 0.5) / size - 0.5
    x, y = np.meshgrid(centres, centres)
    return x * x + y * y <= DISC_RADIUS ** 2


EMISSIVE_CARD = dict(base_color=(0.0, 0.0, 0.0), emission=(1.0, 1.0, 1.0), alpha_texture=disc_image())


def test_a_leaf_cards_holes_show_what_lies_behind_in_the_primary_view(renderer):
    image = renderer.render(card_scene(EMISSIVE_CARD), top_camera(), RenderSettings(mode="RASTER", **SMALL)).image
    covered = image[..., 0] > 0.6
    assert np.isclose(image[~covered, 0], 0.25, atol=0.02).all()  # the floor, seen through the holes
    assert (covered != disc_mask()).mean() <= 0.02


def test_without_alpha_the_card_is_an_opaque_square(renderer):
    row = {k: v for k, v in EMISSIVE_CARD.items() if k != "alpha_texture"}
    image = renderer.render(card_scene(row), top_camera(), RenderSettings(mode="RASTER", **SMALL)).image
    assert (image[..., 0] > 0.6).all()


def test_a_plane_of_alpha_0_3_converges_to_30_percent_coverage(renderer):
    row = dict(base_color=(0.0, 0.0, 0.0), emission=(1.0, 1.0, 1.0), alpha=0.3)
    scene, camera = card_scene(row, floor_emission=0.0), top_camera(32)
    settings = RenderSettings(mode="RASTER", **SMALL)
    samples = [renderer.render(scene, camera, settings, sample=s).image[..., 0] for s in range(48)]
    first = samples[0]
    assert set(np.unique(np.round(first, 3))) <= {0.0, 1.0}  # one sample: dithered, all or nothing
    assert abs(first.mean() - 0.3) < 0.05
    mean = np.mean(samples, axis=0)
    assert abs(mean.mean() - 0.3) < 0.01
    # Each pixel converges on its own (fresh numbers per sample), not a fixed dither pattern.
    assert np.abs(mean - 0.3).max() < 0.3
    assert mean.std() < 0.1


def shadow_view(renderer, card_row: dict) -> np.ndarray:
    """The floor 3 units below and beside the card, where a sun at 45 degrees casts the
    card's shadow, seen from above (the card itself out of view); red channel."""
    sun = dict(kind="SUN", direction=(1, 0, -1), color=(3, 3, 3), radius=0.0)
    camera = Camera(matrix_world=look_at((3, 0, 5), (3, 0, -3), up=(0, 1, 0)), width=64, height=64,
                    projection="ORTHO", ortho_scale=2.0)
    scene = card_scene(card_row, lights=[sun], floor_z=-3.0)
    return renderer.render(scene, camera, RenderSettings(mode="RASTER", **SMALL)).image[..., 0]


def test_the_leaf_cards_shadow_has_its_holes(renderer):
    image = shadow_view(renderer, dict(base_color=(0.8, 0.8, 0.8), alpha_texture=disc_image()))
    lit = image > 0.5 * image.max()
    assert (lit != ~disc_mask()).mean() <= 0.02


def test_without_alpha_the_cards_shadow_is_a_square(renderer):
    image = shadow_view(renderer, dict(base_color=(0.8, 0.8, 0.8)))
    assert image[4:-4, 4:-4].max() < 0.02  # all in shadow (the edges: the shadow filter)


def disc_card_scene(card_row: dict, segments: int = 96) -> SceneData:
    """card_scene with the card cut to the disc in its geometry (a fan of triangles): what
    the alpha-masked card should look like wherever it is seen."""
    scene = card_scene(card_row)
    angles = np.linspace(0.0, 2.0 * np.pi, segments + 1)
    rim = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=-1) * (2.0 * DISC_RADIUS)
    fan = np.stack([np.zeros((segments, 3)), rim[:-1], rim[1:]], axis=1).astype(np.float32)
    fan_uv = (fan[..., :2] / 2.0 + 0.5).astype(np.float32)
    floor = scene.geometry.triangles[2:]
    geo = Geometry.from_objects([(fan, None, 0), (floor, None, 1)])
    geo = Geometry(geo.triangles, geo.normals, geo.material_ids, geo.object_ranges, geo.object_bounds,
                   geo.object_names, uvs=np.concatenate([fan_uv, scene.geometry.uvs[2:]]))
    return SceneData(geo, scene.materials, scene.lights, scene.sky)


def mirror_view(renderer, card_row: dict, mode: str, near_size: float, geometry_disc: bool = False) -> np.ndarray:
    """A mirror floor at z = -1 seen from between it and the card (an orthographic camera at
    z = -0.5 looking down): the mirror shows the card's underside; red channel."""
    scene = disc_card_scene(card_row) if geometry_disc else card_scene(card_row)
    mirror = dict(base_color=(1.0, 1.0, 1.0), reflectivity=1.0, roughness=0.0)
    scene = SceneData(scene.geometry, MaterialTable.from_rows([card_row, mirror]), scene.lights, scene.sky)
    camera = Camera(matrix_world=look_at((0, 0, -0.5), (0, 0, -1), up=(0, 1, 0)), width=64, height=64,
                    projection="ORTHO", ortho_scale=2.0, clip_start=0.01)
    settings = RenderSettings(mode=mode, **{**SMALL, "near_size": near_size, "cube_resolution": 256})
    return renderer.render(scene, camera, settings).image[..., 0]


@pytest.mark.parametrize("mode,near_size", [("FULL_BVH", 4.0), ("HYBRID", 4.0), ("HYBRID", 0.2)],
                         ids=["full_bvh", "bvh", "cube_map"])
def test_a_leaf_cards_holes_show_in_a_mirror(renderer, mode, near_size):
    """As a card cut to the disc in its geometry shows in the same mirror: the cube map's
    march (near_size 0.2) approximates where the reflection lands (paper §3.4), alpha or
    not, so both are seen through it."""
    image = mirror_view(renderer, EMISSIVE_CARD, mode, near_size)
    row = {k: v for k, v in EMISSIVE_CARD.items() if k != "alpha_texture"}
    cut = mirror_view(renderer, row, mode, near_size, geometry_disc=True)
    seen = image > 0.5
    assert (seen != (cut > 0.5)).mean() <= 0.02
    if mode != "HYBRID" or near_size > 1.0:  # traced exactly: the disc itself
        assert (seen != disc_mask()).mean() <= 0.02


@pytest.mark.parametrize("mode,near_size", [("HYBRID", 4.0), ("HYBRID", 0.2)], ids=["bvh", "cube_map"])
def test_without_alpha_the_mirror_shows_the_whole_card(renderer, mode, near_size):
    row = {k: v for k, v in EMISSIVE_CARD.items() if k != "alpha_texture"}
    assert (mirror_view(renderer, row, mode, near_size) > 0.5).mean() > 0.98


def compiled_stages(renderer, scene: SceneData, monkeypatch) -> dict[str, set]:
    """Per shader file a frame of ``scene`` asks for (HYBRID, one sample), whether each was
    asked for with the alpha test: {path: {True/False}}."""
    asked: dict[str, set] = {}
    original = shader_loader._compile

    def spy(ctx, stages, defines):
        for name in stages.values():
            asked.setdefault(str(name), set()).add("ALPHA_TEST" in (defines or {}))
        return original(ctx, stages, defines)

    monkeypatch.setattr(shader_loader, "_compile", spy)
    sun = dict(kind="SUN", direction=(1, 0, -1), color=(3, 3, 3))
    scene = SceneData(scene.geometry, scene.materials, Lights.from_rows([sun]), scene.sky)
    renderer.render(scene, top_camera(16), RenderSettings(mode="HYBRID", **SMALL))
    monkeypatch.setattr(shader_loader, "_compile", original)
    return asked


def test_an_opaque_scene_compiles_no_alpha_test_and_an_alpha_scene_compiles_it_everywhere(renderer, monkeypatch):
    opaque = compiled_stages(renderer, card_scene({k: v for k, v in EMISSIVE_CARD.items() if k != "alpha_texture"}),
                             monkeypatch)
    assert all(flags == {False} for flags in opaque.values()), opaque
    cut = compiled_stages(renderer, card_scene(EMISSIVE_CARD), monkeypatch)
    for stage in ("gbuffer/gbuffer.frag.glsl", "shadow_maps/shadow_depth.frag.glsl", "trace/hybrid_trace.comp.glsl",
                  "diffuse_light/diffuse_gather.comp.glsl"):
        assert True in cut.get(stage, set()), (stage, cut)


def test_the_material_row_holds_alpha_and_its_image_selector():
    table = MaterialTable.from_rows([dict(alpha=0.3), dict(alpha_texture=disc_image(), alpha_channel=1, alpha_clip=0.5),
                                     dict()])
    packed = table.packed()
    np.testing.assert_allclose(packed["params2"][:, 0], [0.3, 1.0, 1.0])
    np.testing.assert_allclose(packed["params2"][:, 1], [0.0, 0.5, 0.0])
    assert list(packed["textures2"][:, 2]) == [-1, 0 * 4 + 1, -1]
    assert table.has_alpha and not MaterialTable.from_rows([dict()]).has_alpha


# -- against Cycles, through Blender's render path ------------------------------------------
def _leaf_card_blender(bpy, card_emits: bool, floor_z: float, floor_kind: str, size: int = 64):
    """A factory-empty scene: a 2 x 2 leaf card at z = 0 whose Principled BSDF takes its
    Alpha from an image's alpha (a disc, as disc_image), above a floor plane ("EMIT": emission
    0.25; "DIFFUSE": grey; "MIRROR": a perfect mirror), black World."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    image = bpy.data.images.new("disc", 64, 64, alpha=True, float_buffer=True)
    image.pixels.foreach_set(disc_image().ravel())
    card_mat = bpy.data.materials.new("card")
    card_mat.use_nodes = True
    nodes, links = card_mat.node_tree.nodes, card_mat.node_tree.links
    bsdf = nodes["Principled BSDF"]
    texture = nodes.new("ShaderNodeTexImage")
    texture.image = image
    links.new(texture.outputs["Alpha"], bsdf.inputs["Alpha"])
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    bsdf.inputs["Roughness"].default_value = 1.0
    if card_emits:
        bsdf.inputs["Base Color"].default_value = (0.0, 0.0, 0.0, 1.0)
        bsdf.inputs["Emission Color"].default_value = (1.0, 1.0, 1.0, 1.0)
        bsdf.inputs["Emission Strength"].default_value = 1.0
    floor_mat = bpy.data.materials.new("floor")
    floor_mat.use_nodes = True
    fb = floor_mat.node_tree.nodes["Principled BSDF"]
    fb.inputs["Specular IOR Level"].default_value = 0.0
    fb.inputs["Roughness"].default_value = 1.0
    if floor_kind == "EMIT":
        fb.inputs["Base Color"].default_value = (0.0, 0.0, 0.0, 1.0)
        fb.inputs["Emission Color"].default_value = (1.0, 1.0, 1.0, 1.0)
        fb.inputs["Emission Strength"].default_value = 0.25
    elif floor_kind == "MIRROR":
        fb.inputs["Base Color"].default_value = (1.0, 1.0, 1.0, 1.0)
        fb.inputs["Metallic"].default_value = 1.0
        fb.inputs["Roughness"].default_value = 0.0
    for name, location, plane_size, material in (("card", (0, 0, 0), 2.0, card_mat),
                                                 ("floor", (0, 0, floor_z), 12.0, floor_mat)):
        bpy.ops.mesh.primitive_plane_add(size=plane_size, location=location)
        bpy.context.object.name = name
        bpy.context.object.data.materials.append(material)
    camera = bpy.data.cameras.new("camera")
    camera.type = "ORTHO"
    camera.ortho_scale = 2.0
    camera.clip_start = 0.01
    camera_object = bpy.data.objects.new("camera", camera)
    scene.collection.objects.link(camera_object)
    scene.camera = camera_object
    world = bpy.data.worlds.new("black")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scene.world = world
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 32
    scene.cycles.use_denoising = False
    scene.cycles.filter_width = 0.01
    scene.hybrid_rt.shadow_resolution = 2048
    scene.hybrid_rt.shadow_cascades = 0
    scene.hybrid_rt.render_samples = 8
    return scene, camera_object


def _both(bpy, scene, tmp_path, mode: str, cycles_bounces: int) -> tuple[np.ndarray, np.ndarray]:
    from test_engine import render_exr

    scene.render.engine = "CYCLES"
    scene.cycles.max_bounces = cycles_bounces
    cycles = render_exr(bpy, scene, tmp_path / "cycles.exr")[..., 0]
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.mode = mode
    ours = render_exr(bpy, scene, tmp_path / "ours.exr")[..., 0]
    return ours, cycles


def _coverage_mismatch(ours: np.ndarray, cycles: np.ndarray, threshold: float) -> float:
    return float(((ours > threshold) != (cycles > threshold)).mean())


def check_primary_view_against_cycles(bpy, tmp_path, recut=None) -> None:
    """The card's holes in the primary view against Cycles' (RASTER). ``recut(scene)``: makes
    the card's coverage anew before the renders (test_closure_alpha.py's graphs)."""
    scene, camera = _leaf_card_blender(bpy, card_emits=True, floor_z=-1.0, floor_kind="EMIT")
    if recut is not None:
        recut(scene, True)
    camera.location = (0.0, 0.0, 5.0)
    ours, cycles = _both(bpy, scene, tmp_path, "RASTER", 0)
    assert 0.2 < (cycles > 0.625).mean() < 0.6  # the disc, with the floor around it
    assert _coverage_mismatch(ours, cycles, 0.625) <= 0.02


def check_shadow_against_cycles(bpy, tmp_path, recut=None) -> None:
    """The card's shadow of a sun on a grey floor against Cycles' (RASTER)."""
    scene, camera = _leaf_card_blender(bpy, card_emits=False, floor_z=-3.0, floor_kind="DIFFUSE")
    if recut is not None:
        recut(scene, False)
    sun = bpy.data.lights.new("sun", "SUN")
    sun.energy = 3.0
    sun.angle = 0.0
    sun_object = bpy.data.objects.new("sun", sun)
    sun_object.rotation_euler = (0.0, -np.pi / 4, 0.0)  # -Z turned to (1, 0, -1)
    scene.collection.objects.link(sun_object)
    camera.location = (3.0, 0.0, 5.0)  # above the shadow, the card out of view
    ours, cycles = _both(bpy, scene, tmp_path, "RASTER", 0)
    lit = 0.5 * cycles.max()
    assert 0.2 < (cycles < lit).mean() < 0.6  # the disc's shadow, lit floor around it
    assert _coverage_mismatch(ours, cycles, lit) <= 0.02


def check_mirror_against_cycles(bpy, tmp_path, recut=None) -> None:
    """The card seen in a mirror floor against Cycles' (HYBRID: the mirror's rays meet the card
    in the near cube, the BVH's any-hit test)."""
    scene, camera = _leaf_card_blender(bpy, card_emits=True, floor_z=-1.0, floor_kind="MIRROR")
    if recut is not None:
        recut(scene, True)
    camera.location = (0.0, 0.0, -0.5)  # between the card and the mirror, looking down
    ours, cycles = _both(bpy, scene, tmp_path, "HYBRID", 4)
    assert 0.2 < (cycles > 0.5).mean() < 0.6
    assert _coverage_mismatch(ours, cycles, 0.5) <= 0.02


def test_a_leaf_cards_holes_match_cycles_in_the_primary_view(addon, tmp_path):
    import bpy

    check_primary_view_against_cycles(bpy, tmp_path)


def test_a_leaf_cards_shadow_matches_cycles(addon, tmp_path):
    import bpy

    check_shadow_against_cycles(bpy, tmp_path)


def test_a_leaf_cards_holes_match_cycles_in_a_mirror(addon, tmp_path):
    import bpy

    check_mirror_against_cycles(bpy, tmp_path)


# -- reading Blender's alpha (blender_adapter/export/alpha.py) --------------------------------
def _principled_material(bpy, name: str = "leaf"):
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    return material, material.node_tree.nodes, material.node_tree.links


def _disc_texture(bpy, nodes):
    image = bpy.data.images.new("disc", 8, 8, alpha=True, float_buffer=True)
    image.pixels.foreach_set(disc_image(8).ravel())
    texture = nodes.new("ShaderNodeTexImage")
    texture.image = image
    return texture


def test_the_reader_takes_an_images_alpha_and_a_gltf_mask_clip(addon):
    import bpy

    read = addon.blender_adapter.export.materials.material_params
    material, nodes, links = _principled_material(bpy)
    bsdf = nodes["Principled BSDF"]
    texture = _disc_texture(bpy, nodes)
    links.new(texture.outputs["Alpha"], bsdf.inputs["Alpha"])
    row = read(material)
    assert row["alpha"] == 1.0 and row["alpha_channel"] == 3 and row["alpha_clip"] == 0.0
    np.testing.assert_array_equal(row["alpha_texture"][..., 3], disc_image(8)[..., 3])
    # glTF MASK as Blender's importer builds it: 1 - (alpha < cutoff).
    less, subtract = nodes.new("ShaderNodeMath"), nodes.new("ShaderNodeMath")
    less.operation, subtract.operation = "LESS_THAN", "SUBTRACT"
    less.inputs[1].default_value = 0.4
    subtract.inputs[0].default_value = 1.0
    links.new(texture.outputs["Alpha"], less.inputs[0])
    links.new(less.outputs[0], subtract.inputs[1])
    links.new(subtract.outputs[0], bsdf.inputs["Alpha"])
    row = read(material)
    assert row["alpha_channel"] == 3 and row["alpha_clip"] == pytest.approx(0.4)


def test_the_reader_takes_a_transparent_mix_and_reads_the_other_shader(addon):
    import bpy

    read = addon.blender_adapter.export.materials.material_params
    material, nodes, links = _principled_material(bpy)
    bsdf = nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.2, 0.4, 0.6, 1.0)
    transparent, mix = nodes.new("ShaderNodeBsdfTransparent"), nodes.new("ShaderNodeMixShader")
    links.new(transparent.outputs[0], mix.inputs[1])
    links.new(bsdf.outputs[0], mix.inputs[2])
    links.new(mix.outputs[0], nodes["Material Output"].inputs["Surface"])
    mix.inputs[0].default_value = 0.3
    row = read(material)
    assert row["alpha"] == pytest.approx(0.3)
    np.testing.assert_allclose(row["base_color"], (0.2, 0.4, 0.6), rtol=1e-6)
    links.new(_disc_texture(bpy, nodes).outputs["Alpha"], mix.inputs[0])  # the cut-out setup
    row = read(material)
    assert row["alpha"] == 1.0 and row["alpha_channel"] == 3


def test_a_blended_material_is_told_once_that_it_renders_dithered(addon):
    import bpy

    messages = addon.blender_adapter.messages
    read = addon.blender_adapter.export.materials.material_params
    material, _, _ = _principled_material(bpy, "glass pane")
    with messages.collecting() as told:
        read(material)
    assert not any("Blended" in m for m in told)
    material.surface_render_method = "BLENDED"
    with messages.collecting() as told:
        read(material)
        read(material)
    assert [m for m in told if "Blended" in m] == [
        "glass pane: Render Method Blended is rendered dithered: stochastic coverage that the samples "
        "average into the blend (as Cycles renders it), not EEVEE's sorted blending"]
