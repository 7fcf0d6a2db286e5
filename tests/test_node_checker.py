# SPDX-License-Identifier: GPL-3.0-or-later
"""Checker Texture (gpu_shaders/include/nodes/tex_checker.glsl) against Cycles on an emission
plane, including coordinates below zero and exact whole numbers, where Blender's nudge puts
a point on an edge into one particular cell. The plane's z = 0 would leave the third axis
untested, so the vector shown is (x, y, x * y): every cell of the board sees a varying z."""
from __future__ import annotations

import numpy as np
import pytest

from node_oracle import cycles_emission_plane, glsl_probe, plane_points
from pattern_compare import difference, with_product_z

CHECKER_CODES: dict[str, int] = {}  # Checker Texture has no settings

SIZE, EXTENT = 48, 1.5
COLOR1, COLOR2 = (0.9, 0.3, 0.1), (0.05, 0.6, 0.8)
# Pixels nearest an edge may fall on its other side in Cycles (ray-plane rounding); measured
# none at these scales, bounded at well under one pixel row.
MAX_FLIPPED = 0.005


def _checker(scale: float, output: str, snap: float | None = None):
    def build(nodes, links, vector):
        if snap is not None:  # whole-number coordinates: floor(object * snap)
            grow = nodes.new("ShaderNodeVectorMath")
            grow.operation = "SCALE"
            links.new(vector, grow.inputs[0])
            grow.inputs["Scale"].default_value = snap
            floor = nodes.new("ShaderNodeVectorMath")
            floor.operation = "FLOOR"
            links.new(grow.outputs["Vector"], floor.inputs[0])
            vector = floor.outputs["Vector"]
        vector = with_product_z(nodes, links, vector)
        checker = nodes.new("ShaderNodeTexChecker")
        links.new(vector, checker.inputs["Vector"])
        checker.inputs["Color1"].default_value = (*COLOR1, 1.0)
        checker.inputs["Color2"].default_value = (*COLOR2, 1.0)
        checker.inputs["Scale"].default_value = scale
        return checker.outputs[output]
    return build


def _ours(ctx, scale: float, points: np.ndarray, snap: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    vector = "floor(p.xyz * {:.9g})".format(snap) if snap is not None else "p.xyz"
    out = glsl_probe(ctx, ["include/nodes/tex_checker.glsl"], f"""
        vec3 q = {vector};
        vec3 color; float fac;
        node_tex_checker(vec3(q.xy, q.x * q.y), vec3{COLOR1}, vec3{COLOR2}, {scale:.9g}, color, fac);
        return vec4(color, fac);""", points)
    return out[..., :3], out[..., 3:].repeat(3, axis=-1)


@pytest.mark.parametrize("scale", [1.5, 5.0, 13.7])
def test_checker_colour_and_fac_match_cycles_at_three_scales(addon, ctx, tmp_path, scale):
    points = plane_points(SIZE, EXTENT)
    color, fac = _ours(ctx, scale, points)
    for output, ours in (("Color", color), ("Fac", fac)):
        cycles = cycles_emission_plane(_checker(scale, output), tmp_path, SIZE, EXTENT)
        d = difference(ours, cycles)
        print(f"checker scale {scale} {output}: {d}")
        assert d.flipped <= MAX_FLIPPED, f"{output}: {d}"
        assert d.mean <= 0.01 and d.p99 <= 0.02, f"{output}: {d}"
    assert 0.3 < fac.mean() < 0.7  # both colours present: a board, not a flat colour


@pytest.mark.parametrize("scale", [1.0, 0.5, 3.0])
def test_checker_on_exact_whole_numbers_picks_blenders_cell_bit_for_bit(addon, ctx, tmp_path, scale):
    """On whole-number coordinates (negative ones included) every point lies on an edge; the
    nudge decides its cell. Bit for bit: the coordinates are exact, no ray rounding."""
    size, extent = 24, 6.0
    points = plane_points(size, extent)
    color, _ = _ours(ctx, scale, points, snap=1.0)
    cycles = cycles_emission_plane(_checker(scale, "Color", snap=1.0), tmp_path, size, extent)
    np.testing.assert_array_equal(color, cycles)
