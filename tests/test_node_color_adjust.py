# SPDX-License-Identifier: GPL-3.0-or-later
"""Hue/Saturation/Value, Invert Color, Gamma and Brightness/Contrast
(gpu_shaders/include/nodes/color_adjust.glsl), and Separate / Combine Color in RGB, HSV and
HSL (separate_combine.glsl), against Cycles. Colours run below 0 and above 1 (scene-linear),
factors leave [0, 1], the hue shift wraps and the gamma reaches 0 and negative values."""
from __future__ import annotations

from node_grid import Case, check_cases, glsl_affine, glsl_vec3

COLOR_MODE_CODES = {"RGB": 0, "HSV": 1, "HSL": 2}

COLOR = ((0.0625, 0.0, -0.25), (0.0, 0.03125, 0.1), (-0.03125, 0.0625, 0.125))   # -0.25 .. 2.1
UNIT_COLOR = ((0.03125, 0.0, 0.0), (0.0, 0.03125, 0.0), (0.015625, 0.015625, 0.03125))  # in [0, 1)
FACTOR = (0.03125, 0.03125, -0.5)                                                  # -0.5 .. 1.44
INCLUDES = ["include/nodes/color_adjust.glsl", "include/nodes/separate_combine.glsl"]


def _links(grid, node, *sources):
    for k, source in enumerate(sources):
        grid.links.new(source, node.inputs[k])
    return node


def _hsv_case(color) -> Case:
    hue, saturation, value = (0.0, 0.0625, -0.25), (0.0625, 0.0, -0.5), (0.0, -0.0625, 1.5)

    def build(grid):
        node = grid.nodes.new("ShaderNodeHueSaturation")
        _links(grid, node, grid.scalar(hue), grid.scalar(saturation), grid.scalar(value),
               grid.scalar(FACTOR), grid.color(color))
        return node.outputs[0]
    glsl = f"""vec3 r; node_hue_saturation_value({glsl_affine(hue)}, {glsl_affine(saturation)},
        {glsl_affine(value)}, {glsl_affine(FACTOR)}, {glsl_vec3(color)}, r); return vec4(r, 1.0);"""
    return Case("Hue/Saturation/Value", build, glsl)


def _invert_case() -> Case:
    def build(grid):
        return _links(grid, grid.nodes.new("ShaderNodeInvert"), grid.scalar(FACTOR), grid.color(COLOR)).outputs[0]
    glsl = f"vec3 r; node_invert({glsl_affine(FACTOR)}, {glsl_vec3(COLOR)}, r); return vec4(r, 1.0);"
    return Case("Invert", build, glsl)


def _gamma_case() -> Case:
    gamma = (0.0, 0.125, -1.0)   # -1 .. 2.875, 0 on row 8

    def build(grid):
        return _links(grid, grid.nodes.new("ShaderNodeGamma"), grid.color(COLOR), grid.scalar(gamma)).outputs[0]
    glsl = f"vec3 r; node_gamma({glsl_vec3(COLOR)}, {glsl_affine(gamma)}, r); return vec4(r, 1.0);"
    return Case("Gamma", build, glsl)


def _bright_contrast_case() -> Case:
    bright, contrast = (0.0, 0.0625, -1.0), (0.0625, 0.0, -1.0)

    def build(grid):
        node = grid.nodes.new("ShaderNodeBrightContrast")
        return _links(grid, node, grid.color(COLOR), grid.scalar(bright), grid.scalar(contrast)).outputs[0]
    glsl = f"""vec3 r; node_bright_contrast({glsl_vec3(COLOR)}, {glsl_affine(bright)},
        {glsl_affine(contrast)}, r); return vec4(r, 1.0);"""
    return Case("Bright/Contrast", build, glsl)


def _separate_case(mode: str, color) -> Case:
    def build(grid):
        node = grid.nodes.new("ShaderNodeSeparateColor")
        node.mode = mode
        grid.links.new(grid.color(color), node.inputs[0])
        combine = grid.nodes.new("ShaderNodeCombineXYZ")  # the three outputs as one vector
        return _links(grid, combine, *node.outputs).outputs[0]
    glsl = f"""float a, b, c; node_separate_color({COLOR_MODE_CODES[mode]}, {glsl_vec3(color)}, a, b, c);
        return vec4(a, b, c, 1.0);"""
    return Case(f"Separate Color {mode} {'unit' if color == UNIT_COLOR else 'wide'}", build, glsl)


def _combine_case(mode: str) -> Case:
    parts = ((0.03125, 0.0, 0.0), (0.0, 0.03125, 0.0), (0.015625, -0.015625, 0.5))   # in [0, 1)

    def build(grid):
        node = grid.nodes.new("ShaderNodeCombineColor")
        node.mode = mode
        return _links(grid, node, *(grid.scalar(p) for p in parts)).outputs[0]
    args = ", ".join(glsl_affine(p) for p in parts)
    glsl = f"vec3 r; node_combine_color({COLOR_MODE_CODES[mode]}, {args}, r); return vec4(r, 1.0);"
    return Case(f"Combine Color {mode}", build, glsl)


def test_color_adjustments_match_cycles(addon, ctx, tmp_path):
    cases = [_hsv_case(COLOR), _invert_case(), _gamma_case(), _bright_contrast_case()]
    check_cases(ctx, tmp_path, cases, INCLUDES)


def test_separate_and_combine_color_match_cycles_in_every_mode(addon, ctx, tmp_path):
    cases = [_separate_case(mode, UNIT_COLOR) for mode in COLOR_MODE_CODES]
    cases += [_separate_case(mode, COLOR) for mode in ("HSV", "HSL")]
    cases += [_combine_case(mode) for mode in COLOR_MODE_CODES]
    check_cases(ctx, tmp_path, cases, INCLUDES)
