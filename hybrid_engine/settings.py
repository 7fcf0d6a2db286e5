# SPDX-License-Identifier: GPL-3.0-or-later
"""Render settings as a frozen, comparable dataclass.

Comparing this frame's settings with the last decides what must be rebuilt (cube-map
targets when the face resolution changes, nothing when only max_depth changes). Each
field's documentation in ``FIELD_DOCS`` is reused verbatim as the Blender UI tooltip, and
``FIELD_LIMITS`` as the property's min/max, so the core and the UI cannot disagree.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

MODES = ("HYBRID", "FULL_BVH", "PROVENANCE", "RASTER")

CUBE_MARCHES = ("HIERARCHICAL", "SAMPLED")

CUBE_MARCH_DOCS = {
    "HIERARCHICAL": "Visit every cube-map texel the ray crosses, skipping empty and unreachable "
    "regions with a min/max depth pyramid: exact and fast",
    "SAMPLED": "The paper's march: n_min to n_max equally spaced depth samples per face (3.4)",
}

MODE_DOCS = {
    "HYBRID": "The paper's method: BVH near the camera, G-buffer cube map beyond it",
    "FULL_BVH": "One BVH over the whole scene, no cube map: the ground truth the hybrid approximates",
    "PROVENANCE": "Reflective and refractive pixels coloured by where their first secondary ray "
    "started: BVH blue, cube map red (paper Figure 4)",
    "RASTER": "Primary visibility only: deferred shading with shadow maps, no secondary rays",
}

FIELD_DOCS = {
    "mode": "What the engine renders",
    "near_size": "Half-size of the near cube around the camera (scene units): geometry inside is "
    "ray traced through a per-frame BVH, geometry outside is ray marched in the cube map",
    "max_depth": "Maximum number of secondary bounces (reflections and refractions) per pixel",
    "cube_resolution": "Resolution of each of the six G-buffer cube-map faces, in pixels",
    "cube_far": "Far plane of the cube-map faces (scene units); rays that pass it see the sky",
    "cube_march": "How rays are marched through the cube-map faces",
    "cube_back_layer": "Also store the far side of closed objects in the cube map (a second layer "
    "of back faces): a ray that passes behind a surface meets its hidden side instead of a "
    "surface stretched by the material's thickness",
    "cube_hidden_exit": "A ray that leaves the cube map at a point the camera cannot see (under a "
    "floor, behind an object) hits the surface that hides the point instead of seeing the sky, "
    "which the paper gives it",
    "n_min": "SAMPLED march: samples per cube-map face for rays grazing the face "
    "(paper 3.4: n = n_min + (N.r)(n_max - n_min))",
    "n_max": "SAMPLED march: samples per cube-map face for rays entering it head-on "
    "(paper 3.4: n = n_min + (N.r)(n_max - n_min))",
    "shadow_resolution": "Resolution of each shadow map, in pixels",
    "shadow_bias": "Depth bias of shadow-map tests, in scene units, against shadow acne",
    "viewport_scale": "Fraction of the viewport's resolution that is rendered (lower is faster)",
    "sky_rays": "Gather the World's light with rays through the BVH and the cube map: the sky each "
    "surface sees at any distance, and the light of the surfaces that hide it (one bounce); "
    "slower than the screen-space occlusion within AO Distance",
    "viewport_samples": "Viewport: samples accumulated while nothing changes (each moved by a "
    "fraction of a pixel, with fresh glossy and shadow directions); any change starts over",
    "ao_distance": "How far (scene units) a surface looks for geometry that hides the World's "
    "light from it (ambient occlusion); 0 lights every surface by the whole sky",
    "render_samples": "Final renders: samples per pixel, each with the camera moved by a different "
    "fraction of a pixel, averaged (anti-aliasing; each sample after the first costs a primary "
    "raster, the shading and the trace). The viewport takes one",
}

FIELD_LIMITS = {
    "near_size": (0.01, 1.0e5),
    "max_depth": (0, 16),
    "cube_resolution": (16, 4096),
    "cube_far": (0.1, 1.0e7),
    "n_min": (1, 1024),
    "n_max": (1, 4096),
    "shadow_resolution": (64, 8192),
    "shadow_bias": (0.0, 10.0),
    "viewport_scale": (0.1, 1.0),
    "render_samples": (1, 256),
    "ao_distance": (0.0, 1.0e4),
    "viewport_samples": (1, 4096),
}


class SettingsError(ValueError):
    """A setting is outside its documented range."""


@dataclass(frozen=True)
class RenderSettings:
    mode: str = "HYBRID"
    near_size: float = 5.0
    max_depth: int = 4
    cube_resolution: int = 512
    cube_far: float = 1000.0
    cube_march: str = "HIERARCHICAL"
    cube_back_layer: bool = False
    cube_hidden_exit: bool = True
    n_min: int = 16
    n_max: int = 64
    shadow_resolution: int = 1024
    shadow_bias: float = 0.02
    viewport_scale: float = 1.0
    render_samples: int = 4
    ao_distance: float = 1.0
    viewport_samples: int = 16
    sky_rays: bool = False

    @property
    def traces_sky(self) -> bool:
        """Whether the World's light is gathered by sky rays (only where a BVH is built)."""
        return self.sky_rays and self.mode in ("HYBRID", "FULL_BVH")

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise SettingsError(f"mode must be one of {', '.join(MODES)}, got {self.mode!r}")
        if self.cube_march not in CUBE_MARCHES:
            raise SettingsError(
                f"cube_march must be one of {', '.join(CUBE_MARCHES)}, got {self.cube_march!r}")
        for f in fields(self):
            if f.name not in FIELD_LIMITS:
                continue
            value = getattr(self, f.name)
            lo, hi = FIELD_LIMITS[f.name]
            if isinstance(value, float) and not math.isfinite(value):
                raise SettingsError(f"{f.name} must be finite, got {value}")
            if not lo <= value <= hi:
                raise SettingsError(f"{f.name} must lie in [{lo}, {hi}], got {value}")
        if self.n_min > self.n_max:
            raise SettingsError(f"n_min ({self.n_min}) must not exceed n_max ({self.n_max})")
        if self.cube_far <= self.near_size:
            raise SettingsError(
                f"cube_far ({self.cube_far}) must lie beyond the near cube (near_size {self.near_size})"
            )
