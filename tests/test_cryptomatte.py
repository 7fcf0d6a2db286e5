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


def test_a_sample_that_does_not_follow_the_last_is_refused(renderer):
    request = CryptomatteRequest(("object",))
    settings = RenderSettings(mode="RASTER", **SMALL)
    renderer.render(box_scene(), CAMERA, settings, outputs=FrameOutputs(cryptomatte=request), accumulate=True)
    with pytest.raises(AccumulationError):
        renderer.render(box_scene(), CAMERA, settings, outputs=FrameOutputs(cryptomatte=request),
                        accumulate=True, sample=3)
