# SPDX-License-Identifier: GPL-3.0-or-later
"""Gradient Texture (gpu_shaders/include/nodes/tex_gradient.glsl), every gradient type, against
Cycles on an emission plane. The node has no Scale input, so its three scales are three
extents of the plane (the range of input coordinates), each reaching below zero and past the
clamp at 1. The vector is (x, y, x * y), so the spheres see a third axis."""
from __future__ import annotations

import pytest

from node_oracle import cycles_emission_plane, glsl_probe, plane_points
from pattern_compare import difference, with_product_z

# gradient_type enum string -> the int code node_tex_gradient takes.
GRADIENT_CODES = {
    "LINEAR": 0,
    "QUADRATIC": 1,
    "EASING": 2,
    "DIAGONAL": 3,
    "SPHERICAL": 4,
    "QUADRATIC_SPHERE": 5,
    "RADIAL": 6,
}

SIZE = 48


def _gradient(gradient_type: str, output: str):
    def build(nodes, links, vector):
        gradient = nodes.new("ShaderNodeTexGradient")
        gradient.gradient_type = gradient_type
        links.new(with_product_z(nodes, links, vector), gradient.inputs["Vector"])
        return gradient.outputs[output]
    return build


@pytest.mark.parametrize("gradient_type", list(GRADIENT_CODES))
@pytest.mark.parametrize("extent", [0.7, 1.3, 4.0])
def test_gradient_colour_and_fac_match_cycles(addon, ctx, tmp_path, gradient_type, extent):
    points = plane_points(SIZE, extent)
    out = glsl_probe(ctx, ["include/nodes/tex_gradient.glsl"], f"""
        vec3 color; float fac;
        node_tex_gradient({GRADIENT_CODES[gradient_type]}, vec3(p.xy, p.x * p.y), color, fac);
        return vec4(color, fac);""", points)
    for output, ours in (("Color", out[..., :3]), ("Fac", out[..., 3:].repeat(3, axis=-1))):
        cycles = cycles_emission_plane(_gradient(gradient_type, output), tmp_path, SIZE, extent)
        d = difference(ours, cycles, value_range=1.0)
        print(f"gradient {gradient_type} extent {extent} {output}: {d}")
        assert d.mean <= 0.01 and d.p99 <= 0.02, f"{output}: {d}"
        assert cycles.max() - cycles.min() > 0.1  # a ramp, not a constant
