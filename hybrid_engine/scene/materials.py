# SPDX-License-Identifier: GPL-3.0-or-later
"""Blender's Principled BSDF reduced to the paper's material model.

The paper (§3.4) needs three things per material: how much of a hit is a mirror, how much
is glass (and its index of refraction), and the per-material *thickness* that decides
whether a cube-map ray-march sample behind the stored depth is a hit. An artist's picture
needs more: roughness, and the specular coat every dielectric has. The Principled BSDF has
many more lobes still; this module is the single place where they are folded into
``MaterialTable`` rows, so the Blender extractor and the material panel (which shows the
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
DEFAULT_SPECULAR_LEVEL = 0.5  # Specular IOR Level: Fresnel as the IOR says
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


def coat_reflectance(ior: float, specular_level: float) -> float:
    """Reflectance at normal incidence of the Principled BSDF's dielectric layer: Fresnel's
    ((ior - 1) / (ior + 1))^2, scaled by twice the Specular IOR Level (Blender: 0.5 leaves
    it as the IOR says, 0 removes all reflection, 1 doubles it), at most 1."""
    f0 = ((ior - 1.0) / (ior + 1.0)) ** 2
    return min(max(f0 * 2.0 * specular_level, 0.0), 1.0)


def principled_to_params(
    base_color: Sequence[float] = DEFAULT_BASE_COLOR,
    metallic: float = 0.0,
    roughness: float = 0.5,
    transmission: float = 0.0,
    ior: float = DEFAULT_IOR,
    emission: Sequence[float] = (0.0, 0.0, 0.0),
    emission_strength: float = 0.0,
    thickness: float = DEFAULT_THICKNESS,
    specular_level: float = DEFAULT_SPECULAR_LEVEL,
    normal_strength: float = 1.0,
) -> dict:
    """Map Principled BSDF inputs to one ``MaterialTable.from_rows`` row.

    The layers (README.md "Materials and the per-material thickness",
    gpu_shaders/include/shading.glsl), with the metallic layer on top of the transmissive one
    as in the Principled BSDF itself:

    * ``reflectivity = metallic`` -- the metal lobe, tinted by ``base_color``;
    * ``transmission = transmission * (1 - metallic)`` -- glass of index ``ior``;
    * the remainder is diffuse with ``base_color``, under a dielectric coat of reflectance
      ``specular`` at normal incidence (``coat_reflectance`` of the IOR and Specular IOR
      Level), which takes its Fresnel share of the light from the diffuse layer;
    * ``roughness`` (GGX) blurs every specular lobe: 0 is a perfect mirror or clear glass;
    * ``emission = emission_color * emission_strength`` is added on top;
    * ``normal_strength`` is the Normal Map node's strength (0 to 10), for a normal map
      the extractor found.

    Inputs are clamped to their Blender ranges (weights to [0, 1], colours to >= 0, IOR to
    >= 1); a non-finite input falls back to Blender's default for that socket, so a broken
    node value can never put a NaN into the renderer.
    """
    metallic = _unit(metallic, 0.0)
    roughness = _unit(roughness, 0.5)
    transmission = _unit(transmission, 0.0)
    strength = max(_finite(emission_strength, 0.0), 0.0)
    emission_rgb = _rgb(emission, (0.0, 0.0, 0.0), "emission")
    ior = max(_finite(ior, DEFAULT_IOR), MIN_IOR)
    return {
        "base_color": _rgb(base_color, DEFAULT_BASE_COLOR, "base_color"),
        "reflectivity": metallic,
        "transmission": transmission * (1.0 - metallic),
        "ior": ior,
        "roughness": roughness,
        "specular": coat_reflectance(ior, _unit(specular_level, DEFAULT_SPECULAR_LEVEL)),
        "emission": tuple(c * strength for c in emission_rgb),
        "thickness": _unit(thickness, DEFAULT_THICKNESS),
        "normal_strength": min(max(_finite(normal_strength, 1.0), 0.0), 10.0),
    }
