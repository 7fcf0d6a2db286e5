# SPDX-License-Identifier: GPL-3.0-or-later
"""The Hosek-Wilkie sky's state for one sun: what the Sky Texture's Hosek/Wilkie model needs
per direction (include/nodes/tex_sky.glsl node_sky_hosek), computed once on the CPU.

Hosek and Wilkie, "An Analytic Model for Full Spectral Sky-Dome Radiance" (SIGGRAPH 2012): the
radiance of a direction at angle theta from the zenith and gamma from the sun is, per XYZ
channel, L_M times
    F = (1 + A exp(B / (cos theta + 0.01))) (C + D exp(E gamma) + F cos^2 gamma
                                             + G chi(H, gamma) + I sqrt(cos theta)),
    chi(g, a) = (1 + cos^2 a) / (1 + g^2 - 2 g cos a)^(3/2).
The nine parameters and L_M come from the published dataset (sky_hosek_data.py): each is a
quintic Bezier curve over t = (solar elevation / (pi / 2))^(1/3), fitted for ground albedo
0 and 1 and integer turbidities 1..10, blended linearly between the neighbours of the given
turbidity and albedo. Cycles feeds it the node's Sun Direction, Turbidity (1..10) and Ground
Albedo, evaluates F x L_M per channel and scales XYZ by 2 pi / 683 into its radiance units.
"""
from __future__ import annotations

import math

import numpy as np

from .sky_hosek_data import CONFIGURATIONS, RADIANCES

# (channel, albedo, turbidity, control point, parameter) and (channel, albedo, turbidity, control point)
_CONFIG = np.asarray(CONFIGURATIONS, np.float64).reshape(3, 2, 10, 6, 9)
_RADIANCE = np.asarray(RADIANCES, np.float64).reshape(3, 2, 10, 6)
_BEZIER = np.array([1.0, 5.0, 10.0, 10.0, 5.0, 1.0])


def _bezier_weights(elevation: float) -> np.ndarray:
    t = (max(elevation, 0.0) / (math.pi / 2.0)) ** (1.0 / 3.0)
    k = np.arange(6)
    return _BEZIER * (1.0 - t) ** (5 - k) * t ** k


def hosek_state(sun_direction, turbidity: float, albedo: float) -> np.ndarray:
    """30 floats: the nine parameters of X, Y and Z, then L_M of X, Y, Z (tex_sky.glsl's order)."""
    sun = np.asarray(sun_direction, np.float64)
    length = float(np.linalg.norm(sun))
    cos_theta = float(sun[2]) / length if length > 0.0 else 1.0
    elevation = math.pi / 2.0 - min(max(math.acos(min(max(cos_theta, -1.0), 1.0)), 0.0), math.pi / 2.0)
    turbidity = min(max(float(turbidity), 1.0), 10.0)
    albedo = float(albedo)
    low = int(turbidity)
    rest = turbidity - low
    weights = _bezier_weights(elevation)
    # (albedo index, turbidity index, weight): the low turbidity, and the next unless at 10.
    blend = [(0, low - 1, (1.0 - albedo) * (1.0 - rest)), (1, low - 1, albedo * (1.0 - rest))]
    if low < 10:
        blend += [(0, low, (1.0 - albedo) * rest), (1, low, albedo * rest)]
    config = sum(w * np.einsum("k,ckp->cp", weights, _CONFIG[:, a, t]) for a, t, w in blend)
    radiance = sum(w * _RADIANCE[:, a, t] @ weights for a, t, w in blend)
    return np.concatenate([np.asarray(config).reshape(27), np.asarray(radiance).reshape(3)])
