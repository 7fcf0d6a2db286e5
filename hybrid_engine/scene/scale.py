# SPDX-License-Identifier: GPL-3.0-or-later
"""Settings that follow the scene's scale and the output's size: what an Automatic setting
(stored as 0 in ``RenderSettings``) is worth for one frame.

A scene is the same picture whether it is modelled in millimetres or kilometres, so none of
its default lengths may be absolute. Each automatic length is derived from the scene's
finite bounds (``SceneBounds``: a non-finite vertex cannot move them) and the camera:

* *Far Clip* (the cube map's far plane, paper §3.2) reaches the farthest corner of the
  scene's bounds seen from the eye, so no object is ever clipped out of the reflections,
  and no farther, so the map's depth precision is spent on the scene;
* *Near Size* (the near cube's half-size, paper §3.3) is a multiple of the scene's typical
  object size, the median size of its distinct meshes (each the median diagonal of its
  instances' bounds): a floor or a sky dome a hundred times larger than the rest does not
  swell the near cube, which would make the BVH hold most of the scene, and many instances
  of one small mesh do not shrink it;
* *Frame Budget*'s limits on the near size are a fraction and a multiple of that Automatic
  near size, so the budget controller searches the sizes that matter at the scene's scale;
* the cube map's face resolution is a ratio of the output's longer side: a face texel keeps
  to the size of a pixel, so a small output does not pay for a large cube map.

Everything here reads the per-object bounds the scene already holds (medians over the
objects per frame), never the triangles, and nothing from the GPU.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .bounds import SceneBounds
from .data import SceneData
from .settings import RenderSettings

# Near Size over the median object diagonal: the Chess benchmark's pieces (median diagonal
# about 1.4) get the near cube of about 3.5 the benchmark was tuned with (bench.FRAME_NEAR_SIZE).
NEAR_SIZE_PER_OBJECT = 2.5
# Frame Budget's Automatic limits over the Automatic near size: the Chess benchmark's
# (about 3.5) gets the limits of about 0.5 and 20 the controller was tuned with.
NEAR_MIN_PER_NEAR = 0.15
NEAR_MAX_PER_NEAR = 6.0
# The far plane lies this much beyond the farthest corner: the cube map stores depths up to
# it exclusive, and a corner exactly on it would be clipped.
FAR_MARGIN = 1.02
# The far plane stays at least this far beyond the near cube's faces (settings validation).
FAR_OVER_NEAR = 2.0
# The face resolution a ratio may give: below the floor, diffuse rays that march the map slip
# between its texels and bring the sky into closed rooms (a face of 256 costs little at any
# output size), and past the ceiling the faces' raster costs more than any output needs.
CUBE_RESOLUTION_RANGE = (256, 2048)
CUBE_RESOLUTION_STEP = 16  # faces a multiple of 16 texels: whole workgroups of the hi-z pyramid
# Lengths used when the scene has no finite geometry (nothing to clip or trace).
EMPTY_SCENE_SCALE = 1.0


@dataclass(frozen=True)
class EffectiveValues:
    """The values a frame rendered with: the settings' own where fixed, derived where
    Automatic (``automatic`` names those)."""

    near_size: float
    cube_far: float
    cube_resolution: int
    near_min: float = 0.0
    near_max: float = 0.0
    automatic: tuple[str, ...] = ()

    def as_dict(self) -> dict[str, float]:
        return {"near_size": self.near_size, "cube_far": self.cube_far, "cube_resolution": self.cube_resolution,
                "near_min": self.near_min, "near_max": self.near_max}


def _diagonals(scene: SceneData) -> tuple[np.ndarray, np.ndarray]:
    """The diagonal of each object's bounds, and which are finite and non-degenerate."""
    b = np.asarray(scene.geometry.object_bounds, np.float64).reshape(-1, 2, 3)
    finite = np.isfinite(b).all(axis=(1, 2)) & (b[:, 0] <= b[:, 1]).all(axis=1)
    diag = np.linalg.norm(b[:, 1] - b[:, 0], axis=1)
    return diag, finite & (diag > 0.0)


def typical_object_size(scene: SceneData) -> float:
    """The median diagonal of the scene's objects with finite, non-degenerate bounds
    (``EMPTY_SCENE_SCALE`` when none has): a length that scales with the scene and reads
    only what every description of it holds, so an instanced scene and its triangles
    flattened to world space get one unit (the random numbers' cells, random.glsl)."""
    diag, kept = _diagonals(scene)
    return float(np.median(diag[kept])) if kept.any() else EMPTY_SCENE_SCALE


def typical_mesh_size(scene: SceneData) -> float:
    """The median size of the scene's distinct shapes: each mesh's size is the mean
    diagonal of its instances with finite, non-degenerate bounds, and the scene's the median
    of those (``EMPTY_SCENE_SCALE`` when none has). A mesh counts once however often it is
    instanced: nine linked duplicates of a pebble, or a thousand scattered blades of grass, do
    not make the room they lie in a scene of pebbles and shrink the near cube to nothing.
    Geometry without an instance table counts each object as its own mesh."""
    diag, kept = _diagonals(scene)
    if not kept.any():
        return EMPTY_SCENE_SCALE
    instances = getattr(scene.geometry, "instances", None)
    if instances is None or len(instances) != len(diag):
        return float(np.median(diag[kept]))
    mesh = np.asarray(instances.mesh)[kept]
    count = np.bincount(mesh)
    shown = count > 0
    return float(np.median(np.bincount(mesh, weights=diag[kept])[shown] / count[shown]))


def farthest_corner(bounds: SceneBounds, eye: np.ndarray) -> float:
    """The distance from ``eye`` to the farthest corner of ``bounds`` (0 when empty)."""
    if bounds.empty:
        return 0.0
    far = np.maximum(np.abs(bounds.lo - eye), np.abs(bounds.hi - eye))
    return float(np.linalg.norm(far))


def auto_near_size(scene: SceneData | None) -> float:
    """The Automatic near size: ``NEAR_SIZE_PER_OBJECT`` times the typical mesh size
    (``EMPTY_SCENE_SCALE``'s when no scene is at hand)."""
    return NEAR_SIZE_PER_OBJECT * (typical_mesh_size(scene) if scene is not None else EMPTY_SCENE_SCALE)


def near_limits(settings: RenderSettings, scene: SceneData | None, auto: float | None = None
                ) -> tuple[float, float]:
    """Frame Budget's smallest and largest near size: the artist's where set, else a fraction
    and a multiple of the Automatic near size (``auto`` when the caller has it). The largest
    is never below the smallest (a fixed minimum above an Automatic maximum lifts it)."""
    if auto is None:
        auto = auto_near_size(scene) if settings.near_min <= 0.0 or settings.near_max <= 0.0 else 0.0
    lo = float(settings.near_min) if settings.near_min > 0.0 else NEAR_MIN_PER_NEAR * auto
    hi = float(settings.near_max) if settings.near_max > 0.0 else NEAR_MAX_PER_NEAR * auto
    return lo, max(lo, hi)


def auto_cube_resolution(ratio: float, width: int, height: int) -> int:
    """The face resolution ``ratio`` times the output's longer side, rounded to a multiple
    of ``CUBE_RESOLUTION_STEP`` within ``CUBE_RESOLUTION_RANGE``."""
    lo, hi = CUBE_RESOLUTION_RANGE
    res = int(round(ratio * max(int(width), int(height)) / CUBE_RESOLUTION_STEP)) * CUBE_RESOLUTION_STEP
    return int(min(max(res, lo), hi))


def effective_values(settings: RenderSettings, scene: SceneData, eye, width: int, height: int) -> EffectiveValues:
    """The near size, far clip and face resolution a frame of ``settings`` seen from ``eye``
    at ``width`` x ``height`` renders with."""
    automatic = [name for name in ("near_min", "near_max") if getattr(settings, name) <= 0.0]
    near = float(settings.near_size)
    # The typical mesh size (a median over the meshes) once per frame, for every
    # Automatic near value that needs it.
    auto = auto_near_size(scene) if automatic or near <= 0.0 else 0.0
    near_min, near_max = near_limits(settings, scene, auto)
    if near <= 0.0:
        automatic.append("near_size")
        near = auto
    far = float(settings.cube_far)
    if far <= 0.0:
        automatic.append("cube_far")
        reach = farthest_corner(SceneBounds.of(scene), np.asarray(eye, np.float64))
        largest_near = max(near, near_max if settings.near_cube_mode == "BUDGET" else near)
        far = max(reach * FAR_MARGIN, largest_near * FAR_OVER_NEAR)
    if "cube_far" not in automatic:  # a fixed far plane bounds the automatic near cubes
        if "near_size" in automatic:
            near = min(near, far / FAR_OVER_NEAR)
        if "near_max" in automatic:
            near_max = min(near_max, far / FAR_OVER_NEAR)
            near_min = min(near_min, near_max) if "near_min" in automatic else near_min
    res = int(settings.cube_resolution)
    if res <= 0:
        automatic.append("cube_resolution")
        res = auto_cube_resolution(settings.cube_resolution_ratio, width, height)
    return EffectiveValues(near, far, res, near_min, near_max, tuple(automatic))


def resolve(settings: RenderSettings, scene: SceneData, eye, width: int, height: int
            ) -> tuple[RenderSettings, EffectiveValues]:
    """``settings`` with every Automatic value replaced by what this frame renders with, and
    those values. Settings without Automatic values come back unchanged (the same object)."""
    values = effective_values(settings, scene, eye, width, height)
    if not values.automatic:
        return settings, values
    return replace(settings, near_size=values.near_size, cube_far=values.cube_far,
                   cube_resolution=values.cube_resolution, near_min=values.near_min,
                   near_max=values.near_max), values
