# SPDX-License-Identifier: GPL-3.0-or-later
"""Principled BSDF → paper material mapping (hybrid_engine/scene/materials.py), without Blender.

The extractor and the material panel both use this one function, so its documented blend
is checked here against an independent restatement of DESIGN.md's rules.
"""
from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from hybrid_engine.scene.materials import DEFAULT_IOR, DEFAULT_THICKNESS, MIN_IOR, principled_to_params
from hybrid_engine.scene.data import MaterialTable

EXACT = 1e-12  # pure float arithmetic on a few numbers: no rounding beyond one ulp or two


def test_metallic_one_roughness_zero_is_a_perfect_mirror_tinted_by_base_color():
    row = principled_to_params(base_color=(0.9, 0.6, 0.2), metallic=1.0, roughness=0.0)
    assert row["reflectivity"] == 1.0
    assert row["transmission"] == 0.0
    assert row["base_color"] == pytest.approx((0.9, 0.6, 0.2))


def test_transmission_one_roughness_zero_is_clear_glass_of_the_given_ior():
    row = principled_to_params(transmission=1.0, roughness=0.0, metallic=0.0, ior=1.33)
    assert row["transmission"] == 1.0
    assert row["reflectivity"] == 0.0
    assert row["ior"] == pytest.approx(1.33)


def test_default_principled_bsdf_is_diffuse():
    """Blender's default Principled BSDF (roughness 0.5, metallic 0, no transmission)."""
    row = principled_to_params()
    assert row["reflectivity"] == 0.0 and row["transmission"] == 0.0
    assert row["base_color"] == pytest.approx((0.8, 0.8, 0.8))
    assert row["thickness"] == DEFAULT_THICKNESS


def test_blend_follows_the_documented_formulas_and_never_exceeds_one():
    """reflectivity = m, transmission = t (1 - m), roughness as given, on a grid of inputs."""
    grid = np.linspace(0.0, 1.0, 6)
    for m, r, t in itertools.product(grid, grid, grid):
        row = principled_to_params(metallic=m, roughness=r, transmission=t)
        assert abs(row["reflectivity"] - m) < EXACT
        assert abs(row["transmission"] - t * (1 - m)) < EXACT
        assert row["roughness"] == r
        diffuse = 1.0 - row["reflectivity"] - row["transmission"]
        assert diffuse >= -EXACT


def test_the_specular_coat_follows_fresnel_and_the_specular_ior_level():
    # IOR 1.5: ((1.5 - 1) / (1.5 + 1))^2 = 0.04 at level 0.5; level 0 removes it, 1 doubles it.
    assert principled_to_params(ior=1.5)["specular"] == pytest.approx(0.04)
    assert principled_to_params(ior=1.5, specular_level=0.0)["specular"] == 0.0
    assert principled_to_params(ior=1.5, specular_level=1.0)["specular"] == pytest.approx(0.08)
    assert principled_to_params(ior=2.0)["specular"] == pytest.approx(1.0 / 9.0)


def test_emission_is_color_times_strength():
    row = principled_to_params(emission=(1.0, 0.5, 0.25, 1.0), emission_strength=4.0)
    assert row["emission"] == pytest.approx((4.0, 2.0, 1.0))


def test_out_of_range_inputs_are_clamped_to_blender_ranges():
    row = principled_to_params(metallic=2.0, roughness=-1.0, transmission=5.0, ior=0.5,
                               base_color=(-1.0, 0.5, 2.0), thickness=3.0)
    assert row["reflectivity"] == 1.0  # metallic 1
    assert row["roughness"] == 0.0
    assert row["transmission"] == 0.0  # fully metallic: no transmission left
    assert row["ior"] == MIN_IOR
    assert row["base_color"] == (0.0, 0.5, 2.0)  # colours only lose negatives (HDR allowed)
    assert row["thickness"] == 1.0


def test_non_finite_inputs_fall_back_to_blender_defaults():
    row = principled_to_params(base_color=(math.nan, 0.1, math.inf), ior=math.nan,
                               emission_strength=math.inf, thickness=math.nan, metallic=math.nan)
    assert row["base_color"] == pytest.approx((0.8, 0.1, 0.8))
    assert row["ior"] == DEFAULT_IOR
    assert row["emission"] == (0.0, 0.0, 0.0)
    assert row["thickness"] == DEFAULT_THICKNESS
    assert row["reflectivity"] == 0.0


def test_a_colour_with_fewer_than_three_components_is_rejected_with_its_name():
    with pytest.raises(ValueError, match="base_color"):
        principled_to_params(base_color=(0.5, 0.5))


def test_rows_build_a_material_table():
    rows = [principled_to_params(metallic=1.0, roughness=0.0), principled_to_params(transmission=1.0, roughness=0.0)]
    table = MaterialTable.from_rows(rows)
    np.testing.assert_array_equal(table.reflectivity, [1.0, 0.0])
    np.testing.assert_array_equal(table.transmission, [0.0, 1.0])
