# SPDX-License-Identifier: GPL-3.0-or-later
"""Blender's Principled BSDF reduced to the paper's material model.

The paper (§3.4) needs three things per material: how much of a hit is a perfect mirror,
how much is clear glass (and its index of refraction), and the per-material *thickness*
that decides whether a cube-map ray-march sample behind the stored depth is a hit. The
Principled BSDF has many more lobes; this module is the single place where they are folded
into ``MaterialTable`` rows, so the Blender extractor and the material panel (which shows the
derived values read-only) can never disagree. It knows nothing of Blender: it takes plain
numbers, so it is tested without bpy.
"""
from __future__ import annotations

import math
from collections.abc import Sequence

# Blender's defaults, used where an input is missing or not a finite number.
DEFAULT_BASE_COLOR = (0.8, 0.8, 0.8)
DEFAULT_IOR = 1.5
DEFAULT_THICKNESS = 0.5
MIN_IOR = 1.0  # the core refracts from air into the material; an IOR below 1 is clamped


def _finite(value: float, default: float) -> float:
    value = float(value)
    return value if math.isfinite(value) else default


def _unit(value: float, default: float) -> float:
    return min(max(_finite(value, default), 0.0), 1.0)


def _rgb(value: Sequence[float], default: Sequence[float], name: str) -> tuple[float, float, float]:
    values = tuple(value)[:3]  # RGBA sockets: the alpha is not part of the model
    if len(values) != 3:
        raise ValueError(f"{name} needs at least 3 components, got {len(values)}")
    return tuple(max(_finite(v, d), 0.0) for v, d in zip(values, default))  # type: ignore[return-value]


def principled_to_params(
    base_color: Sequence[float] = DEFAULT_BASE_COLOR,
    metallic: float = 0.0,
    roughness: float = 0.5,
    transmission: float = 0.0,
    ior: float = DEFAULT_IOR,
    emission: Sequence[float] = (0.0, 0.0, 0.0),
    emission_strength: float = 0.0,
    thickness: float = DEFAULT_THICKNESS,
) -> dict:
    """Map Principled BSDF inputs to one ``MaterialTable.from_rows`` row.

    The blend (DESIGN.md "Materials"): a sharp lobe is only as strong as the surface is
    smooth, so both specular weights fall off linearly with roughness, and the metallic
    layer sits on top of the transmissive one as in the Principled BSDF itself:

    * ``reflectivity = metallic * (1 - roughness)`` -- Metallic 1 with Roughness 0 is a
      perfect mirror, tinted by ``base_color`` when shaded;
    * ``transmission = transmission * (1 - roughness) * (1 - metallic)`` -- Transmission
      Weight 1 with Roughness 0 (and Metallic 0) is clear glass of index ``ior``;
    * the remainder ``1 - reflectivity - transmission`` (never negative, since
      ``m(1-r) + t(1-r)(1-m) <= (1-r)``) is diffuse with ``base_color``;
    * ``emission = emission_color * emission_strength`` is added on top.

    Inputs are clamped to their Blender ranges (weights to [0, 1], colours to >= 0, IOR to
    >= 1); a non-finite input falls back to Blender's default for that socket, so a broken
    node value can never put a NaN into the renderer.
    """
    metallic = _unit(metallic, 0.0)
    roughness = _unit(roughness, 0.5)
    transmission = _unit(transmission, 0.0)
    strength = max(_finite(emission_strength, 0.0), 0.0)
    emission_rgb = _rgb(emission, (0.0, 0.0, 0.0), "emission")
    return {
        "base_color": _rgb(base_color, DEFAULT_BASE_COLOR, "base_color"),
        "reflectivity": metallic * (1.0 - roughness),
        "transmission": transmission * (1.0 - roughness) * (1.0 - metallic),
        "ior": max(_finite(ior, DEFAULT_IOR), MIN_IOR),
        "emission": tuple(c * strength for c in emission_rgb),
        "thickness": _unit(thickness, DEFAULT_THICKNESS),
    }
