# SPDX-License-Identifier: GPL-3.0-or-later
"""The colour of a black body at a temperature, as Blender's lamp Temperature uses it.

Planck's law integrated against the CIE 1931 2° colour-matching functions (Wyman, Sloan
and Shirley's multi-lobe Gaussian fit, "Simple Analytic Approximations to the CIE XYZ
Color Matching Functions", JCGT 2013), converted to linear Rec.709 and scaled to unit
luminance, so that a lamp's Temperature changes its colour and not its brightness.
Plain numpy: the exporter calls it once per lamp whose temperature is in use.
"""
from __future__ import annotations

import numpy as np

_WAVELENGTHS_NM = np.arange(360.0, 831.0, 1.0)
_XYZ_TO_REC709 = np.array([[3.2404542, -1.5371385, -0.4985314],
                           [-0.9692660, 1.8760108, 0.0415560],
                           [0.0556434, -0.2040259, 1.0572252]])
_REC709_LUMINANCE = np.array([0.2126729, 0.7151522, 0.0721750])


def _lobe(x: np.ndarray, mu: float, s1: float, s2: float) -> np.ndarray:
    t = (x - mu) * np.where(x < mu, s1, s2)
    return np.exp(-0.5 * t * t)


def _cie_xyz(wl: np.ndarray) -> np.ndarray:
    x = (1.056 * _lobe(wl, 599.8, 0.0264, 0.0323) + 0.362 * _lobe(wl, 442.0, 0.0624, 0.0374)
         - 0.065 * _lobe(wl, 501.1, 0.0490, 0.0382))
    y = 0.821 * _lobe(wl, 568.8, 0.0213, 0.0247) + 0.286 * _lobe(wl, 530.9, 0.0613, 0.0322)
    z = 1.217 * _lobe(wl, 437.0, 0.0845, 0.0278) + 0.681 * _lobe(wl, 459.0, 0.0385, 0.0725)
    return np.stack([x, y, z], axis=-1)


_CMF = _cie_xyz(_WAVELENGTHS_NM)


def blackbody_rgb(kelvin: float) -> tuple[float, float, float]:
    """Linear Rec.709 colour of a black body at ``kelvin``, luminance 1 (negative
    components, far outside the gamut, clipped to 0 before scaling)."""
    t = max(float(kelvin), 800.0)  # Blender's lamp Temperature starts at 800 K
    lam = _WAVELENGTHS_NM * 1e-9
    c1, c2 = 3.741771852e-16, 1.438776877e-2
    with np.errstate(over="ignore"):
        radiance = c1 / (lam ** 5 * np.expm1(c2 / (lam * t)))
    xyz = (radiance[:, None] * _CMF).sum(axis=0)
    rgb = np.maximum(_XYZ_TO_REC709 @ xyz, 0.0)
    rgb /= float(_REC709_LUMINANCE @ rgb)
    return tuple(float(v) for v in rgb)
