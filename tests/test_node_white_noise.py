# SPDX-License-Identifier: GPL-3.0-or-later
"""White Noise Texture (gpu_shaders/include/nodes/tex_white_noise.glsl) against Cycles, bit for
bit: it is Blender's hash of the coordinates, and every procedural texture draws from the same
hash (include/nodes/hash.glsl). The coordinates are snapped to whole numbers first, because the
hash of a float changes completely with its last bit, and Cycles' object coordinates of a pixel
are a ray-plane intersection, not the exact float the probe is given."""
from __future__ import annotations

import numpy as np
import pytest

from node_oracle import cycles_emission_plane, glsl_probe, plane_points

SIZE, EXTENT = 24, 6.0


def _white_noise(dimensions: str, output: str):
    def build(nodes, links, vector):
        snap = nodes.new("ShaderNodeVectorMath")
        snap.operation = "FLOOR"
        links.new(vector, snap.inputs[0])
        noise = nodes.new("ShaderNodeTexWhiteNoise")
        links.new(snap.outputs["Vector"], noise.inputs["Vector"])
        # W = floor(x) * floor(y): differs from every coordinate, so a swapped word shows.
        split = nodes.new("ShaderNodeSeparateXYZ")
        links.new(snap.outputs["Vector"], split.inputs[0])
        product = nodes.new("ShaderNodeMath")
        product.operation = "MULTIPLY"
        links.new(split.outputs["X"], product.inputs[0])
        links.new(split.outputs["Y"], product.inputs[1])
        links.new(product.outputs[0], next(s for s in noise.inputs if s.identifier == "W"))
        noise.noise_dimensions = dimensions  # after linking: hidden sockets cannot be looked up
        return noise.outputs[output]
    return build


@pytest.mark.parametrize("dimensions", ["1D", "2D", "3D", "4D"])
def test_white_noise_value_and_colour_equal_cycles_bit_for_bit(addon, ctx, tmp_path, dimensions):
    points = plane_points(SIZE, EXTENT)
    for output, expression in (("Value", "vec3(value)"), ("Color", "color")):
        cycles = cycles_emission_plane(_white_noise(dimensions, output), tmp_path, SIZE, EXTENT)
        ours = glsl_probe(ctx, ["include/nodes/tex_white_noise.glsl"], f"""
            vec3 q = floor(p.xyz);
            float value; vec3 color;
            node_tex_white_noise({dimensions[0]}, q, q.x * q.y, value, color);
            return vec4({expression}, 1.0);""", points)[..., :3]
        assert np.unique(cycles[..., 0]).size > SIZE  # a different number per cell, not a constant
        np.testing.assert_array_equal(ours, cycles, err_msg=f"{dimensions} {output}")
