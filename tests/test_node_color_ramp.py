# SPDX-License-Identifier: GPL-3.0-or-later
"""Color Ramp (gpu_shaders/include/nodes/color_ramp.glsl over the table that
blender_adapter/export/node_tables.py bakes) against Cycles: every interpolation, the RGB,
HSV and HSL colour modes with every hue direction, Color and Alpha outputs, and factors
beyond both ends of the ramp."""
from __future__ import annotations

import importlib

from node_grid import Case, check_cases, glsl_affine

COLOR_RAMP_INTERPOLATION_CODES = {"EASE": 0, "CARDINAL": 1, "LINEAR": 2, "B_SPLINE": 3, "CONSTANT": 4}

FAC = (0.046875, 0.00146484375, -0.25)   # -0.25 .. 1.2, a different factor on every pixel
STOPS = (  # position, RGBA: hues far apart so the hue direction matters
    (0.1, (0.9, 0.1, 0.05, 0.2)),
    (0.35, (0.2, 0.9, 0.3, 0.6)),
    (0.6, (1.0, 0.8, 0.1, 0.9)),
    (0.9, (0.1, 0.2, 0.95, 1.0)),
)


def _node_tables(addon):
    return importlib.import_module(f"{addon.__name__}.blender_adapter.export.node_tables")


def _ramp_case(tables, interpolation: str, color_mode: str, hue: str, output: str) -> Case:
    baked = {}

    def build(grid):
        node = grid.nodes.new("ShaderNodeValToRGB")
        ramp = node.color_ramp
        ramp.interpolation, ramp.color_mode, ramp.hue_interpolation = interpolation, color_mode, hue
        ramp.elements[0].position, ramp.elements[0].color = STOPS[0]
        ramp.elements[1].position, ramp.elements[1].color = STOPS[-1]
        for position, color in STOPS[1:-1]:
            ramp.elements.new(position).color = color
        grid.links.new(grid.scalar(FAC), node.inputs[0])
        baked["table"] = tables.bake_color_ramp(ramp)
        return node.outputs[output]

    def glsl(add_rows):
        table = baked["table"]
        base = add_rows(table.rgba)
        assert table.interpolate == (interpolation != "CONSTANT")
        shown = "c.rgb" if output == "Color" else "vec3(c.a)"
        return f"""int i0, i1; float w;
        node_color_ramp_coords({COLOR_RAMP_INTERPOLATION_CODES[interpolation]}, {glsl_affine(FAC)}, i0, i1, w);
        vec4 c = node_table_mix(points[{base} + i0], points[{base} + i1], w);
        return vec4({shown}, 1.0);"""
    return Case(f"{interpolation} {color_mode} {hue} {output}", build, glsl)


def test_every_ramp_interpolation_and_color_mode_matches_cycles(addon, ctx, tmp_path):
    tables = _node_tables(addon)
    cases = [_ramp_case(tables, i, "RGB", "NEAR", "Color") for i in COLOR_RAMP_INTERPOLATION_CODES]
    cases += [_ramp_case(tables, "LINEAR", mode, hue, "Color")
              for mode in ("HSV", "HSL") for hue in ("NEAR", "FAR", "CW", "CCW")]
    cases += [_ramp_case(tables, i, mode, "NEAR", "Color")
              for i, mode in (("EASE", "HSV"), ("B_SPLINE", "HSL"), ("CARDINAL", "HSV"), ("CONSTANT", "HSL"))]
    cases += [_ramp_case(tables, i, "RGB", "NEAR", "Alpha") for i in ("LINEAR", "B_SPLINE", "CONSTANT")]
    check_cases(ctx, tmp_path, cases, ["include/nodes/color_ramp.glsl"])
