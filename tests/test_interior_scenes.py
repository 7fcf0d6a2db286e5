# SPDX-License-Identifier: GPL-3.0-or-later
"""The interior scenes (benchmarks/interior_scenes.py): each isolates what it claims to.

Oracle: Blender's own ray casts (``Scene.ray_cast``) into the built scene, independent of the
renderer: a closed room lets no ray out, the window room lets rays out through its window
only, the Cornell box holds an emissive panel and no other light.
"""
from __future__ import annotations

import importlib

import numpy as np
import pytest

from conftest import SHARED_SCENES

RAYS = 400
SIZE = (32, 18)


@pytest.fixture
def lib(addon):
    return importlib.import_module("benchmarks.scene_library")


def directions(count: int, seed: int = 7) -> np.ndarray:
    d = np.random.default_rng(seed).normal(size=(count, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def escaping(scene, origin, count: int = RAYS) -> np.ndarray:
    """Which of ``count`` fixed random directions from ``origin`` meet nothing."""
    import bpy
    from mathutils import Vector

    depsgraph = bpy.context.evaluated_depsgraph_get()
    return np.array([not scene.ray_cast(depsgraph, Vector(origin), Vector(d))[0] for d in directions(count)])


@pytest.mark.parametrize("name", ["closed_room", "closed_room_lamp"])
def test_a_closed_room_lets_no_ray_out(addon, lib, name):
    scene = lib.build_scene(name, SHARED_SCENES, resolution=SIZE)
    for origin in [(0.0, 0.0, 1.5), (2.9, 2.9, 0.1), scene.camera.matrix_world.translation]:
        assert not escaping(scene, tuple(origin)).any()
    lamps = [obj for obj in scene.objects if obj.type == "LIGHT"]
    assert len(lamps) == (1 if name == "closed_room_lamp" else 0)


def test_the_window_room_lets_rays_out_through_its_window_only(addon, lib):
    interior = importlib.import_module("benchmarks.interior_scenes")
    scene = lib.build_scene("window_room", SHARED_SCENES, resolution=SIZE)
    origin = (0.0, 0.0, 1.5)
    out = escaping(scene, origin)
    assert 0 < out.sum() < RAYS // 10
    width, height, sill = interior.WINDOW
    wall_x = interior.ROOM_INSIDE[0] / 2
    for d in directions(RAYS)[out]:
        t = (wall_x - origin[0]) / d[0]  # where the escaping ray crosses the +x wall's plane
        y, z = origin[1] + t * d[1], origin[2] + t * d[2]
        assert d[0] > 0 and abs(y) <= width / 2 + 1e-3 and sill - 1e-3 <= z <= sill + height + 1e-3


def test_wall_floor_stands_a_cube_on_a_floor_open_to_the_sky(addon, lib):
    scene = lib.build_scene("wall_floor", SHARED_SCENES, resolution=SIZE)
    out = escaping(scene, (0.0, -1.01, 1.0))  # just in front of the cube's -y face
    # Half the directions run into the cube; of the other half, those above the horizon see
    # the sky and those below it the floor: about a quarter escape.
    assert 0.18 * RAYS < out.sum() < 0.32 * RAYS


@pytest.mark.skipif(not SHARED_SCENES.is_dir(), reason="third-party scenes folder is absent")
def test_the_cornell_box_is_lit_by_its_emissive_panel_alone(addon, lib):
    scene = lib.build_scene("cornell", SHARED_SCENES, resolution=SIZE)
    assert not [obj for obj in scene.objects if obj.type == "LIGHT"]
    assert scene.world.node_tree.nodes["Background"].inputs["Strength"].default_value == 0.0
    emissive = []
    for material in {slot.material for obj in scene.objects if obj.type == "MESH" for slot in obj.material_slots}:
        node = material.node_tree.nodes["Principled BSDF"]
        strength = node.inputs["Emission Strength"].default_value * max(node.inputs["Emission Color"].default_value[:3])
        if strength > 0.0:
            emissive.append(material.name)
    assert emissive == ["light"]
    assert scene.render.resolution_x == scene.render.resolution_y
