# SPDX-License-Identifier: GPL-3.0-or-later
"""Mix node (gpu_shaders/include/nodes/color_mix.glsl) against Cycles: the Float and Vector
mixes (uniform and per-axis factor), every Color blend with and without clamped factor and
result, and the legacy MixRGB node. Colours run below 0 and above 1 and the factor leaves
[0, 1], so the clamps and the out-of-range branches of Burn, Dodge and Overlay are all taken."""
from __future__ import annotations

from node_grid import Case, by_id, check_cases, glsl_affine, glsl_vec3

MIX_BLEND_CODES = {
    "MIX": 0, "DARKEN": 1, "MULTIPLY": 2, "BURN": 3, "LIGHTEN": 4, "SCREEN": 5, "DODGE": 6,
    "ADD": 7, "OVERLAY": 8, "SOFT_LIGHT": 9, "LINEAR_LIGHT": 10, "DIFFERENCE": 11,
    "EXCLUSION": 12, "SUBTRACT": 13, "DIVIDE": 14, "HUE": 15, "SATURATION": 16, "COLOR": 17,
    "VALUE": 18,
}

FACTOR = (0.03125, 0.03125, -0.5)                  # -0.5 .. 1.4375
COLOR_A = ((0.0625, 0.0, -0.25), (0.0, 0.03125, 0.1), (-0.03125, 0.0, 0.75))
COLOR_B = ((0.0, 0.0625, -0.25), (0.03125, 0.0, 0.0), (0.0, -0.03125, 0.9))
FLOAT_A, FLOAT_B = (0.25, 0.0, -4.0), (0.0, -0.125, 2.0)
VECTOR_FACTOR = (FACTOR, (0.0625, 0.0, -0.5), (0.0, 0.0625, -0.75))


def _float_case(clamp_factor: bool) -> Case:
    def build(grid):
        node = grid.nodes.new("ShaderNodeMix")
        node.data_type = "FLOAT"
        node.clamp_factor = clamp_factor
        grid.links.new(grid.scalar(FACTOR), by_id(node.inputs, "Factor_Float"))
        grid.links.new(grid.scalar(FLOAT_A), by_id(node.inputs, "A_Float"))
        grid.links.new(grid.scalar(FLOAT_B), by_id(node.inputs, "B_Float"))
        return by_id(node.outputs, "Result_Float")
    glsl = f"""float r; node_mix_float({str(clamp_factor).lower()}, {glsl_affine(FACTOR)},
        {glsl_affine(FLOAT_A)}, {glsl_affine(FLOAT_B)}, r); return vec4(vec3(r), 1.0);"""
    return Case(f"FLOAT clamp_factor={clamp_factor}", build, glsl)


def _vector_case(non_uniform: bool, clamp_factor: bool) -> Case:
    def build(grid):
        node = grid.nodes.new("ShaderNodeMix")
        node.data_type = "VECTOR"
        node.factor_mode = "NON_UNIFORM" if non_uniform else "UNIFORM"
        node.clamp_factor = clamp_factor
        if non_uniform:
            grid.links.new(grid.vector(VECTOR_FACTOR), by_id(node.inputs, "Factor_Vector"))
        else:
            grid.links.new(grid.scalar(FACTOR), by_id(node.inputs, "Factor_Float"))
        grid.links.new(grid.vector(COLOR_A), by_id(node.inputs, "A_Vector"))
        grid.links.new(grid.vector(COLOR_B), by_id(node.inputs, "B_Vector"))
        return by_id(node.outputs, "Result_Vector")
    cf = str(clamp_factor).lower()
    if non_uniform:
        call = f"node_mix_vector_non_uniform({cf}, {glsl_vec3(VECTOR_FACTOR)}, "
    else:
        call = f"node_mix_vector({cf}, {glsl_affine(FACTOR)}, "
    glsl = f"vec3 r; {call}{glsl_vec3(COLOR_A)}, {glsl_vec3(COLOR_B)}, r); return vec4(r, 1.0);"
    return Case(f"VECTOR non_uniform={non_uniform} clamp_factor={clamp_factor}", build, glsl)


def _color_case(blend: str, clamp_factor: bool, clamp_result: bool, legacy: bool = False) -> Case:
    def build(grid):
        if legacy:
            node = grid.nodes.new("ShaderNodeMixRGB")
            node.blend_type = blend
            node.use_clamp = clamp_result
            sockets = ("Fac", "Color1", "Color2", "Color")
        else:
            node = grid.nodes.new("ShaderNodeMix")
            node.data_type = "RGBA"
            node.blend_type = blend
            node.clamp_factor = clamp_factor
            node.clamp_result = clamp_result
            sockets = ("Factor_Float", "A_Color", "B_Color", "Result_Color")
        grid.links.new(grid.scalar(FACTOR), by_id(node.inputs, sockets[0]))
        grid.links.new(grid.color(COLOR_A), by_id(node.inputs, sockets[1]))
        grid.links.new(grid.color(COLOR_B), by_id(node.inputs, sockets[2]))
        return by_id(node.outputs, sockets[3])
    glsl = f"""vec3 r; node_mix_color({MIX_BLEND_CODES[blend]}, {str(clamp_factor).lower()},
        {str(clamp_result).lower()}, {glsl_affine(FACTOR)}, {glsl_vec3(COLOR_A)},
        {glsl_vec3(COLOR_B)}, r); return vec4(r, 1.0);"""
    name = f"{'MixRGB' if legacy else 'RGBA'} {blend} clamp_factor={clamp_factor} clamp_result={clamp_result}"
    return Case(name, build, glsl)


def test_float_and_vector_mix_match_cycles(addon, ctx, tmp_path):
    cases = [_float_case(c) for c in (False, True)]
    cases += [_vector_case(n, c) for n in (False, True) for c in (False, True)]
    check_cases(ctx, tmp_path, cases, ["include/nodes/color_mix.glsl"])


def test_every_color_blend_matches_cycles_with_and_without_clamps(addon, ctx, tmp_path):
    cases = [_color_case(blend, c, c) for blend in MIX_BLEND_CODES for c in (False, True)]
    cases += [_color_case(blend, False, True) for blend in ("MIX", "DODGE", "OVERLAY")]
    check_cases(ctx, tmp_path, cases, ["include/nodes/color_mix.glsl"])


def test_legacy_mixrgb_is_the_color_mix_with_a_clamped_factor(addon, ctx, tmp_path):
    cases = [_color_case(blend, True, k % 2 == 1, legacy=True)
             for k, blend in enumerate(MIX_BLEND_CODES)]
    check_cases(ctx, tmp_path, cases, ["include/nodes/color_mix.glsl"])
