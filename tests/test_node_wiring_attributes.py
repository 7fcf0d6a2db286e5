# SPDX-License-Identifier: GPL-3.0-or-later
"""Color Attribute and Attribute nodes end to end: meshes with vertex colours and named
attributes built in Blender, read by the adapter (blender_adapter/export/meshes.py, only the
names the materials read), carried per corner to the GPU and interpolated where the program
runs (``bpy.ops.render.render``), against Cycles rendering the same scene in the same
process, with the bar of test_node_wiring_colour.py (mean <= 1 %, p99 <= 2 % per plane).

Each case is a plane of 4 x 4 quads in a grid seen from above; its attribute varies over
the plane (a point value per vertex, a corner value that jumps between faces, a face value
per quad), so interpolation, domains and the sRGB conversion of byte colours all show."""
from __future__ import annotations

import math

import numpy as np

from normal_scenes import mirror_material
from test_node_wiring_colour import MEAN_BAR, P99_BAR, cells, difference, render_both

QUADS = 4  # per side of a plane


def _plane_mesh(bpy, name: str):
    """A plane of QUADS x QUADS quads over [-1, 1]^2."""
    n = QUADS + 1
    verts = [(-1 + 2 * i / QUADS, -1 + 2 * j / QUADS, 0.0) for j in range(n) for i in range(n)]
    faces = [(j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i)
             for j in range(QUADS) for i in range(QUADS)]
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    return mesh


def _point_values(mesh, width: int) -> np.ndarray:
    p = np.array([v.co[:] for v in mesh.vertices])
    x, y = (p[:, 0] + 1) / 2, (p[:, 1] + 1) / 2
    cols = [0.1 + 0.8 * x, 0.15 + 0.7 * y, 0.9 - 0.6 * x * y, 0.3 + 0.6 * y]
    return np.stack(cols[:width], -1)


def _corner_values(mesh, width: int) -> np.ndarray:
    """A point value plus a per-face offset: the same vertex differs between its faces."""
    loops = np.array([loop.vertex_index for loop in mesh.loops])
    faces = np.repeat(np.arange(len(mesh.polygons)), [len(p.vertices) for p in mesh.polygons])
    offset = ((faces * 7) % 5) / 5.0 * 0.3
    return np.clip(_point_values(mesh, width)[loops] * 0.7 + offset[:, None], 0.0, 1.0)


def _face_values(mesh, width: int) -> np.ndarray:
    rng = np.random.default_rng(3)
    return rng.uniform(0.05, 0.95, (len(mesh.polygons), width))


VALUES = {"POINT": _point_values, "CORNER": _corner_values, "FACE": _face_values}
WIDTHS = {"BYTE_COLOR": 4, "FLOAT_COLOR": 4, "FLOAT_VECTOR": 3, "FLOAT": 1}


def _add_attribute(mesh, name: str, data_type: str, domain: str, default: bool = False) -> None:
    values = VALUES[domain](mesh, WIDTHS[data_type])
    if data_type in ("BYTE_COLOR", "FLOAT_COLOR"):
        attribute = mesh.color_attributes.new(name, data_type, domain)
        attribute.data.foreach_set("color", values.astype(np.float32).reshape(-1))
        if default:
            mesh.color_attributes.render_color_index = list(mesh.color_attributes).index(attribute)
    else:
        attribute = mesh.attributes.new(name, data_type, domain)
        attribute.data.foreach_set("vector" if data_type == "FLOAT_VECTOR" else "value",
                                   values.astype(np.float32).reshape(-1))


def _color_attribute(layer: str, output: str = "Color"):
    def build(nodes, links):
        node = nodes.new("ShaderNodeVertexColor")
        node.layer_name = layer
        return node.outputs[output]
    return build


def _attribute(name: str, output: str, kind: str = "GEOMETRY"):
    def build(nodes, links):
        node = nodes.new("ShaderNodeAttribute")
        node.attribute_type, node.attribute_name = kind, name
        return node.outputs[output]
    return build


# name: (attributes on the mesh [(name, data type, domain, render default)], the node)
CASES = {
    "byte colour, corner, render default": ([("Paint", "BYTE_COLOR", "CORNER", True), ("Other", "BYTE_COLOR",
                                                                                      "POINT", False)],
                                            _color_attribute("")),
    "byte colour, point": ([("Paint", "BYTE_COLOR", "POINT", False)], _color_attribute("Paint")),
    "byte colour alpha, corner": ([("Paint", "BYTE_COLOR", "CORNER", False)], _color_attribute("Paint", "Alpha")),
    "float colour, corner": ([("Linear", "FLOAT_COLOR", "CORNER", False)], _color_attribute("Linear")),
    "float colour, point": ([("Linear", "FLOAT_COLOR", "POINT", False)], _attribute("Linear", "Color")),
    "float, point, Fac": ([("mask", "FLOAT", "POINT", False)], _attribute("mask", "Fac")),
    "float, face": ([("mask", "FLOAT", "FACE", False)], _attribute("mask", "Color")),
    "vector, corner": ([("flow", "FLOAT_VECTOR", "CORNER", False)], _attribute("flow", "Vector")),
    "vector, point, Fac": ([("flow", "FLOAT_VECTOR", "POINT", False)], _attribute("flow", "Fac")),
    "object property": ([], _attribute("tint", "Color", "OBJECT")),
}
CELL = 2.4


def attribute_scene(bpy, cases: dict, pixels_per_cell: int = 32):
    """One plane per case in a grid, each with its own mesh and emission material."""
    from test_node_wiring_colour import grid_scene

    columns = max(1, math.ceil(math.sqrt(len(cases))))
    scene, _ = grid_scene(bpy, {}, pixels_per_cell)
    for k, (name, (attributes, build)) in enumerate(cases.items()):
        mesh = _plane_mesh(bpy, name)
        for attribute in attributes:
            _add_attribute(mesh, *attribute)
        material = bpy.data.materials.new(name)
        material.use_nodes = True
        nodes, links = material.node_tree.nodes, material.node_tree.links
        nodes.clear()
        output = nodes.new("ShaderNodeOutputMaterial")
        emission = nodes.new("ShaderNodeEmission")
        links.new(build(nodes, links), emission.inputs["Color"])
        links.new(emission.outputs["Emission"], output.inputs["Surface"])
        mesh.materials.append(material)
        plane = bpy.data.objects.new(name, mesh)
        plane["tint"] = (0.8, 0.35, 0.1)
        plane.location = ((k % columns + 0.5) * CELL, (k // columns + 0.5) * CELL, 0.0)
        plane.scale = (0.45 * CELL,) * 3
        scene.collection.objects.link(plane)
    camera = scene.camera
    camera.data.ortho_scale = columns * CELL
    camera.location = (columns * CELL / 2, columns * CELL / 2, 2.0)
    scene.render.resolution_x = scene.render.resolution_y = columns * pixels_per_cell
    return scene


def test_vertex_colours_and_named_attributes_match_cycles_through_blenders_render_path(addon, tmp_path):
    import bpy
    scene = attribute_scene(bpy, CASES)
    with addon.blender_adapter.messages.collecting() as told:
        images = render_both(bpy, scene, tmp_path)
    assert not [t for t in told if "not evaluated yet" in t or "not supported" in t], told
    names = list(CASES)
    ours, cycles = cells(images["HYBRID_RT"], len(names)), cells(images["CYCLES"], len(names))
    assert all(np.ptp(c) > 0.05 for name, c in zip(names, cycles) if name != "object property")
    scores = {name: difference(o, c) for name, o, c in zip(names, ours, cycles)}
    failing = {n: s for n, s in scores.items() if not (s[0] <= MEAN_BAR and s[1] <= P99_BAR)}
    assert not failing, f"against Cycles (mean, p99): {failing}"


def test_a_vertex_colour_seen_in_a_hybrid_mirror_matches_its_primary_view(addon, tmp_path):
    """HYBRID mode: the coloured planes above a perfect mirror, seen from between the two (the
    mirror's rays hit them in the BVH) and straight from above: the orthographic views look
    along the same vertical lines, so the two images agree pixel for pixel."""
    import bpy
    from test_engine import render_exr

    cases = {name: CASES[name] for name in ("byte colour, corner, render default", "float, point, Fac",
                                            "vector, corner", "float colour, corner")}
    scene = attribute_scene(bpy, cases, pixels_per_cell=40)
    floor = _plane_mesh(bpy, "floor")
    floor.materials.append(mirror_material(bpy))
    floor_object = bpy.data.objects.new("floor", floor)
    floor_object.location, floor_object.scale = (CELL, CELL, -1.0), (4 * CELL,) * 3
    scene.collection.objects.link(floor_object)
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.mode = "HYBRID"
    scene.hybrid_rt.near_size = 8.0
    scene.hybrid_rt.render_samples = 1
    camera = scene.camera
    primary = render_exr(bpy, scene, tmp_path / "primary.exr")[..., :3]
    camera.location = (camera.location.x, camera.location.y, -0.5)  # between the planes and the mirror
    mirrored = render_exr(bpy, scene, tmp_path / "mirror.exr")[..., :3]
    ours, seen = cells(mirrored, len(cases)), cells(primary, len(cases))
    assert all(np.ptp(c) > 0.05 for c in seen)
    scores = {name: difference(o, c) for name, o, c in zip(cases, ours, seen)}
    failing = {n: s for n, s in scores.items() if not (s[0] <= MEAN_BAR and s[1] <= P99_BAR)}
    assert not failing, f"mirror against primary (mean, p99): {failing}"


def test_a_mesh_is_read_with_the_attributes_its_materials_read_and_no_other(addon):
    """The adapter reads only requested names: a scene whose materials read none carries none
    (no cost), and adding a Color Attribute node to a material reads the mesh's colour."""
    import bpy
    from test_node_wiring_colour import grid_scene

    scene, materials = grid_scene(bpy, {"plain": lambda nodes, links, coords: coords})
    plane = bpy.data.objects["plain"]
    _add_attribute(plane.data, "Paint", "BYTE_COLOR", "CORNER", True)
    cache = addon.blender_adapter.scene_cache.SceneCache()
    cache.sync(bpy.context.evaluated_depsgraph_get(), full=True)
    mesh = cache.scene_data.geometry.instances.meshes[0]
    assert mesh.attributes is None
    tree = materials["plain"].node_tree
    colour = tree.nodes.new("ShaderNodeVertexColor")
    tree.links.new(colour.outputs["Color"], tree.nodes["Emission"].inputs["Color"])
    depsgraph = bpy.context.evaluated_depsgraph_get()
    depsgraph.update()
    changes = addon.blender_adapter.scene_cache.Changes()
    changes.materials.add(materials["plain"].original.as_pointer())
    cache.sync(depsgraph, changes)
    mesh = cache.scene_data.geometry.instances.meshes[0]
    assert list(mesh.attributes) == [""] and mesh.attributes[""].shape == (3 * mesh.triangle_count, 4)


def test_a_painted_colour_is_read_again_with_the_mesh_kept_as_a_deformed_version(addon):
    """Vertex painting arrives as a geometry update of the mesh: the re-read keeps the
    topology (same mesh id, next version, so only its values are sent) and reads the colour."""
    import bpy
    from test_node_wiring_colour import grid_scene

    scene_cache = addon.blender_adapter.scene_cache
    scene, materials = grid_scene(bpy, {"painted": lambda nodes, links, coords: coords})
    plane = bpy.data.objects["painted"]
    _add_attribute(plane.data, "Paint", "FLOAT_COLOR", "POINT", True)
    tree = materials["painted"].node_tree
    colour = tree.nodes.new("ShaderNodeVertexColor")
    tree.links.new(colour.outputs["Color"], tree.nodes["Emission"].inputs["Color"])
    cache = scene_cache.SceneCache()
    cache.sync(bpy.context.evaluated_depsgraph_get(), full=True)
    before = cache.scene_data.geometry.instances.meshes[0]
    plane.data.color_attributes["Paint"].data.foreach_set("color", np.tile(np.float32([0.2, 0.4, 0.6, 1.0]), 4))
    plane.data.update()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    depsgraph.update()
    changes = scene_cache.Changes(only_moves=False, cameras_only=False)
    changes.geometry.add(plane.original.as_pointer())
    changes.meshes.add(plane.data.original.as_pointer())
    changes.touched |= changes.geometry | changes.meshes
    cache.sync(depsgraph, changes)
    after = cache.scene_data.geometry.instances.meshes[0]
    assert after.mesh_id == before.mesh_id and after.version == before.version + 1
    np.testing.assert_allclose(after.attributes[""], np.tile([0.2, 0.4, 0.6, 1.0], (3 * after.triangle_count, 1)),
                               atol=1e-6)
    assert not np.allclose(before.attributes[""], after.attributes[""])


def test_instancer_and_object_attributes_of_collection_instances_match_cycles(addon, tmp_path):
    """Three quads: a plain object, and two instances of a collection's quad through empties,
    one of which has the property: Instancer looks at the empty first, then the object; Object
    at the object, then its mesh."""
    import bpy
    from test_engine import render_exr
    from test_object_random import _random_scene

    for kind in ("INSTANCER", "OBJECT"):
        scene = _random_scene(bpy)
        tree = bpy.data.materials["random"].node_tree
        node = tree.nodes.new("ShaderNodeAttribute")
        node.attribute_type, node.attribute_name = kind, "tint"
        tree.links.new(node.outputs["Color"], tree.nodes["Emission"].inputs["Color"])
        bpy.data.objects["Plain"]["tint"] = (0.9, 0.2, 0.1)
        bpy.data.objects["Copy"].data["tint"] = (0.1, 0.3, 0.8)  # on the mesh
        bpy.data.objects["First"]["tint"] = (0.2, 0.9, 0.3)
        scene.render.engine = "CYCLES"
        scene.cycles.samples, scene.cycles.device = 16, "CPU"
        cycles = render_exr(bpy, scene, tmp_path / "cycles.exr")[8:13, :, :3]
        scene.render.engine = "HYBRID_RT"
        scene.hybrid_rt.mode = "RASTER"
        ours = render_exr(bpy, scene, tmp_path / "ours.exr")[8:13, :, :3]
        means = lambda image: np.array([image[:, c - 2:c + 3].mean((0, 1)) for c in (10, 30, 50)])  # noqa: E731
        assert len({tuple(np.round(v, 2)) for v in means(cycles)}) == (3 if kind == "INSTANCER" else 2), kind
        np.testing.assert_allclose(means(ours), means(cycles), rtol=5e-3, atol=2e-3, err_msg=kind)


def test_a_view_layer_attribute_is_named_to_the_artist(addon):
    import bpy
    from test_node_wiring_colour import grid_scene

    def view_layer(nodes, links, coords):
        node = nodes.new("ShaderNodeAttribute")
        node.attribute_type, node.attribute_name = "VIEW_LAYER", "tint"
        return node.outputs["Color"]

    grid_scene(bpy, {"layered": view_layer})
    with addon.blender_adapter.messages.collecting() as told:
        addon.blender_adapter.scene_cache.extract_scene(bpy.context.evaluated_depsgraph_get())
    assert any("View Layer attributes are not evaluated" in t for t in told), told
