# SPDX-License-Identifier: GPL-3.0-or-later
"""Map Range and Clamp (gpu_shaders/include/nodes/map_range.glsl) against Cycles: every
interpolation, clamped and not, for Float and Vector, with source ranges that are forward,
empty and reversed, target ranges that flip, and step counts down to zero and below."""
from __future__ import annotations

from node_grid import Case, by_id, check_cases, glsl_affine, glsl_vec3

MAP_RANGE_CODES = {"LINEAR": 0, "STEPPED": 1, "SMOOTHSTEP": 2, "SMOOTHERSTEP": 3}
CLAMP_CODES = {"MINMAX": 0, "RANGE": 1}

VALUE = (0.125, 0.0, -1.0)          # -1 .. 2.875
FROM_MIN = (0.0, 0.0625, -0.5)       # passes from_max = 1 on row 24: empty, then reversed
FROM_MAX = (0.0, 0.0, 1.0)
TO_MIN = (0.0, 0.0, 0.25)
TO_MAX = (0.0, -0.0625, 1.5)         # below to_min from row 21: the target range flips
STEPS = (0.0625, 0.0625, -0.5)       # -0.5 .. 3.375, zero on the diagonal u + v = 8
SCALAR_INPUTS = (VALUE, FROM_MIN, FROM_MAX, TO_MIN, TO_MAX, STEPS)
# per axis: the scalar inputs, then the same with u and v swapped, then with a shift
SWAPPED = tuple((sv, su, o) for su, sv, o in SCALAR_INPUTS)
SHIFTED = tuple((su, sv, o + 0.375) for su, sv, o in SCALAR_INPUTS)
VECTOR_INPUTS = tuple(zip(SCALAR_INPUTS, SWAPPED, SHIFTED))
FLOAT_SOCKETS = ("Value", "From Min", "From Max", "To Min", "To Max", "Steps")
VECTOR_SOCKETS = ("Vector", "From_Min_FLOAT3", "From_Max_FLOAT3", "To_Min_FLOAT3", "To_Max_FLOAT3",
                  "Steps_FLOAT3")


def _map_range_case(interpolation: str, use_clamp: bool, vector: bool) -> Case:
    def build(grid):
        node = grid.nodes.new("ShaderNodeMapRange")
        node.data_type = "FLOAT_VECTOR" if vector else "FLOAT"
        for identifier, spec in zip(VECTOR_SOCKETS if vector else FLOAT_SOCKETS,
                                    VECTOR_INPUTS if vector else SCALAR_INPUTS):
            source = grid.vector(spec) if vector else grid.scalar(spec)
            grid.links.new(source, by_id(node.inputs, identifier))
        node.interpolation_type = interpolation
        node.clamp = use_clamp
        return by_id(node.outputs, "Vector" if vector else "Result")

    code, clamp = MAP_RANGE_CODES[interpolation], str(use_clamp).lower()
    if vector:
        args = ", ".join(glsl_vec3(spec) for spec in VECTOR_INPUTS)
        glsl = f"vec3 r; node_map_range_vector({code}, {clamp}, {args}, r); return vec4(r, 1.0);"
    else:
        args = ", ".join(glsl_affine(spec) for spec in SCALAR_INPUTS)
        glsl = f"float r; node_map_range({code}, {clamp}, {args}, r); return vec4(vec3(r), 1.0);"
    return Case(f"{'FLOAT_VECTOR' if vector else 'FLOAT'} {interpolation} clamp={use_clamp}", build, glsl)


def _clamp_case(clamp_type: str) -> Case:
    value, low, high = VALUE, (0.0, 0.0625, -0.5), (0.0, -0.0625, 1.5)   # low > high from row 16

    def build(grid):
        node = grid.nodes.new("ShaderNodeClamp")
        node.clamp_type = clamp_type
        for k, spec in enumerate((value, low, high)):
            grid.links.new(grid.scalar(spec), node.inputs[k])
        return node.outputs[0]

    glsl = f"""float r; node_clamp({CLAMP_CODES[clamp_type]}, {glsl_affine(value)}, {glsl_affine(low)},
        {glsl_affine(high)}, r); return vec4(vec3(r), 1.0);"""
    return Case(f"Clamp {clamp_type}", build, glsl)


def test_map_range_matches_cycles_for_every_interpolation_clamp_and_type(addon, ctx, tmp_path):
    cases = [_map_range_case(i, c, v) for v in (False, True) for i in MAP_RANGE_CODES for c in (False, True)]
    check_cases(ctx, tmp_path, cases, ["include/nodes/map_range.glsl"])


def test_clamp_matches_cycles_in_both_modes_with_crossed_bounds(addon, ctx, tmp_path):
    check_cases(ctx, tmp_path, [_clamp_case(t) for t in CLAMP_CODES], ["include/nodes/map_range.glsl"])
