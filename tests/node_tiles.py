# SPDX-License-Identifier: GPL-3.0-or-later
"""Six comparison cases in one Cycles render, for the continuous procedural textures (Noise,
Wave): the plane is cut into a 3 x 2 grid of tiles and an input of the node is driven from the
tile index on both sides, Cycles' (math nodes on the object coordinates) and the probe's (the
same arithmetic in GLSL). Tile column c = floor((x + 3) / 2) in 0..2 and row
r = floor((y + 3) / 3) in 0..1; pixel centres never fall on a tile edge.

The node sees the vector (x, y, 0.6 x - 0.4 y), not the plane's z = 0, so that every axis of a
3D texture varies. Continuous noise is compared with the issue's tolerance, not bit for bit
(Cycles' coordinates come from a ray-plane hit and differ from the probe's in the last bits):
per tile, the mean absolute difference within 1 % and the 99th percentile within 2 % of the
value range Cycles shows in that tile."""
from __future__ import annotations

import numpy as np

from node_oracle import plane_points

SIZE, EXTENT = 48, 3.0
MEAN_BAR, P99_BAR = 0.01, 0.02


def math_node(nodes, links, operation, a, b=None, c=None):
    """A Math node's output socket; each operand is a socket or a constant."""
    node = nodes.new("ShaderNodeMath")
    node.operation = operation
    for index, value in enumerate((a, b, c)):
        if value is None:
            continue
        if isinstance(value, (int, float)):
            node.inputs[index].default_value = value
        else:
            links.new(value, node.inputs[index])
    return node.outputs[0]


def tile_inputs(nodes, links, object_vector, column_values, row_values):
    """Cycles' side: (vector, column_value, row_value, w) sockets, where column_value =
    column_values[0] + c * column_values[1] (likewise for rows) and w = 0.7 y + 1.3 x."""
    m = lambda *args: math_node(nodes, links, *args)  # noqa: E731
    split = nodes.new("ShaderNodeSeparateXYZ")
    links.new(object_vector, split.inputs[0])
    x, y = split.outputs["X"], split.outputs["Y"]
    column = m("FLOOR", m("MULTIPLY", m("ADD", x, 3.0), 0.5))
    row = m("FLOOR", m("DIVIDE", m("ADD", y, 3.0), 3.0))
    combine = nodes.new("ShaderNodeCombineXYZ")
    links.new(x, combine.inputs[0])
    links.new(y, combine.inputs[1])
    links.new(m("MULTIPLY_ADD", x, 0.6, m("MULTIPLY", y, -0.4)), combine.inputs[2])
    column_value = m("MULTIPLY_ADD", column, column_values[1], column_values[0])
    row_value = m("MULTIPLY_ADD", row, row_values[1], row_values[0])
    w = m("MULTIPLY_ADD", y, 0.7, m("MULTIPLY", x, 1.3))
    return combine.outputs[0], column_value, row_value, w


def tile_glsl(column_values, row_values) -> str:
    """The probe's side: GLSL statements defining vec3 vector, float column_value, row_value, w
    from p, in the same operation order."""
    return f"""
    float column = floor((p.x + 3.0) * 0.5);
    float row = floor((p.y + 3.0) / 3.0);
    vec3 vector = vec3(p.x, p.y, p.x * 0.6 + p.y * -0.4);
    float column_value = column * {column_values[1]:.6f} + {column_values[0]:.6f};
    float row_value = row * {row_values[1]:.6f} + {row_values[0]:.6f};
    float w = p.y * 0.7 + p.x * 1.3;"""


def tile_errors(ours: np.ndarray, cycles: np.ndarray) -> list[tuple[float, float]]:
    """(mean, p99) absolute difference over each tile, as fractions of Cycles' value range in
    that tile, tiles in order (row 0 columns 0..2, row 1 columns 0..2)."""
    points = plane_points(SIZE, EXTENT)
    column = np.floor((points[..., 0] + 3.0) * 0.5).astype(int)
    row = np.floor((points[..., 1] + 3.0) / 3.0).astype(int)
    errors = []
    for r in range(2):
        for c in range(3):
            mask = (row == r) & (column == c)
            want, got = cycles[mask], ours[mask]
            span = max(float(want.max() - want.min()), 1e-6)
            diff = np.abs(got - want) / span
            errors.append((float(diff.mean()), float(np.percentile(diff, 99))))
    return errors


def assert_within_bar(errors, label):
    """Every tile of every output within the issue's bar."""
    for output, tiles in errors.items():
        for index, (mean, p99) in enumerate(tiles):
            assert mean <= MEAN_BAR and p99 <= P99_BAR, (
                f"{label} {output} tile {index}: mean {mean:.4f}, p99 {p99:.4f}")


