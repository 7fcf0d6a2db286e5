# SPDX-License-Identifier: GPL-3.0-or-later
"""Magic Texture (gpu_shaders/include/nodes/tex_magic.glsl) against Cycles on an emission
plane: every turbulence depth 0 to 10, and three scales at two distortions. The vector is
(x, y, x * y) so all three coordinates vary."""
from __future__ import annotations

import pytest

from node_oracle import cycles_emission_plane, glsl_probe, plane_points
from pattern_compare import difference, with_product_z

MAGIC_CODES: dict[str, int] = {}  # turbulence_depth is passed as its own number, 0..10

SIZE, EXTENT = 48, 1.0


def _magic(depth: int, scale: float, distortion: float, output: str):
    def build(nodes, links, vector):
        magic = nodes.new("ShaderNodeTexMagic")
        magic.turbulence_depth = depth
        magic.inputs["Scale"].default_value = scale
        magic.inputs["Distortion"].default_value = distortion
        links.new(with_product_z(nodes, links, vector), magic.inputs["Vector"])
        return magic.outputs[output]
    return build


def _check(ctx, tmp_path, depth: int, scale: float, distortion: float) -> None:
    points = plane_points(SIZE, EXTENT)
    out = glsl_probe(ctx, ["include/nodes/tex_magic.glsl"], f"""
        vec3 color; float fac;
        node_tex_magic({depth}, vec3(p.xy, p.x * p.y), {scale:.9g}, {distortion:.9g}, color, fac);
        return vec4(color, fac);""", points)
    for output, ours in (("Color", out[..., :3]), ("Fac", out[..., 3:].repeat(3, axis=-1))):
        cycles = cycles_emission_plane(_magic(depth, scale, distortion, output), tmp_path, SIZE, EXTENT)
        d = difference(ours, cycles)
        print(f"magic depth {depth} scale {scale} distortion {distortion} {output}: {d}")
        assert d.mean <= 0.01 and d.p99 <= 0.02, f"{output}: {d}"
        assert cycles.max() - cycles.min() > 0.01  # a pattern, not a constant


@pytest.mark.parametrize("depth", range(11))
def test_magic_matches_cycles_at_every_depth(addon, ctx, tmp_path, depth):
    _check(ctx, tmp_path, depth, 5.0, 1.0)


@pytest.mark.parametrize("distortion", [0.6, 2.0])
@pytest.mark.parametrize("scale", [1.7, 5.0, 12.0])
@pytest.mark.parametrize("depth", [2, 10])
def test_magic_matches_cycles_at_three_scales_and_two_distortions(addon, ctx, tmp_path, depth, scale, distortion):
    _check(ctx, tmp_path, depth, scale, distortion)
