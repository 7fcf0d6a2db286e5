# SPDX-License-Identifier: GPL-3.0-or-later
"""Tables that stand for a Color Ramp or a curve on the GPU, baked from Blender's own evaluator.

Cycles does not evaluate a Color Ramp or an RGB/Vector/Float Curve per shading point: it
samples Blender's evaluator at ``TABLE_SIZE`` evenly spaced inputs once and interpolates
linearly between neighbouring samples at render time (a Color Ramp set to Constant picks the
sample below instead). Baking the same table here and doing the same lookup on the GPU
(``gpu_shaders/include/nodes/color_ramp.glsl`` and ``curves.glsl``) therefore gives Cycles'
values for every interpolation and colour mode, including the HSV/HSL hue directions, without
a GLSL copy of each spline. Curves are sampled across the x range their points span; inputs
outside it continue the end slope of the table when the curve extends Extrapolated, and stay
flat when it extends Horizontal."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

TABLE_SIZE = 257  # Cycles' ramp and curve table length: samples at i / 256


@dataclass(frozen=True)
class RampTable:
    """A Color Ramp's (TABLE_SIZE, 4) RGBA samples at i / (TABLE_SIZE - 1) and whether the
    lookup blends neighbours (every interpolation but Constant)."""
    rgba: np.ndarray
    interpolate: bool


@dataclass(frozen=True)
class CurveTable:
    """Curve samples over [min_x, max_x]: (TABLE_SIZE, 3) for RGB and Vector Curves (one
    column per channel or axis), (TABLE_SIZE, 1) for a Float Curve."""
    values: np.ndarray
    min_x: float
    max_x: float
    extrapolate: bool


def bake_color_ramp(ramp) -> RampTable:
    """``ramp``: a bpy ColorRamp (``node.color_ramp``)."""
    positions = np.arange(TABLE_SIZE, dtype=np.float32) / np.float32(TABLE_SIZE - 1)
    rgba = np.array([tuple(ramp.evaluate(float(p))) for p in positions], np.float32)
    return RampTable(rgba=rgba, interpolate=ramp.interpolation != "CONSTANT")


def _x_range(mapping, curves) -> tuple[float, float]:
    """The x span of the curves' points together (the table's domain)."""
    min_x = min(float(curve.points[0].location[0]) for curve in curves)
    max_x = max(float(curve.points[len(curve.points) - 1].location[0]) for curve in curves)
    return min_x, max_x


def _sample_positions(min_x: float, max_x: float) -> np.ndarray:
    """The table's inputs, in float32 arithmetic as the render-time lookup inverts them."""
    steps = np.arange(TABLE_SIZE, dtype=np.float32) / np.float32(TABLE_SIZE - 1)
    return np.float32(min_x) + steps * (np.float32(max_x) - np.float32(min_x))


def bake_rgb_curves(mapping) -> CurveTable:
    """``mapping``: the RGB Curves node's CurveMapping (curves R, G, B, then the combined C,
    applied first, as Blender's curve editor shows them)."""
    mapping.initialize()
    curves = [mapping.curves[k] for k in range(4)]
    min_x, max_x = _x_range(mapping, curves)
    values = []
    for x in _sample_positions(min_x, max_x):
        combined = mapping.evaluate(curves[3], float(x))
        values.append([mapping.evaluate(curves[k], combined) for k in range(3)])
    return CurveTable(np.array(values, np.float32), min_x, max_x, mapping.extend == "EXTRAPOLATED")


def bake_vector_curves(mapping) -> CurveTable:
    """``mapping``: the Vector Curves node's CurveMapping (curves X, Y, Z)."""
    mapping.initialize()
    curves = [mapping.curves[k] for k in range(3)]
    min_x, max_x = _x_range(mapping, curves)
    values = [[mapping.evaluate(curve, float(x)) for curve in curves] for x in _sample_positions(min_x, max_x)]
    return CurveTable(np.array(values, np.float32), min_x, max_x, mapping.extend == "EXTRAPOLATED")


def bake_float_curve(mapping) -> CurveTable:
    """``mapping``: the Float Curve node's CurveMapping (one curve)."""
    mapping.initialize()
    curve = mapping.curves[0]
    min_x, max_x = _x_range(mapping, [curve])
    values = [[mapping.evaluate(curve, float(x))] for x in _sample_positions(min_x, max_x)]
    return CurveTable(np.array(values, np.float32), min_x, max_x, mapping.extend == "EXTRAPOLATED")
