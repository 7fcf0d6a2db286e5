# SPDX-License-Identifier: GPL-3.0-or-later
"""Building blocks of the library's Blender scenes: meshes from flat arrays, boxes,
Principled materials, lamps, Worlds, collections.

Every scene module (scene_library.py, interior_scenes.py) builds with these, so that a
material or a lamp means the same in each and in the core's conventions (a lamp's colour
times power, a sun's angle).
"""
from __future__ import annotations

import bpy
import numpy as np
from mathutils import Vector

def new_collection(scene, name: str, parent=None):
    collection = bpy.data.collections.new(name)
    (parent or scene.collection).children.link(collection)
    return collection


def new_mesh(name: str, positions: np.ndarray, corner_verts: np.ndarray, face_starts: np.ndarray,
              *, smooth: bool, corner_normals: np.ndarray | None = None,
              face_materials: np.ndarray | None = None):
    """A mesh from flat arrays with ``foreach_set`` (no per-element Python).

    ``corner_normals`` become Blender's float "free" custom normals (attribute
    ``custom_normal`` on the face corners): exact, unlike the compressed split normals.
    """
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(positions))
    mesh.vertices.foreach_set("co", np.ascontiguousarray(positions, np.float32).reshape(-1))
    mesh.loops.add(len(corner_verts))
    mesh.loops.foreach_set("vertex_index", np.ascontiguousarray(corner_verts, np.int32))
    mesh.polygons.add(len(face_starts))
    mesh.polygons.foreach_set("loop_start", np.ascontiguousarray(face_starts, np.int32))
    if face_materials is not None:
        mesh.polygons.foreach_set("material_index", np.ascontiguousarray(face_materials, np.int32))
    mesh.update(calc_edges=True)
    if smooth:
        mesh.shade_smooth()
    else:
        mesh.shade_flat()
    if corner_normals is not None:
        attribute = mesh.attributes.new("custom_normal", "FLOAT_VECTOR", "CORNER")
        attribute.data.foreach_set("vector", np.ascontiguousarray(corner_normals, np.float32).reshape(-1))
    return mesh


def principled(name: str, base_color=(0.8, 0.8, 0.8), *, metallic: float = 0.0, roughness: float = 0.5,
                transmission: float = 0.0, ior: float = 1.5, thickness: float = 0.5):
    """A Principled BSDF material: EEVEE, Cycles and Hybrid RT all read the same inputs."""
    material = bpy.data.materials.new(name)  # Blender 5 materials always have a node tree
    bsdf = material.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*base_color[:3], 1.0)
    set_inputs(material, Metallic=metallic, Roughness=roughness, **{"Transmission Weight": transmission},
                IOR=ior)
    material.hybrid_rt.thickness = thickness
    return material


def principled_node(material):
    node = next((n for n in material.node_tree.nodes if n.type == "BSDF_PRINCIPLED"), None)
    if node is None:
        raise RuntimeError(f"material {material.name!r} has no Principled BSDF")
    return node


def set_inputs(material, **values: float) -> None:
    """Set Principled BSDF inputs, unlinking any texture that drove them (a mirror is
    metallic 1, roughness 0 everywhere). Base Color and its texture are left alone."""
    bsdf = principled_node(material)
    links = material.node_tree.links
    for name, value in values.items():
        socket = bsdf.inputs[name]
        for link in list(socket.links):
            links.remove(link)
        socket.default_value = value


def light(scene, collection, name: str, kind: str, color, *, position=(0.0, 0.0, 0.0),
           direction=(0.0, 0.0, -1.0), radius: float = 0.0):
    """A light whose colour x power equals ``color`` and whose size is ``radius`` (the core's
    Lights convention: a sun's angle, a point or spot radius)."""
    color = np.asarray(color, np.float64)
    power = float(color.max())
    light = bpy.data.lights.new(name, kind)
    light.energy = power
    light.color = tuple(color / power) if power > 0 else (1.0, 1.0, 1.0)
    if kind == "SUN":
        light.angle = radius
    else:
        light.shadow_soft_size = radius
    obj = bpy.data.objects.new(name, light)
    obj.location = position
    # A light shines along its -Z axis.
    obj.rotation_mode = "QUATERNION"
    obj.rotation_quaternion = Vector((0.0, 0.0, -1.0)).rotation_difference(Vector(direction).normalized())
    collection.objects.link(obj)
    return obj


def world(scene, color, strength: float) -> None:
    world = bpy.data.worlds.new(f"{scene.name} world")  # with Background and World Output nodes
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (*color[:3], 1.0)
    background.inputs["Strength"].default_value = strength
    world.color = color[:3]
    scene.world = world


def box_mesh(name: str, lo, hi):
    """An axis-aligned box as a closed mesh with flat faces."""
    corners = np.array([[x, y, z] for z in (lo[2], hi[2]) for y in (lo[1], hi[1]) for x in (lo[0], hi[0])],
                       np.float32)
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    return new_mesh(name, corners, np.array(quads, np.int32).reshape(-1), np.arange(0, 24, 4, dtype=np.int32),
                     smooth=False)
