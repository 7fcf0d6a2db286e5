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

# The diagnostic views render a HYBRID frame and show, per pixel, where its rays and time went
# (trace/diagnostic_views.py); they are modes so that the viewport, F12 and timing reports show them alike.
DIAGNOSTIC_VIEWS = ("BOUNCES", "CUBE_STEPS", "BVH_NODES", "BOUNCE_PATHS")
MODES = ("HYBRID", "FULL_BVH", "PROVENANCE", *DIAGNOSTIC_VIEWS, "RASTER")

CUBE_MARCHES = ("HIERARCHICAL", "SAMPLED")

NEAR_CUBE_MODES = ("FIXED", "BUDGET")
NEAR_CUBE_MODE_DOCS = {
    "FIXED": "The near cube keeps the size you set",
    "BUDGET": "The near cube is resized every frame to keep the frame time near the budget, "
    "between the minimum and maximum you set",
}
NEAR_CUBE_MODE_LABELS = {"FIXED": "Fixed", "BUDGET": "Frame Budget"}

CUBE_MARCH_DOCS = {
    "HIERARCHICAL": "Visit every cube-map texel a ray crosses, skipping empty regions: exact and fast",
    "SAMPLED": "Take a fixed number of equally spaced samples per face, as the paper does: "
    "faster on simple scenes, but thin objects can be stepped over",
}

MODE_DOCS = {
    "HYBRID": "Reflections and refractions traced exactly near the camera and looked up in a "
    "cube map beyond it: fast, and close to Full BVH",
    "FULL_BVH": "Every reflection and refraction traced exactly through the whole scene: the "
    "reference Hybrid is compared with, and slower",
    "PROVENANCE": "Shows where each reflection starts: blue near the camera (traced exactly), "
    "red farther away (looked up in the cube map)",
    "BOUNCES": "Diagnostic: how many bounces deep each pixel's reflections and refractions go",
    "CUBE_STEPS": "Diagnostic: how many steps each pixel's rays take searching the cube map",
    "BVH_NODES": "Diagnostic: how many BVH nodes each pixel's rays visit near the camera",
    "BOUNCE_PATHS": "Diagnostic: where each pixel's rays of one bounce end: near the camera (BVH), "
    "in the cube map or in the sky",
    "RASTER": "No reflections or refractions: the lit surfaces only, fastest",
}
MODE_LABELS = {"HYBRID": "Hybrid", "FULL_BVH": "Full BVH", "PROVENANCE": "Provenance", "BOUNCES": "Bounces",
               "CUBE_STEPS": "Cube Map Steps", "BVH_NODES": "BVH Nodes", "BOUNCE_PATHS": "Bounce Paths",
               "RASTER": "Raster"}
CUBE_MARCH_LABELS = {"HIERARCHICAL": "Hierarchical", "SAMPLED": "Sampled"}

# How diffuse surfaces find the World's (and the other surfaces') light: traced paths
# (passes/diffuse_light/), or the screen-space occlusion within AO Distance
# (passes/shading/screen_ao.py), which RASTER, having no BVH, always uses.
WORLD_LIGHTS = ("RAYS", "SCREEN")
WORLD_LIGHT_DOCS = {
    "RAYS": "Trace rays from every diffuse surface through the BVH and the cube map: the sky "
    "where they escape, the light of the surfaces they meet, bounce after bounce. Closed rooms "
    "stay dark, whatever their size",
    "SCREEN": "Look for what hides the sky in the screen's depths, within AO Distance: faster "
    "and smoother, but light leaks through walls and from off screen",
}
WORLD_LIGHT_LABELS = {"RAYS": "Rays", "SCREEN": "Screen Space"}

FIELD_DOCS = {
    "mode": "How reflections and refractions are rendered",
    "near_size": "Half the size of the box around the camera whose objects reflections and "
    "refractions meet exactly; beyond it they are looked up in the cube map. Larger is more "
    "exact and slower. 0: Automatic, a multiple of the scene's typical object size",
    "max_depth": "How many times a ray may be reflected or refracted; past the last bounce the "
    "surface it meets is lit but reflects nothing more",
    "cube_resolution": "Size of each of the cube map's six faces: sharper distant reflections, "
    "more memory and time. 0: Automatic, the output's longer side times the Resolution Ratio",
    "cube_resolution_ratio": "Automatic face resolution: the cube map's face size as a fraction of "
    "the output's longer side (a face texel about a pixel's size)",
    "cube_far": "How far the cube map reaches; reflections of anything beyond show the World. "
    "0: Automatic, the farthest corner of the scene's bounds seen from the camera",
    "cube_march": "How rays search the cube map for what they meet",
    "near_cube_mode": "Whether the near cube keeps its size or follows a frame-time budget",
    "frame_budget_ms": "The frame time the near cube is sized for, in milliseconds (33.3 for "
    "30 frames per second)",
    "near_min": "Frame Budget: the smallest size the near cube may shrink to (0: Automatic, a "
                "fraction of the scene's typical object size)",
    "near_max": "Frame Budget: the largest size the near cube may grow to (0: Automatic, a "
                "multiple of the scene's typical object size)",
    "cube_back_layer": "Also store the far side of closed objects in the cube map (a second layer "
    "of back faces): a ray that passes behind a surface meets its hidden side instead of a "
    "surface stretched by the material's thickness. Final renders always store it",
    "cube_hidden_exit": "A ray that leaves the cube map at a point the camera cannot see (under a "
    "floor, behind an object) hits the surface that hides the point instead of seeing the sky, "
    "which the paper gives it",
    "diagnostic_bounce": "Bounce Paths view: the bounce whose rays it shows (1: the first "
    "reflections and refractions)",
    "n_min": "Sampled search: samples per cube-map face for rays that run along the face",
    "n_max": "Sampled search: samples per cube-map face for rays that cross it head-on",
    "shadow_resolution": "Size of each shadow map: sharper shadows, more memory and time",
    "shadow_bias": "A constant distance added to the bias, in scene units (files of earlier "
    "versions keep their bias here). 0: the bias is in shadow-map texels only, which holds at "
    "every scale",
    "shadow_bias_texels": "How far shadows start behind the surfaces that cast them, in texels "
    "of the shadow map there (so at every scene scale): raise it if lit surfaces show dark "
    "speckles, lower it if shadows come loose from their objects",
    "shadow_normal_offset": "How far the shadow lookup moves off a surface turned away from the "
    "lamp, in shadow-map texels times the sine of its angle to the lamp (normal offset)",
    "shadow_cascades": "Extra shadow maps for sun lamps over the part of the view nearest the "
    "camera, each 4 times finer than the next: sharp sun shadows close by, with one more "
    "shadow render whenever the camera moves. 0: one map over the whole scene",
    "viewport_scale": "Fraction of the viewport's resolution that is rendered (lower is faster)",
    "viewport_samples": "Viewport: samples accumulated while nothing changes (each moved by a "
    "fraction of a pixel, with fresh glossy and shadow directions); any change starts over",
    "ao_distance": "Screen Space World Light: how far (scene units) a surface looks for geometry "
    "that hides the World's light from it (ambient occlusion); 0 lights every surface by the "
    "whole sky",
    "render_samples": "Final renders: samples per pixel, each with the camera moved by a different "
    "fraction of a pixel, averaged (anti-aliasing; each sample after the first costs a primary "
    "raster, the shading and the trace). The viewport takes one",
    "world_light": "How diffuse surfaces find the light of the World and of the surfaces around "
    "them",
    "diffuse_bounces": "Rays World Light: how many times light bounces between diffuse surfaces "
    "before it reaches the eye. 0: direct light only (the sky and lamps a surface sees), each "
    "bounce more lights rooms from their walls, at the cost of one more ray",
    "diffuse_rays": "Rays World Light: paths traced from each diffuse pixel per sample: less "
    "noise, proportionally slower",
    "bounce_feedback": "Rays World Light, denoised frames: a path that has bounced Bounces times and "
    "ends on a surface the last frame saw takes that surface's light from then, so more bounces build "
    "up over the frames, for the cost of the bounces traced: brighter rooms than Cycles' count of "
    "bounces, and the viewport's first frames darker than the later ones",
    "radiance_cache": "Rays World Light, denoised frames: where a path bounces off its first surface, "
    "take the light many paths brought back from around that spot over the last frames instead of "
    "the path's own, where the denoiser has few frames of a pixel (a view's first samples, what the "
    "camera uncovers): less noise indoors there, a slight blur of the bounced light",
    "lit_cube": "Shade the cube map's surfaces once per frame (lamps, World and light bounced between "
    "them, built up over frames) and let reflections read that light, blurred to their roughness, "
    "instead of shading every hit again",
    "denoise_viewport": "Viewport: filter the noise of the World's and the bounced light, in space and "
    "over the frames, following the surfaces as the camera moves (reflections and textures stay sharp)",
    "denoise_render": "Final renders: filter the noise of the World's and the bounced light over the "
    "image and the samples (reflections and textures stay sharp)",
}

FIELD_LIMITS = {
    "near_size": (0.0, 1.0e5),
    "frame_budget_ms": (1.0, 1.0e5),
    "near_min": (0.0, 1.0e5),
    "near_max": (0.0, 1.0e5),
    "max_depth": (0, 16),
    "diagnostic_bounce": (1, 17),
    "cube_resolution": (0, 4096),
    "cube_far": (0.0, 1.0e7),
    "cube_resolution_ratio": (0.05, 4.0),
    "n_min": (1, 1024),
    "n_max": (1, 4096),
    "shadow_resolution": (64, 8192),
    "shadow_bias": (0.0, 1.0e4),
    "shadow_bias_texels": (0.0, 64.0),
    "shadow_normal_offset": (0.0, 64.0),
    "shadow_cascades": (0, 4),
    "viewport_scale": (0.1, 1.0),
    "render_samples": (1, 256),
    "ao_distance": (0.0, 1.0e4),
    "viewport_samples": (1, 4096),
    "diffuse_bounces": (0, 8),
    "diffuse_rays": (1, 16),
}


# Settings whose 0 means Automatic (scene/scale.py), and the fixed value the interface offers
# when the artist switches Automatic off (the defaults before they followed the scene).
AUTOMATIC_FIXED = {"near_size": 5.0, "cube_far": 1000.0, "cube_resolution": 512, "near_min": 0.5, "near_max": 20.0}
MIN_CUBE_RESOLUTION = 16


class SettingsError(ValueError):
    """A setting is outside its documented range."""


@dataclass(frozen=True)
class RenderSettings:
    mode: str = "HYBRID"
    near_size: float = 0.0  # Automatic (scene/scale.py)
    max_depth: int = 4
    cube_resolution: int = 0  # Automatic: cube_resolution_ratio of the output
    cube_resolution_ratio: float = 0.4
    cube_far: float = 0.0  # Automatic
    cube_march: str = "HIERARCHICAL"
    cube_back_layer: bool = False
    cube_hidden_exit: bool = True
    n_min: int = 16
    n_max: int = 64
    shadow_resolution: int = 1024
    shadow_bias: float = 0.0
    shadow_bias_texels: float = 1.0
    shadow_normal_offset: float = 1.5
    shadow_cascades: int = 2
    viewport_scale: float = 1.0
    render_samples: int = 4
    ao_distance: float = 1.0
    viewport_samples: int = 16
    near_cube_mode: str = "FIXED"
    frame_budget_ms: float = 33.3
    near_min: float = 0.0  # Automatic (scene/scale.py)
    near_max: float = 0.0  # Automatic
    diagnostic_bounce: int = 1
    world_light: str = "RAYS"
    diffuse_bounces: int = 4
    diffuse_rays: int = 1
    bounce_feedback: bool = False
    lit_cube: bool = False
    radiance_cache: bool = True
    denoise_viewport: bool = True
    denoise_render: bool = True

    @property
    def trace_mode(self) -> str:
        """The mode whose passes render this frame: a diagnostic view renders HYBRID's."""
        return "HYBRID" if self.mode in DIAGNOSTIC_VIEWS else self.mode

    @property
    def traces_diffuse(self) -> bool:
        """Whether diffuse light is gathered by traced paths (passes/diffuse_light/): asked
        for, and a BVH is built to trace them through (RASTER and PROVENANCE build none and
        fall back to the screen-space occlusion)."""
        return self.world_light == "RAYS" and self.trace_mode in ("HYBRID", "FULL_BVH")

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise SettingsError(f"mode must be one of {', '.join(MODES)}, got {self.mode!r}")
        if self.near_cube_mode not in NEAR_CUBE_MODES:
            raise SettingsError(f"near_cube_mode must be one of {', '.join(NEAR_CUBE_MODES)}, "
                                f"got {self.near_cube_mode!r}")
        if self.world_light not in WORLD_LIGHTS:
            raise SettingsError(
                f"world_light must be one of {', '.join(WORLD_LIGHTS)}, got {self.world_light!r}")
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
        if 0.0 < self.near_max < self.near_min:
            raise SettingsError(f"near_min ({self.near_min}) must not exceed near_max ({self.near_max})")
        if 0 < self.cube_resolution < MIN_CUBE_RESOLUTION:
            raise SettingsError(f"cube_resolution must be 0 (Automatic) or at least {MIN_CUBE_RESOLUTION}, "
                                f"got {self.cube_resolution}")
        if self.cube_far <= 0.0:
            return  # Automatic: placed beyond the near cube each frame (scene/scale.py)
        if self.near_cube_mode == "BUDGET" and self.cube_far <= self.near_max:  # 0 (Automatic) passes
            raise SettingsError(
                f"cube_far ({self.cube_far}) must lie beyond the largest near cube (near_max {self.near_max})")
        if self.cube_far <= self.near_size and self.near_size > 0.0:
            raise SettingsError(
                f"cube_far ({self.cube_far}) must lie beyond the near cube (near_size {self.near_size})"
            )
