# SPDX-License-Identifier: GPL-3.0-or-later
"""Object Info Random and Color as Cycles gives them (blender_adapter/scene_cache.py
``_random_id``, the object's colour): an object's Random from its name, an instance's from the
depsgraph, through the instance table to the node program, so scattered copies vary as in
Cycles and keep their value across renders."""
from __future__ import annotations

import numpy as np
import pytest

from test_engine import render_exr


def _random_scene(bpy):
    """Three quads side by side under an orthographic top view, each emitting its Object Info
    Random as grey: a plain object, and two instances of a collection through an empty."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    material = bpy.data.materials.new("random")
    material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()
    output = nodes.new("ShaderNodeOutputMaterial")
    emission = nodes.new("ShaderNodeEmission")
    info = nodes.new("ShaderNodeObjectInfo")
    links.new(info.outputs["Random"], emission.inputs["Color"])
    links.new(emission.outputs["Emission"], output.inputs["Surface"])

    def quad(name, x):
        mesh = bpy.data.meshes.new(name)
        mesh.from_pydata([(x - 0.4, -0.4, 0), (x + 0.4, -0.4, 0), (x + 0.4, 0.4, 0), (x - 0.4, 0.4, 0)], [],
                         [(0, 1, 2, 3)])
        mesh.materials.append(material)
        return bpy.data.objects.new(name, mesh)

    scene.collection.objects.link(quad("Plain", -1.0))
    shared = bpy.data.collections.new("Shared")
    shared.objects.link(quad("Copy", 0.0))
    for name, x in (("First", 0.0), ("Second", 1.0)):
        empty = bpy.data.objects.new(name, None)
        empty.instance_type = "COLLECTION"
        empty.instance_collection = shared
        empty.location = (x, 0.0, 0.0)
        scene.collection.objects.link(empty)
    _camera_and_world(bpy, scene)
    return scene


def _quad_values(image) -> np.ndarray:
    """The grey at the centre of each of the three quads (columns 10, 30, 50)."""
    return image[10, [10, 30, 50], 0]


def test_object_info_random_equals_cycles_for_objects_and_instances(addon, tmp_path):
    import bpy

    scene = _random_scene(bpy)
    scene.render.engine = "CYCLES"
    scene.cycles.samples, scene.cycles.device = 1, "CPU"
    cycles = _quad_values(render_exr(bpy, scene, tmp_path / "cycles.exr"))
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.mode = "RASTER"
    ours = _quad_values(render_exr(bpy, scene, tmp_path / "ours.exr"))
    again = _quad_values(render_exr(bpy, scene, tmp_path / "again.exr"))
    assert len(set(np.round(cycles, 4))) == 3  # three different values in the oracle
    np.testing.assert_allclose(ours, cycles, rtol=5e-3)  # the same numbers; the film differs by 0.25 %
    np.testing.assert_array_equal(again, ours)  # stable from render to render


def test_object_info_color_is_each_objects_colour_as_in_cycles(addon, tmp_path):
    import bpy

    scene = _random_scene(bpy)
    tree = bpy.data.materials["random"].node_tree
    info, emission = tree.nodes["Object Info"], tree.nodes["Emission"]
    tree.links.new(info.outputs["Color"], emission.inputs["Color"])
    bpy.data.objects["Plain"].color = (0.9, 0.2, 0.1, 1.0)
    bpy.data.objects["Copy"].color = (0.1, 0.3, 0.8, 1.0)
    bpy.data.objects["First"].color = (0.2, 0.9, 0.3, 1.0)  # its instances show it, as in Cycles
    scene.render.engine = "CYCLES"
    scene.cycles.samples, scene.cycles.device = 1, "CPU"
    cycles = render_exr(bpy, scene, tmp_path / "cycles.exr")[10, [10, 30, 50], :3]
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.mode = "RASTER"
    ours = render_exr(bpy, scene, tmp_path / "ours.exr")[10, [10, 30, 50], :3]
    np.testing.assert_allclose(cycles[0], (0.9, 0.2, 0.1), rtol=1e-2)  # the oracle shows the colours
    np.testing.assert_allclose(ours, cycles, rtol=1e-2, atol=1e-3)


def _emitting_random(bpy):
    """The material of ``_random_scene`` (Object Info Random as grey emission), made anew."""
    material = bpy.data.materials.new("random")
    material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()
    output = nodes.new("ShaderNodeOutputMaterial")
    emission = nodes.new("ShaderNodeEmission")
    info = nodes.new("ShaderNodeObjectInfo")
    links.new(info.outputs["Random"], emission.inputs["Color"])
    links.new(emission.outputs["Emission"], output.inputs["Surface"])
    return material


def _camera_and_world(bpy, scene):
    camera = bpy.data.cameras.new("camera")
    camera.type, camera.ortho_scale = "ORTHO", 3.0
    camera_object = bpy.data.objects.new("camera", camera)
    camera_object.location = (0.0, 0.0, 2.0)
    scene.collection.objects.link(camera_object)
    scene.camera = camera_object
    world = bpy.data.worlds.new("black")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scene.world = world
    scene.render.resolution_x, scene.render.resolution_y = 60, 20
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"


def _quad_object(bpy, scene, material):
    """A quad of 0.8 at the origin, hidden from the render (only its instances show)."""
    mesh = bpy.data.meshes.new("quad")
    mesh.from_pydata([(-0.4, -0.4, 0), (0.4, -0.4, 0), (0.4, 0.4, 0), (-0.4, 0.4, 0)], [], [(0, 1, 2, 3)])
    mesh.materials.append(material)
    quad = bpy.data.objects.new("quad", mesh)
    scene.collection.objects.link(quad)
    quad.location = (0.0, 5.0, 0.0)  # out of view; its instances are placed by their points
    return quad


def _geometry_nodes_scene(bpy):
    """Three instances of the quad on the points of a mesh line (Instance on Points)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    quad = _quad_object(bpy, scene, _emitting_random(bpy))
    tree = bpy.data.node_groups.new("scatter", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    nodes, links = tree.nodes, tree.links
    output = nodes.new("NodeGroupOutput")
    line = nodes.new("GeometryNodeMeshLine")
    line.inputs["Count"].default_value = 3
    line.inputs["Start Location"].default_value = (-1.0, 0.0, 0.0)
    line.inputs["Offset"].default_value = (1.0, 0.0, 0.0)
    info = nodes.new("GeometryNodeObjectInfo")
    info.inputs["Object"].default_value = quad
    info.transform_space = "ORIGINAL"
    scatter = nodes.new("GeometryNodeInstanceOnPoints")
    links.new(line.outputs["Mesh"], scatter.inputs["Points"])
    links.new(info.outputs["Geometry"], scatter.inputs["Instance"])
    links.new(scatter.outputs["Instances"], output.inputs["Geometry"])
    holder = bpy.data.objects.new("scatter", bpy.data.meshes.new("holder"))
    scene.collection.objects.link(holder)
    holder.modifiers.new("scatter", "NODES").node_group = tree
    _camera_and_world(bpy, scene)
    return scene


def _particle_scene(bpy):
    """Three particle instances of the quad, emitted from the three vertices of an emitter
    (no physics: they stay where they were born)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    quad = _quad_object(bpy, scene, _emitting_random(bpy))
    emitter_mesh = bpy.data.meshes.new("emitter")
    emitter_mesh.from_pydata([(-1.0, 0.0, 0.0), (0.0, 0.0, 0.0), (1.0, 0.0, 0.0)], [], [])
    emitter = bpy.data.objects.new("emitter", emitter_mesh)
    scene.collection.objects.link(emitter)
    modifier = emitter.modifiers.new("particles", "PARTICLE_SYSTEM")
    settings = modifier.particle_system.settings
    settings.count = 3
    settings.frame_start, settings.frame_end, settings.lifetime = -2.0, -2.0, 1000.0
    settings.emit_from, settings.use_emit_random = "VERT", False
    settings.physics_type = "NO"
    settings.render_type, settings.instance_object = "OBJECT", quad
    settings.particle_size, settings.use_rotation_instance = 1.0, False
    settings.use_rotations = False
    _camera_and_world(bpy, scene)
    scene.frame_set(1)
    return scene


def _quad_means(image) -> np.ndarray:
    """The mean grey over the middle 5 x 5 pixels of each of the three quads (Cycles' pixels
    scatter by a few per cent at one sample even on a flat emitter: the means of 64 settle
    within 0.1 % of the value)."""
    return np.array([image[8:13, c - 2:c + 3, 0].mean() for c in (10, 30, 50)])


@pytest.mark.parametrize("build", [_geometry_nodes_scene, _particle_scene], ids=["geometry nodes", "particles"])
def test_object_info_random_of_generated_instances_equals_cycles_and_holds_from_frame_to_frame(addon, tmp_path,
                                                                                                build):
    import bpy

    scene = build(bpy)
    scene.render.engine = "CYCLES"
    scene.cycles.samples, scene.cycles.device = 64, "CPU"
    cycles = _quad_means(render_exr(bpy, scene, tmp_path / "cycles.exr"))
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.mode = "RASTER"
    ours = _quad_means(render_exr(bpy, scene, tmp_path / "ours.exr"))
    scene.frame_set(2)
    next_frame = _quad_means(render_exr(bpy, scene, tmp_path / "next.exr"))
    assert len(set(np.round(cycles, 3))) == 3 and cycles.min() > 0.0  # three instances, three values
    np.testing.assert_allclose(ours, cycles, rtol=5e-3)
    np.testing.assert_array_equal(next_frame, ours)  # the same instances keep their values


@pytest.mark.parametrize("build", [_geometry_nodes_scene, _particle_scene], ids=["geometry nodes", "particles"])
def test_object_info_color_of_generated_instances_equals_cycles(addon, tmp_path, build):
    import bpy

    scene = build(bpy)
    tree = bpy.data.materials["random"].node_tree
    tree.links.new(tree.nodes["Object Info"].outputs["Color"], tree.nodes["Emission"].inputs["Color"])
    bpy.data.objects["quad"].color = (0.1, 0.3, 0.8, 1.0)
    instancer = bpy.data.objects["scatter" if "scatter" in bpy.data.objects else "emitter"]
    instancer.color = (0.9, 0.5, 0.2, 1.0)
    scene.render.engine = "CYCLES"
    scene.cycles.samples, scene.cycles.device = 16, "CPU"
    cycles = np.array([render_exr(bpy, scene, tmp_path / "cycles.exr")[8:13, c - 2:c + 3, :3].mean((0, 1))
                       for c in (10, 30, 50)])
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.mode = "RASTER"
    image = render_exr(bpy, scene, tmp_path / "ours.exr")
    ours = np.array([image[8:13, c - 2:c + 3, :3].mean((0, 1)) for c in (10, 30, 50)])
    assert cycles.max() > 0.15  # the oracle shows a colour
    np.testing.assert_allclose(ours, cycles, rtol=5e-3, atol=1e-3)
