# SPDX-License-Identifier: GPL-3.0-or-later
"""Brick Texture (gpu_shaders/include/nodes/tex_brick.glsl) against Cycles on an emission
plane: the per-brick tint must be Blender's own integer noise (a different noise would give
each brick another shade), rows shifted and squashed as the settings say, and the mortar band
and its smooth edge where Blender draws them, below zero included.

With Mortar Smooth at 0 the mortar edge is a hard step, and a pixel centred within float
rounding of it may fall on the other side in Cycles (its coordinates come from a ray-plane
hit); such pixels are counted and bounded instead of widening the tolerance."""
from __future__ import annotations

import pytest

from node_oracle import cycles_emission_plane, glsl_probe, plane_points
from pattern_compare import difference

BRICK_CODES: dict[str, int] = {}  # no enum settings: offset, squash (float), *_frequency (int)

SIZE, EXTENT = 48, 1.37
COLOR1, COLOR2, MORTAR = (0.9, 0.3, 0.1), (0.1, 0.5, 0.9), (0.0, 0.05, 0.2)
MAX_FLIPPED = 0.01

# name -> (offset, offset_frequency, squash, squash_frequency, inputs by socket identifier)
CASES = {
    "defaults": (0.5, 2, 1.0, 2, {}),
    "offset_squash": (0.3, 3, 1.7, 2, {"Bias": -0.2, "Brick Width": 0.7, "Row Height": 0.3}),
    "hard_mortar": (0.5, 1, 0.6, 3, {"Mortar Smooth": 0.0, "Mortar Size": 0.05, "Bias": 0.3}),
    "wide_smooth": (0.8, 2, 1.0, 2, {"Mortar Smooth": 0.9, "Mortar Size": 0.08, "Row Height": 0.4}),
}
DEFAULTS = {"Mortar Size": 0.02, "Mortar Smooth": 0.1, "Bias": 0.0, "Brick Width": 0.5, "Row Height": 0.25}


def _brick(case: str, scale: float, output: str):
    offset, offset_frequency, squash, squash_frequency, inputs = CASES[case]

    def build(nodes, links, vector):
        brick = nodes.new("ShaderNodeTexBrick")
        links.new(vector, brick.inputs["Vector"])
        brick.offset, brick.offset_frequency = offset, offset_frequency
        brick.squash, brick.squash_frequency = squash, squash_frequency
        brick.inputs["Color1"].default_value = (*COLOR1, 1.0)
        brick.inputs["Color2"].default_value = (*COLOR2, 1.0)
        brick.inputs["Mortar"].default_value = (*MORTAR, 1.0)
        brick.inputs["Scale"].default_value = scale
        for name, value in inputs.items():
            brick.inputs[name].default_value = value
        return brick.outputs[output]
    return build


@pytest.mark.parametrize("scale", [1.3, 5.0, 11.0])
@pytest.mark.parametrize("case", list(CASES))
def test_brick_colour_and_fac_match_cycles(addon, ctx, tmp_path, case, scale):
    offset, offset_frequency, squash, squash_frequency, inputs = CASES[case]
    v = {**DEFAULTS, **inputs}
    points = plane_points(SIZE, EXTENT)
    out = glsl_probe(ctx, ["include/nodes/tex_brick.glsl"], f"""
        vec3 color; float fac;
        node_tex_brick(p.xyz, vec3{COLOR1}, vec3{COLOR2}, vec3{MORTAR}, {scale:.9g},
                       {v["Mortar Size"]:.9g}, {v["Mortar Smooth"]:.9g}, {v["Bias"]:.9g},
                       {v["Brick Width"]:.9g}, {v["Row Height"]:.9g}, {offset:.9g}, {offset_frequency},
                       {squash:.9g}, {squash_frequency}, color, fac);
        return vec4(color, fac);""", points)
    for output, ours in (("Color", out[..., :3]), ("Fac", out[..., 3:].repeat(3, axis=-1))):
        cycles = cycles_emission_plane(_brick(case, scale, output), tmp_path, SIZE, EXTENT)
        d = difference(ours, cycles, value_range=1.0)
        print(f"brick {case} scale {scale} {output}: {d}")
        assert d.flipped <= MAX_FLIPPED, f"{output}: {d}"
        assert d.mean <= 0.01 and d.p99 <= 0.02, f"{output}: {d}"
    assert 0.02 < out[..., 3].mean() < 0.9  # bricks and mortar both present
