# SPDX-License-Identifier: GPL-3.0-or-later
"""Cryptomatte (hybrid_engine/scene/cryptomatte.py, passes/film/cryptomatte.py): Blender's ids
and manifest, and the passes' anti-aliased coverage through the renderer. Blender's side (the
compositor's Cryptomatte node, the manifest against Cycles') is in test_engine.py."""
from __future__ import annotations

import json
import struct

import numpy as np
import pytest

from hybrid_engine import Camera, Geometry, Lights, MaterialTable, RenderSettings, SceneData, Sky
from hybrid_engine.frame.antialias import render_antialiased
from hybrid_engine.frame.film import FrameOutputs
from hybrid_engine.passes.film.accumulate import AccumulationError
from hybrid_engine.scene import cryptomatte
from hybrid_engine.scene.camera import look_at
from hybrid_engine.scene.cryptomatte import CryptomatteRequest, name_id
from scenes_analytic import box, quad

SMALL = dict(cube_resolution=32, shadow_resolution=128, near_size=2.0)
# Cycles' manifest of one scene (Blender 5.0.1, objects Plane, Ball, Sun and material Red) and
# the metadata keys of its layers: the hashes Blender computes for these names.
CYCLES_HASHES = {"Plane": "4159b52a", "Ball": "74d3ebe9", "Sun": "ee8d1ae3", "Red": "6e1a9181",
                 "default_surface": "78d05529"}
CYCLES_KEYS = {"ViewLayer.CryptoObject": "cryptomatte/542cafa", "ViewLayer.CryptoMaterial": "cryptomatte/c7dbf5e",
               "ViewLayer.CryptoAsset": "cryptomatte/aa21542"}


def test_name_hashes_and_metadata_keys_are_blenders():
    assert {name: f"{cryptomatte.name_hash(name):08x}" for name in CYCLES_HASHES} == CYCLES_HASHES
    assert {layer: cryptomatte.metadata_key(layer) for layer in CYCLES_KEYS} == CYCLES_KEYS
    fields = cryptomatte.metadata("ViewLayer", "object", ["Plane", "Ball"])
    assert fields["cryptomatte/542cafa/name"] == "ViewLayer.CryptoObject"
    assert fields["cryptomatte/542cafa/hash"] == "MurmurHash3_32"
    assert fields["cryptomatte/542cafa/conversion"] == "uint32_to_float32"
    assert json.loads(fields["cryptomatte/542cafa/manifest"]) == {"Plane": "4159b52a", "Ball": "74d3ebe9"}


def test_an_id_is_the_hashs_bits_with_the_exponent_kept_finite_and_normal():
    value = cryptomatte.name_hash("Plane")
    assert struct.pack("<f", name_id("Plane")) == struct.pack("<I", value)  # an ordinary exponent: as is
    for bits, exponent in ((0x00000001, 1), (0xFF800001, 254)):
        number = cryptomatte.hash_to_float(bits)
        assert (struct.unpack("<I", struct.pack("<f", number))[0] >> 23) & 0xFF == exponent
        assert np.isfinite(number) and number != 0.0


def box_scene() -> SceneData:
    """A floor (object Floor, material grey) with a box on it (object Box, material red)."""
    mats = MaterialTable.from_rows([dict(name="grey", base_color=(0.8, 0.8, 0.8)),
                                    dict(name="red", base_color=(0.8, 0.1, 0.1))])
    floor = quad((0, 0, 0), (3, 0, 0), (0, 3, 0))
    return SceneData(Geometry.from_objects([(floor, None, 0), (box((-0.7, -0.5, 0), (0.6, 0.7, 1.1)), None, 1)],
                                           names=["Floor", "Box"]), mats,
                     Lights.from_rows([dict(kind="SUN", direction=(0.2, 0.3, -1), color=(2, 2, 2))]),
                     Sky(color=(0.2, 0.3, 0.5)))


CAMERA = Camera(matrix_world=look_at((1.3, -4.5, 3.2), (0.0, 0.0, 0.4)), width=40, height=30, lens=35.0)


def coverage_of(passes: dict[str, np.ndarray], prefix: str, ident: float) -> np.ndarray:
    """What the Cryptomatte node computes for one id: the sum of its ranks' coverages."""
    total = np.zeros(next(iter(passes.values())).shape[:2], np.float32)
    for name, data in passes.items():
        if name.startswith(prefix):
            for pair in (data[..., 0:2], data[..., 2:4]):
                total += np.where(pair[..., 0] == np.float32(ident), pair[..., 1], 0.0)
    return total


def render_crypto(renderer, samples: int, levels: int = 6):
    request = CryptomatteRequest(("object", "material", "asset"), levels)
    return render_antialiased(renderer, box_scene(), CAMERA, RenderSettings(mode="RASTER", **SMALL), samples,
                              outputs=FrameOutputs(cryptomatte=request)).data_passes


def test_object_material_and_asset_passes_hold_ranked_antialiased_coverage(renderer):
    passes = render_crypto(renderer, samples=16)
    assert sorted(passes) == sorted(f"{kind}0{i}" for kind in ("CryptoObject", "CryptoMaterial", "CryptoAsset")
                                    for i in range(3))
    box_matte = coverage_of(passes, "CryptoObject", name_id("Box"))
    floor_matte = coverage_of(passes, "CryptoObject", name_id("Floor"))
    interior = box_matte > 0.999
    edge = (box_matte > 0.02) & (box_matte < 0.98)
    assert interior.sum() > 40 and edge.sum() > 15, "the box shows an interior and anti-aliased edges"
    np.testing.assert_allclose(box_matte[interior], 1.0, atol=1e-3)
    # Coverages of the pixel's ids sum to its covered share: 1 wherever the floor or the box fill it.
    filled = (box_matte + floor_matte) > 0.999
    assert filled.sum() > 0.5 * box_matte.size
    # The material and asset (an object without parent: its own name) passes hold the same mattes.
    np.testing.assert_allclose(coverage_of(passes, "CryptoMaterial", name_id("red")), box_matte, atol=1e-6)
    np.testing.assert_allclose(coverage_of(passes, "CryptoAsset", name_id("Box")), box_matte, atol=1e-6)
    # Ranked by coverage: rank 0 holds at least as much as rank 1, and so on over the passes.
    ranks = np.concatenate([passes[f"CryptoObject0{i}"][..., [1, 3]] for i in range(3)], axis=-1)
    assert (np.diff(ranks, axis=-1) <= 0).all()


def test_one_sample_gives_whole_pixels_and_the_levels_set_the_passes(renderer):
    passes = render_crypto(renderer, samples=1, levels=3)
    assert sorted(passes) == ["CryptoAsset00", "CryptoAsset01", "CryptoMaterial00", "CryptoMaterial01",
                              "CryptoObject00", "CryptoObject01"]
    coverage = passes["CryptoObject00"][..., 1]
    assert set(np.unique(coverage)) <= {0.0, 1.0}


def test_a_card_of_alpha_0_3_gives_seven_tenths_of_its_coverage_to_the_floor_it_shows(renderer):
    # The passes count what each sample's G-buffer shows, so a surface the alpha test lets
    # through gives its samples to what lies behind it: Cryptomatte's mattes take
    # transparency into account (the standard, and Blender's manual of its node).
    mats = MaterialTable.from_rows([dict(name="grey", base_color=(0.8, 0.8, 0.8)),
                                    dict(name="veil", base_color=(0.8, 0.1, 0.1), alpha=0.3)])
    card = quad((0.0, 0.0, 0.5), (0.8, 0, 0), (0, 0.8, 0))
    scene = SceneData(Geometry.from_objects([(quad((0, 0, 0), (3, 0, 0), (0, 3, 0)), None, 0), (card, None, 1)],
                                            names=["Floor", "Card"]), mats,
                      Lights.from_rows([dict(kind="SUN", direction=(0.2, 0.3, -1), color=(2, 2, 2))]),
                      Sky(color=(0.2, 0.3, 0.5)))
    request = CryptomatteRequest(("object",), 6)
    passes = render_antialiased(renderer, scene, CAMERA, RenderSettings(mode="RASTER", **SMALL), 64,
                                outputs=FrameOutputs(cryptomatte=request)).data_passes
    card_matte = coverage_of(passes, "CryptoObject", name_id("Card"))
    floor_matte = coverage_of(passes, "CryptoObject", name_id("Floor"))
    seen = card_matte > 0.0
    interior = seen & (card_matte + floor_matte > 0.999)
    assert interior.sum() > 30
    assert abs(float(card_matte[interior].mean()) - 0.3) < 0.05
    assert abs(float(floor_matte[interior].mean()) - 0.7) < 0.05


def test_a_sample_that_does_not_follow_the_last_is_refused(renderer):
    request = CryptomatteRequest(("object",))
    settings = RenderSettings(mode="RASTER", **SMALL)
    renderer.render(box_scene(), CAMERA, settings, outputs=FrameOutputs(cryptomatte=request), accumulate=True)
    with pytest.raises(AccumulationError):
        renderer.render(box_scene(), CAMERA, settings, outputs=FrameOutputs(cryptomatte=request),
                        accumulate=True, sample=3)


# -- Blender's side: the compositor's Cryptomatte node and Cycles' manifest ------------------------

def build_ball_scene(bpy):
    """A ball parented to a plane (its asset is the plane), a sun and a camera, with every
    Cryptomatte kind asked for at the default 6 levels."""
    import math

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=10)
    plane = bpy.context.object
    plane.data.materials.append(bpy.data.materials.new("Ground"))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0, location=(0, 0, 1))
    ball = bpy.context.object
    ball.name = "Ball"
    ball.parent = plane
    ball.data.materials.append(bpy.data.materials.new("Red"))
    bpy.ops.object.light_add(type="SUN")
    camera = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    camera.location, camera.rotation_euler = (0, -6, 3), (math.radians(70), 0, 0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.render.resolution_x, scene.render.resolution_y = 48, 32
    scene.render.resolution_percentage = 100
    layer = scene.view_layers[0]
    layer.use_pass_cryptomatte_object = layer.use_pass_cryptomatte_material = True
    layer.use_pass_cryptomatte_asset = True
    settings = scene.render.image_settings
    settings.media_type = "MULTI_LAYER_IMAGE"
    settings.file_format = "OPEN_EXR_MULTILAYER"
    settings.exr_codec = "NONE"
    settings.color_depth = "32"
    return scene


def matte_in_compositor(bpy, scene, layer_name: str, names: str) -> None:
    """Render Layers' image -> Cryptomatte (the render's ``layer_name`` layer, ``names``
    picked) -> its Matte as the composite."""
    tree = bpy.data.node_groups.new("Matte", "CompositorNodeTree")
    scene.compositing_node_group = tree
    crypto, output = tree.nodes.new("CompositorNodeCryptomatteV2"), tree.nodes.new("NodeGroupOutput")
    layers = tree.nodes.new("CompositorNodeRLayers")
    crypto.source, crypto.scene, crypto.layer_name = "RENDER", scene, layer_name
    crypto.matte_id = names
    tree.interface.new_socket("Image", in_out="OUTPUT", socket_type="NodeSocketColor")
    tree.links.new(layers.outputs["Image"], crypto.inputs["Image"])
    tree.links.new(crypto.outputs["Matte"], output.inputs["Image"])


def render_with_metadata(bpy, scene, path) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """Render and save a multilayer EXR; its channels and its Cryptomatte metadata."""
    from image_io import _oiio, read_exr_channels

    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    source = _oiio().ImageInput.open(str(path))
    try:
        fields = {a.name: a.value for a in source.spec().extra_attribs if a.name.startswith("cryptomatte/")}
    finally:
        source.close()
    return read_exr_channels(path), fields


@pytest.mark.parametrize("layer_name, picked", [("ViewLayer.CryptoObject", "Ball"),
                                                ("ViewLayer.CryptoMaterial", "Red")])
def test_the_compositors_cryptomatte_node_extracts_an_antialiased_matte(addon, tmp_path, layer_name, picked):
    import bpy

    scene = build_ball_scene(bpy)
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.render_samples = 16
    matte_in_compositor(bpy, scene, layer_name, picked)
    channels, _ = render_with_metadata(bpy, scene, tmp_path / "ours.exr")
    matte = channels["Composite.Combined.R"]
    interior, edge = matte > 0.99, (matte > 0.02) & (matte < 0.98)
    assert interior.sum() > 100 and edge.sum() > 20, (interior.sum(), edge.sum())
    np.testing.assert_allclose(matte[interior], 1.0, atol=1e-3)
    assert (matte[0] == 0).all(), "the bottom row sees only the plane"


def test_our_manifest_and_passes_are_named_as_cycles_writes_them(addon, tmp_path):
    import bpy

    scene = build_ball_scene(bpy)
    scene.render.engine = "CYCLES"
    scene.cycles.samples, scene.cycles.device = 4, "CPU"
    cycles_channels, cycles = render_with_metadata(bpy, scene, tmp_path / "cycles.exr")
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.render_samples = 4
    ours_channels, ours = render_with_metadata(bpy, scene, tmp_path / "ours.exr")
    assert {name for name in cycles_channels if ".Crypto" in name} == \
        {name for name in ours_channels if ".Crypto" in name}
    assert {key for key in cycles if not key.endswith("manifest")} == {key for key in ours if not key.endswith("manifest")}
    for key, value in cycles.items():
        if key.endswith("/manifest"):
            mine, theirs = json.loads(ours[key]), json.loads(value)
            if cycles[key.replace("manifest", "name")].endswith("CryptoMaterial"):
                # Cycles lists its own built-in shaders too; every name we list is Cycles'.
                theirs = {name: h for name, h in theirs.items() if name in mine}
            assert mine == theirs, key
        else:
            assert ours[key] == value, key
    # The ball's id where Cycles sees it most.
    ball = np.float32(name_id("Ball"))
    assert ((ours_channels["ViewLayer.CryptoObject00.r"] == ball)
            == (cycles_channels["ViewLayer.CryptoObject00.r"] == ball)).mean() > 0.95
