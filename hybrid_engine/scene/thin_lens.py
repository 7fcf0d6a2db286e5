# SPDX-License-Identifier: GPL-3.0-or-later
"""The camera's thin lens (Depth of Field), as Blender's camera and Cycles define it.

Cycles models depth of field as a thin lens: each camera ray starts at a point of the
aperture and is aimed at the point of the focus plane that the pinhole ray through the
same pixel meets (``camera_sample_perspective``). The aperture's radius in scene units is
``focal_length / (2 * f_stop)`` with the focal length in millimetres taken as metres
(``lens * 1e-3``; ``1 / (2 * f_stop)`` for an orthographic camera), independent of the
sensor; a polygonal aperture (``blades`` >= 3) is sampled as Cycles' ``regular_polygon_sample``
(corners on the unit circle, the first at ``rotation``), and the Ratio squeezes it along x
(anamorphic bokeh: x divided by the ratio).

Hybrid RT draws one aperture point per accumulated sample: the whole image of that sample
is rendered from the point, with the projection sheared so that the focus plane stays where
the pinhole camera sees it (frame/camera_effects.py). Averaged over the samples, a point off
the focus plane spreads over the circle of confusion, as Cycles' per-pixel aperture points
spread it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

# Cycles clamps the f-stop so that the aperture stays finite (blender/camera.cpp).
MIN_F_STOP = 1e-5


class ThinLensError(ValueError):
    """Lens values that describe no aperture (a negative size, a focus distance of zero)."""


@dataclass(frozen=True)
class ThinLens:
    """An aperture of ``radius`` scene units, focused at ``focus_distance`` along the view
    axis; ``blades`` 0 is a disc, 3 or more a regular polygon turned by ``rotation`` radians;
    ``ratio`` is Blender's aperture Ratio (x is divided by it)."""

    radius: float
    focus_distance: float
    blades: int = 0
    rotation: float = 0.0
    ratio: float = 1.0

    def __post_init__(self) -> None:
        values = (self.radius, self.focus_distance, self.rotation, self.ratio)
        if not all(math.isfinite(v) for v in values):
            raise ThinLensError(f"lens values must be finite, got {values}")
        if self.radius < 0:
            raise ThinLensError(f"the aperture radius must not be negative, got {self.radius}")
        if not self.focus_distance > 0:
            raise ThinLensError(f"the focus distance must be positive, got {self.focus_distance}")
        if not self.ratio > 0:
            raise ThinLensError(f"the aperture ratio must be positive, got {self.ratio}")
        # Cycles draws a disc for fewer than three blades.
        object.__setattr__(self, "blades", int(self.blades) if int(self.blades) >= 3 else 0)

    @property
    def active(self) -> bool:
        """Whether the lens blurs anything (a zero aperture is a pinhole)."""
        return self.radius > 0.0

    @classmethod
    def from_blender(cls, lens_mm: float, f_stop: float, focus_distance: float, *, blades: int = 0,
                     rotation: float = 0.0, ratio: float = 1.0, orthographic: bool = False) -> "ThinLens":
        """The lens of a Blender camera's Depth of Field panel, with Cycles' aperture radius
        (module docstring). ``focus_distance`` is the one the camera resolved (the focus
        object's distance along the view axis, else the Distance)."""
        f_stop = max(float(f_stop), MIN_F_STOP)
        radius = 1.0 / (2.0 * f_stop) if orthographic else float(lens_mm) * 1e-3 / (2.0 * f_stop)
        return cls(radius=radius, focus_distance=max(float(focus_distance), 1e-6), blades=blades,
                   rotation=float(rotation), ratio=float(ratio))

    def aperture_point(self, u: float, v: float) -> tuple[float, float]:
        """The point of the aperture, in camera-space x and y (scene units), that the uniform
        numbers ``u``, ``v`` in [0, 1) pick: uniform over the disc or the polygon, as Cycles'
        ``camera_sample_aperture`` maps them."""
        if self.blades == 0:
            x, y = _concentric_disc(u, v)
        else:
            x, y = _regular_polygon(self.blades, self.rotation, u, v)
        return x * self.radius / self.ratio, y * self.radius


def _concentric_disc(u: float, v: float) -> tuple[float, float]:
    """Shirley and Chiu's concentric map of the unit square onto the unit disc (Cycles'
    ``sample_uniform_disk``): uniform, and it keeps a stratified set stratified."""
    a, b = 2.0 * u - 1.0, 2.0 * v - 1.0
    if a == 0.0 and b == 0.0:
        return 0.0, 0.0
    if abs(a) > abs(b):
        r, phi = a, (math.pi / 4.0) * (b / a)
    else:
        r, phi = b, math.pi / 2.0 - (math.pi / 4.0) * (a / b)
    return r * math.cos(phi), r * math.sin(phi)


def _regular_polygon(corners: int, rotation: float, u: float, v: float) -> tuple[float, float]:
    """Cycles' ``regular_polygon_sample``: one of the polygon's triangles (centre and two
    neighbouring corners on the unit circle) by ``u``, a uniform point in it by the rest."""
    corner = math.floor(u * corners)
    u = u * corners - corner
    u = math.sqrt(u)
    v = v * u
    u = 1.0 - u
    angle = math.pi / corners
    px, py = (u + v) * math.cos(angle), (u - v) * math.sin(angle)
    rotation += corner * 2.0 * math.pi / corners
    cr, sr = math.cos(rotation), math.sin(rotation)
    return cr * px - sr * py, sr * px + cr * py
