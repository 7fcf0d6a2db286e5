# SPDX-License-Identifier: GPL-3.0-or-later
"""The issue's yardstick for a procedural texture against Cycles, shared by the pattern-node
tests (Checker, Brick, Gradient, Magic, Image Texture mapping): errors measured as fractions of
the value range Cycles shows, and, for patterns with hard edges, the share of pixels whose
side of an edge differs.

Why flipped pixels are counted rather than folded into the error: Cycles' coordinates come
from a ray-plane hit, a few float bits away from the probe's, so a pixel centred within that
distance of a checker or mortar edge may land on the other side. Such a pixel is wholly wrong,
not a little wrong, and a tolerance wide enough to hide it would hide real errors too."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Difference:
    mean: float      # mean absolute difference / value range
    p99: float       # 99th percentile of the absolute difference / value range
    flipped: float   # share of pixels off by more than FLIP_LEVEL of the range in any channel

    def __str__(self) -> str:
        return f"mean {self.mean:.2e}  p99 {self.p99:.2e}  flipped {self.flipped:.4f}"


FLIP_LEVEL = 0.02


def difference(ours: np.ndarray, cycles: np.ndarray, value_range: float | None = None) -> Difference:
    """``ours`` against ``cycles`` (same shape, channels last). The range defaults to Cycles'
    own spread of values, so a texture of small amplitude is judged at its own scale."""
    ours = np.asarray(ours, np.float64)
    cycles = np.asarray(cycles, np.float64)
    assert ours.shape == cycles.shape, (ours.shape, cycles.shape)
    assert np.isfinite(ours).all(), "non-finite values in the GLSL result"
    if value_range is None:
        value_range = float(cycles.max() - cycles.min())
    value_range = max(value_range, 1e-6)
    error = np.abs(ours - cycles) / value_range
    per_pixel = error.reshape(*error.shape[:2], -1).max(axis=-1)
    return Difference(float(error.mean()), float(np.percentile(error, 99)),
                      float((per_pixel > FLIP_LEVEL).mean()))


def with_product_z(nodes, links, vector):
    """Blender nodes turning the plane's (x, y, 0) into (x, y, x * y): a z that changes sign
    and crosses whole numbers, so a texture's third axis is exercised on a flat plane. The
    GLSL side writes ``vec3(q.xy, q.x * q.y)``, the same float operations."""
    split = nodes.new("ShaderNodeSeparateXYZ")
    links.new(vector, split.inputs[0])
    product = nodes.new("ShaderNodeMath")
    product.operation = "MULTIPLY"
    links.new(split.outputs["X"], product.inputs[0])
    links.new(split.outputs["Y"], product.inputs[1])
    join = nodes.new("ShaderNodeCombineXYZ")
    links.new(split.outputs["X"], join.inputs["X"])
    links.new(split.outputs["Y"], join.inputs["Y"])
    links.new(product.outputs[0], join.inputs["Z"])
    return join.outputs["Vector"]
