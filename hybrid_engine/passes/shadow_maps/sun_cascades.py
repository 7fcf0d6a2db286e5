# SPDX-License-Identifier: GPL-3.0-or-later
"""Sun shadow cascades: shadow maps fitted to the first stretches of the camera's view.

One orthographic map over the whole scene (shadow_depth.py) spends the same texels on a
distant corner as next to the camera, where a sun's shadow edges are seen largest: over a
large scene its texels are coarse, and thin objects' shadows near the camera are drawn as
a staircase of teeth. Cascaded shadow maps (Engel 2006; the sun lamps of EEVEE and of
every real-time engine) add maps over nested parts of the view: cascade k covers the
camera's frustum from its clip start to ``reach * CASCADE_SPLIT ** -(count - k)``, where
``reach`` is how far the camera sees into the scene, so two cascades give texels 4 and 16
times finer than the scene map near the camera. The lookup (include/lighting.glsl) takes
the finest cascade that holds a point, else the scene map; the tracer's hits choose the
same way, wherever they are.

Each cascade is fitted to the bounding sphere of its part of the frustum, with the radius
rounded up to a quarter octave and the centre snapped to a grid in the sun's frame that is a
whole number of texels (Valient, "Stable rendering of cascaded shadow maps", ShaderX6): the
shadow edges do not crawl while the camera moves. The grid is coarse, a sixteenth of the
cascade's width, and the width grows by the half cell the snap may move the centre: a
moving camera keeps a cascade's matrix until its sphere's centre crosses into the next
cell, so a cascade is drawn again only every few frames of a walking camera, for texels
1/15 larger. The matrices are a function of the camera alone (no history): a viewport and
an F12 render of one view agree. The depth range spans the whole scene along the sun's
direction, so casters outside the cascade's sphere still cast into it.
"""
from __future__ import annotations

import math

import numpy as np

from ...scene.bounds import SceneBounds
from ...scene.camera import Camera, look_at, orthographic_matrix, view_from_world
from ..shadow_maps.shadow_atlas import ShadowView

# Each cascade reaches this many times less far than the next coarser one (the last, the
# scene map, reaches everywhere).
CASCADE_SPLIT = 4.0
# Cascade radii are rounded up to powers of 2 ** (1 / RADIUS_STEPS_PER_OCTAVE).
RADIUS_STEPS_PER_OCTAVE = 4
# A cascade's centre moves in steps of 1 / SNAP_CELLS of its width.
SNAP_CELLS = 16


def view_reach(camera: Camera, bounds: SceneBounds) -> float:
    """How far the camera sees into the scene: its clip end, or the distance to the far side
    of the scene's bounding sphere when that is nearer."""
    far_side = float(np.linalg.norm(camera.position - bounds.center)) + bounds.radius
    return max(min(float(camera.clip_end), far_side), float(camera.clip_start) * 2.0)


def quantized(value: float, steps_per_octave: int = RADIUS_STEPS_PER_OCTAVE) -> float:
    """``value`` rounded up to the next power of 2 ** (1 / steps_per_octave)."""
    steps = math.ceil(math.log2(max(value, 1e-9)) * steps_per_octave - 1e-9)
    return 2.0 ** (steps / steps_per_octave)


def view_sphere(camera: Camera, distance: float) -> tuple[np.ndarray, float]:
    """(centre, radius) of a sphere holding the camera's frustum between its clip start and
    ``distance``: the smallest one centred on the view axis around the frustum made
    symmetric, with the frustum's width rounded up to a sixteenth of an octave. A jittered
    camera (a sub-pixel shift of its view plane, antialias.py) gets the same sphere."""
    left, right, bottom, top = camera.viewplane()
    start = float(camera.clip_start)
    distance = max(float(distance), start)
    half = quantized(math.hypot(max(abs(left), abs(right)), max(abs(bottom), abs(top))), 16)
    if camera.projection == "ORTHO":
        along = 0.5 * (start + distance)
        radius = math.hypot(distance - along, half)
    else:
        slope = half / start
        along = min(0.5 * (start + distance) * (1.0 + slope * slope), distance)
        radius = max(math.hypot(distance - along, distance * slope), math.hypot(along - start, start * slope))
    return camera.position + camera.forward * along, radius


def cascade_reaches(camera: Camera, bounds: SceneBounds, count: int) -> list[float]:
    """The distance each of ``count`` cascades covers from the camera, finest first."""
    reach = view_reach(camera, bounds)
    return [reach * CASCADE_SPLIT ** -(count - k) for k in range(count)]


def sun_cascade_views(camera: Camera, direction: np.ndarray, bounds: SceneBounds, count: int,
                      resolution: int) -> list[ShadowView]:
    """``count`` orthographic shadow views for a sun shining along unit ``direction``,
    finest first (module doc); none when the scene's bounds are empty."""
    if count <= 0 or bounds.empty:
        return []
    direction = np.asarray(direction, np.float64)
    # The sun's frame: fixed by its direction alone, so that snapping is to one grid.
    frame = look_at(np.zeros(3), direction)
    rotation = frame[:3, :3]  # columns: the sun's right, up and back axes
    scene_radius = bounds.radius
    # The eye lies on the sun's side of the scene's bounding sphere, at a depth fixed by the
    # scene alone: every caster lies in front of it, the far plane behind the whole sphere.
    eye_depth = float(rotation[:, 2] @ bounds.center) + 1.01 * scene_radius
    near, far = 0.005 * scene_radius, 2.03 * scene_radius
    views = []
    for reach in cascade_reaches(camera, bounds, count):
        center, radius = view_sphere(camera, reach)
        # Snapping moves the centre by up to half a cell along each of the sun's axes: the
        # map's half-width r + radius / SNAP_CELLS must still hold the sphere of radius r.
        radius = quantized(radius * SNAP_CELLS / (SNAP_CELLS - 1))
        cell = 2.0 * radius / resolution * max(resolution // SNAP_CELLS, 1)  # whole texels
        across = np.floor(rotation[:, :2].T @ center / cell + 0.5) * cell
        placed = frame.copy()  # the sun's frame, moved to the cascade's eye
        placed[:3, 3] = rotation @ np.array([across[0], across[1], eye_depth])
        view = view_from_world(placed)
        proj = orthographic_matrix(radius, radius, near, far)
        views.append(ShadowView(proj @ view, 2.0 * radius, False, near, far))
    return views

