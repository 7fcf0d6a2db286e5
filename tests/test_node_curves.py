# SPDX-License-Identifier: GPL-3.0-or-later
"""RGB Curves, Vector Curves and Float Curve (gpu_shaders/include/nodes/curves.glsl over the
tables blender_adapter/export/node_tables.py bakes) against Cycles: bent curves with a moved
end point (so the x range is not [0, 1]), inputs beyond both ends with Extrapolated and
Horizontal extension, and factors outside [0, 1]."""
from __future__ import annotations

import importlib

from node_grid import Case, check_cases, glsl_affine, glsl_vec3

CURVE_EXTEND = ("EXTRAPOLATED", "HORIZONTAL")

COLOR = ((0.046875, 0.0, -0.25), (0.0, 0.046875, -0.25), (0.0234375, 0.0234375, -0.25))  # -0.25 .. 1.2
VECTOR = ((0.09375, 0.0, -1.5), (0.0, 0.09375, -1.5), (0.046875, -0.046875, 0.1))        # -1.5 .. 1.4
FAC = (0.0, 0.046875, -0.2)                                                              # -0.2 .. 1.25
VALUE = (0.046875, 0.00146484375, -0.25)


def _bend(curve, points, handle="AUTO"):
    """Move the curve's two end points and add the inner ones: (x, y) pairs."""
    curve.points[0].location = points[0]
    curve.points[1].location = points[-1]
    for x, y in points[1:-1]:
        curve.points.new(x, y).handle_type = handle


def _curves_case(tables, kind: str, extend: str) -> Case:
    baked = {}

    def build(grid):
        if kind == "RGB":
            node = grid.nodes.new("ShaderNodeRGBCurve")
            mapping = node.mapping
            _bend(mapping.curves[3], [(0.05, 0.1), (0.5, 0.7), (1.0, 0.95)])
            _bend(mapping.curves[0], [(0.0, 0.2), (0.3, 0.6), (1.0, 1.0)], "VECTOR")
            _bend(mapping.curves[1], [(0.0, 0.0), (0.6, 0.3), (0.9, 1.0)])
            _bend(mapping.curves[2], [(0.1, 0.0), (0.4, 0.5), (1.0, 0.8)])
            grid.links.new(grid.color(COLOR), node.inputs["Color"])
            baked["table"] = lambda: tables.bake_rgb_curves(mapping)
        elif kind == "VECTOR":
            node = grid.nodes.new("ShaderNodeVectorCurve")
            mapping = node.mapping
            _bend(mapping.curves[0], [(-1.0, -0.5), (0.0, 0.5), (1.0, 1.0)])
            _bend(mapping.curves[1], [(-0.8, 1.0), (0.2, -0.3), (1.0, 0.2)])
            _bend(mapping.curves[2], [(-1.0, -1.0), (0.5, 0.0), (0.9, 1.0)], "VECTOR")
            grid.links.new(grid.vector(VECTOR), node.inputs["Vector"])
            baked["table"] = lambda: tables.bake_vector_curves(mapping)
        else:
            node = grid.nodes.new("ShaderNodeFloatCurve")
            mapping = node.mapping
            _bend(mapping.curves[0], [(0.1, 0.3), (0.4, 0.9), (0.7, 0.2), (0.95, 0.6)])
            grid.links.new(grid.scalar(VALUE), node.inputs["Value"])
        if kind == "FLOAT":
            baked["table"] = lambda: tables.bake_float_curve(mapping)
        mapping.extend = extend
        mapping.update()
        grid.links.new(grid.scalar(FAC), node.inputs[0])
        baked["table"] = baked["table"]()
        return node.outputs[0]

    def glsl(add_rows):
        table = baked["table"]
        assert table.extrapolate == (extend == "EXTRAPOLATED")
        base = add_rows(table.values)
        head = f"""float min_x = {table.min_x!r}, max_x = {table.max_x!r};
            bool extrapolate = {str(table.extrapolate).lower()};
            float fac = {glsl_affine(FAC)};
            int i0, i1; float w;"""
        if kind == "FLOAT":
            return head + f"""
            float x = {glsl_affine(VALUE)};
            node_curve_coords(x, min_x, max_x, extrapolate, i0, i1, w);
            float r; node_curve_finish_float(fac, x, node_table_mix(points[{base} + i0], points[{base} + i1], w).x, r);
            return vec4(vec3(r), 1.0);"""
        original = glsl_vec3(COLOR if kind == "RGB" else VECTOR)
        return head + f"""
            vec3 x = {original}, curved;
            for (int k = 0; k < 3; ++k) {{
                node_curve_coords(x[k], min_x, max_x, extrapolate, i0, i1, w);
                curved[k] = node_table_mix(points[{base} + i0], points[{base} + i1], w)[k];
            }}
            vec3 r; node_curves_finish(fac, x, curved, r);
            return vec4(r, 1.0);"""
    return Case(f"{kind} curves {extend}", build, glsl)


def test_rgb_vector_and_float_curves_match_cycles_with_either_extension(addon, ctx, tmp_path):
    tables = importlib.import_module(f"{addon.__name__}.blender_adapter.export.node_tables")
    cases = [_curves_case(tables, kind, extend) for kind in ("RGB", "VECTOR", "FLOAT") for extend in CURVE_EXTEND]
    check_cases(ctx, tmp_path, cases, ["include/nodes/curves.glsl"])
