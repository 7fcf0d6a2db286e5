# SPDX-License-Identifier: GPL-3.0-or-later
"""Interiors: the scenes that show whether light is carried indoors as Cycles carries it.

Outdoors almost every surface sees the sky, and an estimate of the World's light that ignores
distant occluders looks right. Indoors it does not: walls hide the sky, and most of what lights
a room has bounced off another surface first. Each scene here isolates one part of that:

* ``closed_room`` -- six walls and no opening under a white World of strength 1, no lamps:
  Cycles renders it black. Anything brighter is World light leaking through the walls.
* ``closed_room_lamp`` -- the same room lit by one point lamp inside: the walls the lamp does
  not see directly are lit by bounced light only.
* ``window_room`` -- a room with one window, the sun and the sky outside: a sunlit patch on
  the floor, and the rest of the room lit by what it bounces.
* ``wall_floor`` -- a grey cube on a grey floor under a white World: the cube's top face sees
  the sky alone; its vertical faces see the floor below the horizon, which bounces light up.
* ``cornell`` -- the Cornell box (the public-domain OBJ of McGuire and Cardenas), lit only by
  its emissive ceiling panel: emissive meshes as lights.

All are static and small, so Cycles converges on them in seconds; ``scripts/measure_light.py``
renders each with Cycles, EEVEE and Hybrid RT side by side.
"""
from __future__ import annotations

import math
from pathlib import Path

import bpy
import numpy as np
from mathutils import Matrix

from hybrid_engine.scene.camera import look_at

from .scene_parts import box_mesh, light, new_collection, principled, world

INTERIOR_SCENES = ("closed_room", "closed_room_lamp", "window_room", "wall_floor", "cornell")
CORNELL_OBJ = "cornell/CornellBox-Original.obj"
ASSETS = {name: () for name in INTERIOR_SCENES} | {"cornell": (CORNELL_OBJ,)}
CREDITS = {name: "procedural (benchmarks/interior_scenes.py)" for name in INTERIOR_SCENES} | {
    "cornell": "Cornell Box (original): Morgan McGuire and Guedis Cardenas, Williams College (public domain)"}

ROOM_INSIDE = (6.0, 6.0, 3.0)  # inner width (x), depth (y), height (z) of the closed rooms
WALL_M = 0.2  # wall, floor and ceiling thickness
WALL_ALBEDO = (0.8, 0.8, 0.8)
LAMP_POWER_W = 300.0  # the closed room's one point lamp, in Blender's watts
WINDOW = (1.6, 1.4, 0.9)  # window width, height and sill height, in the +x wall
ROOM_SUN = (4.0, 3.9, 3.6)  # the window room's sun: colour times strength (W/m^2)
ROOM_SUN_DIRECTION = (-0.75, 0.25, -0.6)  # shining in through the +x wall's window
SKY_BLUE = (0.45, 0.6, 0.9)
GREY = (0.5, 0.5, 0.5)
CORNELL_LENS_MM = 49.5  # a horizontal field of view of about 40 degrees, as the original's camera


def _static_camera(scene, collection, eye, target, *, lens: float, clip_end: float = 100.0):
    data = bpy.data.cameras.new("Camera")
    data.lens, data.clip_start, data.clip_end = lens, 0.05, clip_end
    camera = bpy.data.objects.new("Camera", data)
    camera.matrix_world = Matrix(look_at(eye, target).tolist())
    collection.objects.link(camera)
    scene.camera = camera
    return camera


def _boxes(collection, parts: dict[str, tuple], material) -> None:
    for name, (lo, hi) in parts.items():
        obj = bpy.data.objects.new(name, box_mesh(name, lo, hi))
        obj.data.materials.append(material)
        collection.objects.link(obj)


def _shell(window: bool) -> dict[str, tuple]:
    """The room's six walls as slabs meeting at the corners (no gap for light to pass); with
    ``window``, the +x wall is four slabs around an opening."""
    w, d, h = ROOM_INSIDE[0] / 2, ROOM_INSIDE[1] / 2, ROOM_INSIDE[2]
    t = WALL_M
    parts = {
        "Floor": ((-w - t, -d - t, -t), (w + t, d + t, 0.0)),
        "Ceiling": ((-w - t, -d - t, h), (w + t, d + t, h + t)),
        "Wall -x": ((-w - t, -d - t, 0.0), (-w, d + t, h)),
        "Wall -y": ((-w, -d - t, 0.0), (w, -d, h)),
        "Wall +y": ((-w, d, 0.0), (w, d + t, h)),
    }
    if not window:
        parts["Wall +x"] = ((w, -d - t, 0.0), (w + t, d + t, h))
        return parts
    ww, wh, sill = WINDOW
    parts.update({
        "Wall +x left": ((w, -d - t, 0.0), (w + t, -ww / 2, h)),
        "Wall +x right": ((w, ww / 2, 0.0), (w + t, d + t, h)),
        "Wall +x sill": ((w, -ww / 2, 0.0), (w + t, ww / 2, sill)),
        "Wall +x lintel": ((w, -ww / 2, sill + wh), (w + t, ww / 2, h)),
    })
    return parts


def _room(scene, window: bool, lamp: bool) -> None:
    collection = new_collection(scene, "Room")
    _boxes(collection, _shell(window), principled("White plaster", WALL_ALBEDO, roughness=1.0))
    box = principled("Grey box", GREY, roughness=0.8)
    _boxes(collection, {"Box": ((-1.6, 0.6, 0.0), (-0.4, 1.8, 1.2))}, box)
    if lamp:
        light(scene, collection, "Lamp", "POINT", (LAMP_POWER_W,) * 3, position=(1.0, -0.5, 2.2), radius=0.1)
    if window:
        sun = light(scene, collection, "Sun", "SUN", ROOM_SUN, direction=ROOM_SUN_DIRECTION,
                    radius=math.radians(1.0))
        sun.data.angle = math.radians(1.0)
        world(scene, SKY_BLUE, 1.0)
    else:
        world(scene, (1.0, 1.0, 1.0), 1.0)
    _static_camera(scene, collection, (-2.6, -2.6, 1.6), (1.0, 1.0, 0.9), lens=18.0)


def build_closed_room(scene, assets: Path | None) -> None:
    """Six walls, no opening, a white World outside, no lamps: black in Cycles."""
    _room(scene, window=False, lamp=False)
    scene["hybrid_rt_label"] = "closed room: a white World outside, no lamps (black in Cycles)"


def build_closed_room_lamp(scene, assets: Path | None) -> None:
    """The closed room lit by one point lamp inside."""
    _room(scene, window=False, lamp=True)
    scene["hybrid_rt_label"] = "closed room lit by one lamp inside"


def build_window_room(scene, assets: Path | None) -> None:
    """A room with one window, the sun and a blue sky outside."""
    _room(scene, window=True, lamp=False)
    scene["hybrid_rt_label"] = "room lit by the sun and sky through one window"


def build_wall_floor(scene, assets: Path | None) -> None:
    """A grey cube on a grey floor under a white World."""
    collection = new_collection(scene, "Wall and floor")
    grey = principled("Grey", GREY, roughness=1.0)
    _boxes(collection, {"Floor": ((-20.0, -20.0, -0.2), (20.0, 20.0, 0.0)), "Cube": ((-1.0, -1.0, 0.0), (1.0, 1.0, 2.0))},
           grey)
    world(scene, (1.0, 1.0, 1.0), 1.0)
    _static_camera(scene, collection, (2.2, -5.5, 3.4), (0.0, 0.0, 0.9), lens=35.0)
    scene["hybrid_rt_label"] = "grey cube on a grey floor under a white World"


def build_cornell(scene, assets: Path | None) -> None:
    """The original Cornell box, lit by its emissive ceiling panel alone (black World)."""
    collection = new_collection(scene, "Cornell box")
    view_layer = scene.view_layers[0]
    for child in view_layer.layer_collection.children:
        if child.collection == collection:
            view_layer.active_layer_collection = child
    result = bpy.ops.wm.obj_import(filepath=str(assets / CORNELL_OBJ))
    if "FINISHED" not in result:
        raise RuntimeError(f"importing {CORNELL_OBJ} failed ({result})")
    world(scene, (0.0, 0.0, 0.0), 0.0)
    _static_camera(scene, collection, (0.0, -3.9, 1.0), (0.0, 0.0, 1.0), lens=CORNELL_LENS_MM)
    scene.render.resolution_y = scene.render.resolution_x
    scene["hybrid_rt_label"] = "Cornell box lit by its emissive panel alone"


BUILDERS = {"closed_room": build_closed_room, "closed_room_lamp": build_closed_room_lamp,
            "window_room": build_window_room, "wall_floor": build_wall_floor, "cornell": build_cornell}


def luminance(image: np.ndarray) -> np.ndarray:
    """Rec. 709 luminance of linear RGB(A) pixels, as the issue's figures are measured."""
    return image[..., 0] * 0.2126 + image[..., 1] * 0.7152 + image[..., 2] * 0.0722
