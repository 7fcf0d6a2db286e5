# SPDX-License-Identifier: GPL-3.0-or-later
"""The Normal Map node in every space (node_program.glsl ``node_normal_map``), through
Blender's render path: against Cycles from both sides of the surface (Blender Object and
Blender World read Y and Z negated, object and world maps turn over on back faces), and at
ray hits in a HYBRID mirror, where the tangent frame is the hit triangle's (its UV
directions, trace_ray.glsl ``bvh_hit``). The tiles' UVs are turned, so the tangent space is
not the object's."""
from __future__ import annotations

import math

import numpy as np
import pytest

from normal_scenes import (difference, inner, mirror_scene, normal_map, primary_and_mirrored, render_both, row_scene,
                           tile_pixels)

MEAN_BAR, P99_BAR = 0.01, 0.02
SPACES = ("TANGENT", "OBJECT", "WORLD", "BLENDER_OBJECT", "BLENDER_WORLD")
UV_TURN = math.radians(60.0)
_rendered: dict[str, tuple[np.ndarray, np.ndarray]] = {}


@pytest.fixture
def both_sides(addon, tmp_path):
    """Both engines' render of one tile per space, from above and from below (once)."""
    import bpy

    if "front" not in _rendered:
        builds = {space: (lambda n, l, s=space: normal_map(n, l, s)) for space in SPACES}
        scene, camera = row_scene(bpy, builds, uv_turn=UV_TURN)
        _rendered["front"] = render_both(bpy, scene, tmp_path)
        camera.location, camera.rotation_euler = (0.0, 0.0, -3.0), (math.pi, 0.0, 0.0)
        _rendered["back"] = render_both(bpy, scene, tmp_path)
    return _rendered


@pytest.mark.parametrize("side", ["front", "back"])
@pytest.mark.parametrize("space", SPACES)
def test_a_normal_map_matches_cycles_in_every_space_from_either_side(both_sides, space, side):
    ours, cycles = both_sides[side]
    k = SPACES.index(space)
    a, b = tile_pixels(ours, k), tile_pixels(cycles, k)
    assert b.std() > 0.02, f"{space}: Cycles shows no map"
    mean, p99 = difference(a, b)
    assert mean <= MEAN_BAR and p99 <= P99_BAR, f"{space} {side}: mean {mean:.4f}, p99 {p99:.4f} against Cycles"


@pytest.mark.parametrize("tracer", ["cpu", "gpu"])
@pytest.mark.parametrize("space", SPACES)
def test_a_normal_map_seen_in_a_hybrid_mirror_matches_its_primary_view(addon, tmp_path, monkeypatch, space, tracer):
    """Either tracer: the wave tracer's hit records carry the tangent frame."""
    import bpy

    monkeypatch.setenv("HYBRID_RT_KERNELS", f"trace={tracer}")

    scene, camera = mirror_scene(bpy, lambda n, l: normal_map(n, l, space), uv_turn=UV_TURN)
    primary, mirrored = primary_and_mirrored(bpy, scene, camera, tmp_path)
    assert inner(primary).std() > 0.02
    mean, p99 = difference(inner(mirrored), inner(primary))
    assert mean <= MEAN_BAR and p99 <= P99_BAR, (space, mean, p99)
