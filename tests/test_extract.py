# SPDX-License-Identifier: GPL-3.0-or-later
"""The exporter (blender_adapter/scene_cache.py over blender_adapter/export/) against hand-computed geometry.

Every expected value is computed here from the inputs the test chose (vertex lists and
matrices in numpy), not read back through the code under test. Blender's own
``loop_triangles`` is the oracle for the triangulation shortcut.
"""
from __future__ import annotations

import math
import time

import bpy
import numpy as np
import pytest
from mathutils import Matrix, Vector

GEOMETRY_TOLERANCE = 1e-5  # float32 world transforms of coordinates of order 10
NORMAL_TOLERANCE = 1e-5  # unit vectors in float32
CUSTOM_NORMAL_TOLERANCE = 1e-4  # Blender stores custom normals compressed (2 x 16-bit angles)
EXTRACT_BUDGET_MS = 150.0  # design target for one million triangles
BENCH_REPEATS = 5  # best of several runs: the machine is shared


# ---------------------------------------------------------------------------------------
# helpers
def clear_scene() -> None:
    for collection in (bpy.data.objects, bpy.data.meshes, bpy.data.materials, bpy.data.lights,
                       bpy.data.cameras, bpy.data.curves):
        for item in list(collection):
            collection.remove(item)


def mesh_object(name: str, verts, faces, matrix=None, link=True):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(v) for v in verts], [], [tuple(f) for f in faces])
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    if matrix is not None:
        obj.matrix_world = Matrix(np.asarray(matrix).tolist())
    if link:
        bpy.context.scene.collection.objects.link(obj)
    return obj


def extract(addon):
    depsgraph = bpy.context.evaluated_depsgraph_get()
    depsgraph.update()
    return addon.blender_adapter.scene_cache.extract_scene(depsgraph)


def transform(matrix, points):
    points = np.asarray(points, np.float64)
    return points @ np.asarray(matrix)[:3, :3].T + np.asarray(matrix)[:3, 3]


def triangles_of(verts, faces, matrix=np.eye(4)):
    """World triangles of a mesh given as triangles only."""
    world = transform(matrix, verts)
    return world[np.asarray(faces)]


def sort_triangles(triangles, any_corner_order=False):
    """Triangles in a canonical order (the order of objects is the depsgraph's business);
    with ``any_corner_order`` the corners within each triangle are sorted too (modifiers
    such as Mirror reverse a face's corner order)."""
    t = np.round(np.asarray(triangles, np.float64).reshape(-1, 3, 3), 4)
    if any_corner_order:
        t = np.stack([tri[np.lexsort(tri.T[::-1])] for tri in t])
    t = t.reshape(-1, 9)
    return t[np.lexsort(t.T[::-1])]


def assert_same_triangles(got, expected, any_corner_order=False):
    assert got.shape[0] == len(expected)
    np.testing.assert_allclose(sort_triangles(got, any_corner_order), sort_triangles(expected, any_corner_order),
                               atol=GEOMETRY_TOLERANCE)


TETRA_VERTS = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
TETRA_FACES = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]  # outward winding


def trs(location=(0, 0, 0), rotation=(0, 0, 0), scale=(1, 1, 1)) -> np.ndarray:
    m = Matrix.LocRotScale(Vector(location), __import__("mathutils").Euler(rotation), Vector(scale))
    return np.array(m)


# ---------------------------------------------------------------------------------------
# geometry
def test_transformed_mesh_matches_hand_computed_triangles_and_normals(addon):
    clear_scene()
    matrix = trs((1, 2, 3), (0.3, -0.5, 1.1), (2.0, 0.5, 1.5))
    mesh_object("tetra", TETRA_VERTS, TETRA_FACES, matrix)
    geometry = extract(addon).geometry
    expected = triangles_of(TETRA_VERTS, TETRA_FACES, matrix)
    np.testing.assert_allclose(geometry.triangles, expected, atol=GEOMETRY_TOLERANCE)
    # Flat faces: world normal = normalised inverse-transpose of the local face normal,
    # equal to the normalised cross product of the transformed edges.
    face_normals = np.cross(expected[:, 1] - expected[:, 0], expected[:, 2] - expected[:, 0])
    face_normals /= np.linalg.norm(face_normals, axis=1, keepdims=True)
    np.testing.assert_allclose(geometry.normals, np.repeat(face_normals[:, None], 3, 1), atol=NORMAL_TOLERANCE)
    np.testing.assert_array_equal(geometry.object_ranges, [[0, 4]])
    # Bounds: the mesh's object-space box, its corners transformed (what lets a moved
    # object cost eight points): it holds every vertex.
    local = np.array(TETRA_VERTS, np.float64)
    box = np.array([[(local.min(0), local.max(0))[(i >> a) & 1][a] for a in range(3)] for i in range(8)])
    world_box = box @ matrix[:3, :3].T + matrix[:3, 3]
    np.testing.assert_allclose(geometry.object_bounds[0], [world_box.min(0), world_box.max(0)], atol=GEOMETRY_TOLERANCE)
    assert (expected.reshape(-1, 3) >= geometry.object_bounds[0, 0] - 1e-6).all()
    assert (expected.reshape(-1, 3) <= geometry.object_bounds[0, 1] + 1e-6).all()
    assert geometry.object_names == ["tetra"]


def test_negative_scale_keeps_winding_consistent_with_outward_normals(addon):
    clear_scene()
    matrix = trs((0, 0, 0), (0, 0, 0.4), (-1.0, 2.0, 1.0))
    mesh_object("mirrored", TETRA_VERTS, TETRA_FACES, matrix)
    geometry = extract(addon).geometry
    t = geometry.triangles.astype(np.float64)
    winding = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    centroid = transform(matrix, np.mean(TETRA_VERTS, axis=0))
    outward = t.mean(axis=1) - centroid
    # The shading normals point out of the solid, and the winding agrees with them.
    assert (np.einsum("ij,ij->i", geometry.normals[:, 0], outward) > 0).all()
    assert (np.einsum("ij,ij->i", winding, geometry.normals[:, 0]) > 0).all()
    # Same corners as the hand-transformed faces, with corners 1 and 2 swapped.
    expected = triangles_of(TETRA_VERTS, TETRA_FACES, matrix)[:, [0, 2, 1]]
    np.testing.assert_allclose(t, expected, atol=GEOMETRY_TOLERANCE)


def test_array_and_mirror_modifiers_are_applied(addon):
    clear_scene()
    verts = [(1, 0, 0), (2, 0, 0), (1, 1, 0)]
    obj = mesh_object("tri", verts, [(0, 1, 2)])
    array = obj.modifiers.new("array", "ARRAY")
    array.count = 3
    array.use_relative_offset = False
    array.use_constant_offset = True
    array.constant_offset_displace = (0, 0, 2)
    mirror = obj.modifiers.new("mirror", "MIRROR")  # across local X, after the array
    mirror.use_axis = (True, False, False)
    mirror.use_mirror_merge = False
    geometry = extract(addon).geometry
    expected = []
    for k in range(3):
        tri = np.array(verts, float) + (0, 0, 2 * k)
        expected += [tri, tri * (-1, 1, 1)]
    assert_same_triangles(geometry.triangles, np.array(expected), any_corner_order=True)
    assert len(obj.data.polygons) == 1  # the user's mesh is untouched


def test_shape_keys_are_applied(addon):
    clear_scene()
    obj = mesh_object("keyed", TETRA_VERTS, TETRA_FACES)
    obj.shape_key_add(name="Basis")
    key = obj.shape_key_add(name="Up")
    key.data[3].co = (0, 0, 3)
    key.value = 0.5
    geometry = extract(addon).geometry
    moved = np.array(TETRA_VERTS, float)
    moved[3] = (0, 0, 2)  # halfway from z = 1 to z = 3
    assert_same_triangles(geometry.triangles, moved[np.array(TETRA_FACES)])


def test_collection_instances_are_placed_by_the_instancer_and_read_once(addon, monkeypatch):
    clear_scene()
    meshes = addon.blender_adapter.export.meshes
    source = bpy.data.collections.new("source")
    local = trs((0, 0, 1), (0, 0, 0), (1, 1, 1))
    obj = mesh_object("part", TETRA_VERTS, TETRA_FACES, local, link=False)
    source.objects.link(obj)
    placements = [trs((5, 0, 0)), trs((0, 7, 0), (0, 0, math.pi / 2))]
    for i, placement in enumerate(placements):
        empty = bpy.data.objects.new(f"instancer{i}", None)
        empty.instance_type = "COLLECTION"
        empty.instance_collection = source
        empty.matrix_world = Matrix(placement.tolist())
        bpy.context.scene.collection.objects.link(empty)
    reads = []
    real_read = meshes.read_mesh
    monkeypatch.setattr(meshes, "read_mesh", lambda mesh, *rest: reads.append(mesh.name) or real_read(mesh, *rest))
    geometry = extract(addon).geometry
    expected = np.concatenate([triangles_of(TETRA_VERTS, TETRA_FACES, p @ local) for p in placements])
    assert_same_triangles(geometry.triangles, expected)
    assert len(geometry.object_ranges) == 2
    assert len(reads) == 1, f"instanced mesh read {len(reads)} times"


def test_geometry_nodes_instances_are_extracted(addon):
    clear_scene()
    tree = bpy.data.node_groups.new("points_of_cubes", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    nodes, links = tree.nodes, tree.links
    output = nodes.new("NodeGroupOutput")
    line = nodes.new("GeometryNodeMeshLine")
    line.inputs["Count"].default_value = 3
    line.inputs["Offset"].default_value = (2.0, 0.0, 0.0)
    cube = nodes.new("GeometryNodeMeshCube")
    cube.inputs["Size"].default_value = (1.0, 1.0, 1.0)
    on_points = nodes.new("GeometryNodeInstanceOnPoints")
    links.new(line.outputs["Mesh"], on_points.inputs["Points"])
    links.new(cube.outputs["Mesh"], on_points.inputs["Instance"])
    links.new(on_points.outputs["Instances"], output.inputs[0])
    host_matrix = trs((0, 0, 10))
    host = mesh_object("host", [(0, 0, 0)], [], host_matrix)
    host.modifiers.new("nodes", "NODES").node_group = tree
    geometry = extract(addon).geometry
    assert geometry.triangle_count == 3 * 12
    corners = geometry.triangles.reshape(-1, 3)
    for k in range(3):  # each unit cube centred on a point of the line, lifted by the host
        in_cube = np.all(np.abs(corners - (2.0 * k, 0, 10)) <= 0.5 + GEOMETRY_TOLERANCE, axis=1)
        assert in_cube.sum() == 12 * 3
    np.testing.assert_allclose(geometry.object_bounds[:, 0].min(0), (-0.5, -0.5, 9.5), atol=GEOMETRY_TOLERANCE)
    np.testing.assert_allclose(geometry.object_bounds[:, 1].max(0), (4.5, 0.5, 10.5), atol=GEOMETRY_TOLERANCE)


def test_custom_split_normals_are_transformed_to_world_space(addon):
    clear_scene()
    matrix = trs((0, 0, 0), (0.2, 0.0, 0.7), (1.0, 3.0, 1.0))
    obj = mesh_object("custom", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [(0, 1, 2)], matrix)
    custom = np.array([(0.0, 0.6, 0.8), (0.6, 0.0, 0.8), (0.0, 0.0, 1.0)])
    obj.data.normals_split_custom_set([tuple(n) for n in custom])
    geometry = extract(addon).geometry
    normal_matrix = np.linalg.inv(matrix[:3, :3]).T
    expected = custom @ normal_matrix.T
    expected /= np.linalg.norm(expected, axis=1, keepdims=True)
    np.testing.assert_allclose(geometry.normals[0], expected, atol=CUSTOM_NORMAL_TOLERANCE)


def test_smooth_normals_are_vertex_normals(addon):
    clear_scene()
    obj = mesh_object("smooth", TETRA_VERTS, TETRA_FACES)
    obj.data.shade_smooth()
    geometry = extract(addon).geometry
    # A smooth vertex normal is the same at every corner that shares the vertex.
    by_vertex = {}
    for tri, normals in zip(geometry.triangles.reshape(-1, 3), geometry.normals.reshape(-1, 3)):
        by_vertex.setdefault(tuple(np.round(tri, 5)), []).append(normals)
    assert len(by_vertex) == 4
    for normals in by_vertex.values():
        np.testing.assert_allclose(normals, np.broadcast_to(normals[0], np.shape(normals)), atol=NORMAL_TOLERANCE)
    np.testing.assert_allclose(np.linalg.norm(geometry.normals, axis=2), 1.0, atol=NORMAL_TOLERANCE)


def test_material_slots_map_to_the_global_table_with_fallback_zero(addon):
    clear_scene()
    red, blue, green = (bpy.data.materials.new(n) for n in ("red", "blue", "green"))
    red.diffuse_color = (1, 0, 0, 1)
    obj = mesh_object("slots", TETRA_VERTS, TETRA_FACES)
    for material in (red, None, blue):  # slot 1 stays empty
        obj.data.materials.append(material)
    obj.material_slots[2].link = "OBJECT"  # object-linked slot overrides the mesh's blue
    obj.material_slots[2].material = green
    obj.data.polygons.foreach_set("material_index", [0, 1, 2, 7])  # 7: no such slot
    scene = extract(addon)
    names = scene.materials.names
    ids = scene.geometry.material_ids
    assert names[ids[0]] == "red"
    assert ids[1] == 0 and ids[3] == 0  # empty slot and missing slot → fallback
    assert names[ids[2]] == "green"
    assert "blue" not in names
    # Material nodes are read for the table (red's Principled default colour, not diffuse_color).
    assert len(scene.materials) == 3


def test_principled_values_reach_the_table_through_the_shared_mapping(addon):
    clear_scene()
    mirror = bpy.data.materials.new("mirror")
    principled = mirror.node_tree.nodes["Principled BSDF"]
    principled.inputs["Base Color"].default_value = (0.9, 0.7, 0.5, 1.0)
    principled.inputs["Metallic"].default_value = 1.0
    principled.inputs["Roughness"].default_value = 0.0
    principled.inputs["Emission Color"].default_value = (1.0, 0.5, 0.0, 1.0)
    principled.inputs["Emission Strength"].default_value = 2.0
    mirror.hybrid_rt.thickness = 0.25
    obj = mesh_object("mirror", TETRA_VERTS, TETRA_FACES)
    obj.data.materials.append(mirror)
    table = extract(addon).materials
    k = table.names.index("mirror")
    np.testing.assert_allclose(table.base_color[k], (0.9, 0.7, 0.5), atol=1e-6)
    assert table.reflectivity[k] == 1.0 and table.transmission[k] == 0.0
    np.testing.assert_allclose(table.emission[k], (2.0, 1.0, 0.0), atol=1e-6)
    assert table.thickness[k] == pytest.approx(0.25)


def test_triangulation_shortcut_matches_blender_loop_triangles(addon):
    """Triangles, convex quads, a concave quad (Blender flips its split), a degenerate quad
    and an n-gon: corners must be exactly Blender's loop triangles."""
    clear_scene()
    verts = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0),  # convex quad
             (2, 0, 0), (4, 0, 0), (2.2, 0.2, 0), (2, 2, 0),  # concave (dart) quad
             (5, 0, 0), (6, 0, 0), (7, 0, 0), (8, 0, 0),  # degenerate (collinear) quad
             (9, 0, 0), (10, 0, 0), (10.5, 1, 0), (10, 2, 0), (9, 2, 0), (8.7, 1, 0.3),  # hexagon
             (0, 3, 0), (1, 3, 0), (0, 4, 0)]  # triangle
    faces = [(0, 1, 2, 3), (4, 5, 6, 7), (8, 9, 10, 11), (12, 13, 14, 15, 16, 17), (18, 19, 20)]
    obj = mesh_object("mixed", verts, faces)
    geometry = extract(addon).geometry
    mesh = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    expected = np.array([[verts[v] for v in tri.vertices] for tri in mesh.loop_triangles])
    np.testing.assert_allclose(geometry.triangles, expected, atol=GEOMETRY_TOLERANCE)


def test_active_render_uv_map_is_extracted(addon):
    clear_scene()
    obj = mesh_object("uv", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [(0, 1, 2)])
    obj.data.uv_layers.new(name="other")
    render_map = obj.data.uv_layers.new(name="render")
    render_map.active_render = True
    render_map.uv.foreach_set("vector", [0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    geometry = extract(addon).geometry
    np.testing.assert_allclose(geometry.uvs[0], [(0.1, 0.2), (0.3, 0.4), (0.5, 0.6)], atol=1e-6)


def test_curves_text_and_metaballs_become_triangles_without_leaking_meshes(addon):
    clear_scene()
    bpy.ops.curve.primitive_bezier_circle_add()
    bpy.context.object.data.extrude = 0.2
    bpy.ops.object.text_add(location=(5, 0, 0))
    bpy.ops.object.metaball_add(location=(-5, 0, 0))
    meshes_before = len(bpy.data.meshes)
    geometry = extract(addon).geometry
    assert len(bpy.data.meshes) == meshes_before
    xs = geometry.object_bounds[:, :, 0].mean(axis=1)
    assert geometry.triangle_count > 0
    assert (xs < -3).any() and (xs > 3).any() and (np.abs(xs) < 2).any()  # all three present


# ---------------------------------------------------------------------------------------
# bad input
def test_empty_scene_gives_empty_geometry_and_the_fallback_material(addon):
    clear_scene()
    scene = extract(addon)
    assert scene.geometry.triangle_count == 0 and len(scene.geometry.object_ranges) == 0
    assert len(scene.materials) == 1 and len(scene.lights) == 0


def test_mesh_without_faces_contributes_nothing(addon):
    clear_scene()
    mesh = bpy.data.meshes.new("edges")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0)], [(0, 1)], [])
    bpy.context.scene.collection.objects.link(bpy.data.objects.new("edges", mesh))
    assert extract(addon).geometry.triangle_count == 0


def test_non_finite_vertices_drop_their_triangles_and_leave_user_data_unchanged(addon):
    clear_scene()
    verts = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (math.nan, 0, 0), (0, math.inf, 0), (2, 2, 0)]
    faces = [(0, 1, 2), (1, 3, 2), (1, 5, 2), (0, 4, 1)]
    obj = mesh_object("broken", verts, faces)
    before = np.empty(len(verts) * 3, np.float32)
    obj.data.vertices.foreach_get("co", before)
    geometry = extract(addon).geometry
    assert_same_triangles(geometry.triangles, np.array(verts)[[[0, 1, 2], [1, 5, 2]]])
    assert np.isfinite(geometry.object_bounds).all()
    after = np.empty_like(before)
    obj.data.vertices.foreach_get("co", after)
    np.testing.assert_array_equal(before, after)
    assert len(obj.data.polygons) == 4


def test_a_vertex_set_to_infinity_drops_its_triangles_and_stays_out_of_the_bounds(addon):
    """Blender stores a coordinate set to infinity as float32's largest value, which numpy
    calls finite: it must still count as non-finite, or its box overflows every fit."""
    clear_scene()
    obj = mesh_object("stretched", [(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0)], [(0, 1, 2), (1, 3, 2)])
    obj.data.vertices[3].co = (math.inf, 0.0, 0.0)
    assert obj.data.vertices[3].co.x == np.finfo(np.float32).max  # Blender's clamp
    geometry = extract(addon).geometry
    assert_same_triangles(geometry.triangles, np.array([[(0, 0, 0), (1, 0, 0), (0, 1, 0)]], np.float32))
    np.testing.assert_array_equal(geometry.object_bounds[0], [[0, 0, 0], [1, 1, 0]])


def test_zero_area_triangles_are_kept_with_unit_normals(addon):
    clear_scene()
    mesh_object("flat", [(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0)], [(0, 1, 2), (0, 1, 3)])
    geometry = extract(addon).geometry
    assert geometry.triangle_count == 2
    np.testing.assert_allclose(np.linalg.norm(geometry.normals, axis=2), 1.0, atol=NORMAL_TOLERANCE)


# ---------------------------------------------------------------------------------------
# lights, world, camera
def test_lights_are_extracted_with_position_direction_and_power(addon):
    clear_scene()
    rows = {}
    for kind, location, rotation in (("POINT", (1, 2, 3), (0, 0, 0)), ("SUN", (0, 0, 9), (math.pi / 2, 0, 0)),
                                     ("SPOT", (4, 0, 1), (0, math.pi / 2, 0)), ("AREA", (0, 0, 5), (0, 0, 0))):
        light = bpy.data.lights.new(kind.lower(), kind)
        light.color = (1.0, 0.5, 0.25)
        light.energy = 10.0
        light.use_shadow = kind != "AREA"
        if kind == "SPOT":
            light.spot_size, light.spot_blend = 0.8, 0.3
        obj = bpy.data.objects.new(kind.lower(), light)
        obj.location, obj.rotation_euler = location, rotation
        bpy.context.scene.collection.objects.link(obj)
        rows[kind] = (location, np.array(trs(location, rotation))[:3, 2] * -1)
    lights = extract(addon).lights
    assert len(lights) == 4
    kinds = {"POINT": 0, "SUN": 1, "SPOT": 2, "AREA": 3}
    for kind, (location, direction) in rows.items():
        i = list(lights.kind).index(kinds[kind])
        np.testing.assert_allclose(lights.position[i], location, atol=GEOMETRY_TOLERANCE)
        np.testing.assert_allclose(lights.direction[i], direction, atol=NORMAL_TOLERANCE)
        np.testing.assert_allclose(lights.color[i], (10.0, 5.0, 2.5), atol=1e-5)
        assert lights.cast_shadow[i] == (kind != "AREA")
    spot = list(lights.kind).index(2)
    assert lights.spot_size[spot] == pytest.approx(0.8) and lights.spot_blend[spot] == pytest.approx(0.3)


def test_world_background_colour_and_strength(addon):
    clear_scene()
    world = bpy.data.worlds.new("w")
    bpy.context.scene.world = world
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (0.2, 0.3, 0.4, 1.0)
    background.inputs["Strength"].default_value = 2.5
    sky = extract(addon).sky
    assert sky.color == pytest.approx((0.2, 0.3, 0.4)) and sky.strength == pytest.approx(2.5)
    assert sky.environment is None


def test_no_world_gives_blenders_default_grey(addon):
    clear_scene()
    bpy.context.scene.world = None
    sky = extract(addon).sky
    assert sky.color == pytest.approx((0.05, 0.05, 0.05)) and sky.environment is None


def test_equirectangular_environment_texture_becomes_the_sky_image(addon, rng):
    clear_scene()
    world = bpy.data.worlds.new("env")
    bpy.context.scene.world = world
    image = bpy.data.images.new("sky", width=8, height=4, float_buffer=True)
    pixels = rng.random((4, 8, 4)).astype(np.float32)
    image.pixels.foreach_set(pixels.ravel())
    environment = world.node_tree.nodes.new("ShaderNodeTexEnvironment")
    environment.image = image
    world.node_tree.links.new(environment.outputs["Color"], world.node_tree.nodes["Background"].inputs["Color"])
    sky = extract(addon).sky
    np.testing.assert_allclose(sky.environment, pixels[:, :, :3], atol=1e-6)
    # Read once per image content: a second export hands over the same array (the GPU keeps
    # its irradiance and mipmaps), another image a new one.
    assert extract(addon).sky.environment is sky.environment
    other = bpy.data.images.new("sky2", width=8, height=4, float_buffer=True)
    other.pixels.foreach_set(rng.random(8 * 4 * 4).astype(np.float32))
    environment.image = other
    assert extract(addon).sky.environment is not sky.environment


def test_camera_from_scene_reads_optics_and_scaled_resolution(addon):
    clear_scene()
    data = bpy.data.cameras.new("cam")
    data.lens, data.sensor_width, data.sensor_fit = 35.0, 32.0, "HORIZONTAL"
    data.shift_x, data.clip_start, data.clip_end = 0.1, 0.5, 250.0
    cam = bpy.data.objects.new("cam", data)
    cam.location = (1, -5, 2)
    bpy.context.scene.collection.objects.link(cam)
    scene = bpy.context.scene
    scene.camera = cam
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 1000, 500, 50
    depsgraph = bpy.context.evaluated_depsgraph_get()
    camera = addon.blender_adapter.export.camera.camera_from_scene(scene, depsgraph)
    assert (camera.width, camera.height) == (500, 250)
    assert (camera.lens, camera.sensor_width, camera.sensor_fit) == (35.0, 32.0, "HORIZONTAL")
    assert camera.shift_x == pytest.approx(0.1) and (camera.clip_start, camera.clip_end) == (0.5, 250.0)
    np.testing.assert_allclose(camera.position, (1, -5, 2))
    data.type = "ORTHO"
    data.ortho_scale = 9.0
    camera = addon.blender_adapter.export.camera.camera_from_scene(scene)
    assert camera.projection == "ORTHO" and camera.ortho_scale == 9.0


def test_missing_or_panoramic_camera_fails_with_a_clear_message(addon):
    clear_scene()
    scene = bpy.context.scene
    camera_from_scene = addon.blender_adapter.export.camera.camera_from_scene
    scene.camera = None
    with pytest.raises(ValueError, match="no active camera"):
        camera_from_scene(scene)
    data = bpy.data.cameras.new("pano")
    data.type = "PANO"
    scene.camera = bpy.data.objects.new("pano", data)
    scene.collection.objects.link(scene.camera)
    with pytest.raises(ValueError, match="PANO"):
        camera_from_scene(scene)


def test_objects_disabled_for_render_are_excluded_in_a_final_render(addon):
    """The final render's depsgraph drops hide_render objects; checked with a tiny engine
    that only extracts."""
    clear_scene()
    extract_scene = addon.blender_adapter.scene_cache.extract_scene
    mesh_object("shown", TETRA_VERTS, TETRA_FACES)
    mesh_object("hidden", TETRA_VERTS, TETRA_FACES, trs((5, 0, 0))).hide_render = True
    seen = {}

    class ExtractOnlyEngine(bpy.types.RenderEngine):
        bl_idname = "HYBRID_RT_TEST_EXTRACT"
        bl_label = "extract only"

        def render(self, depsgraph):
            seen["names"] = extract_scene(depsgraph).geometry.object_names

    bpy.utils.register_class(ExtractOnlyEngine)
    try:
        scene = bpy.context.scene
        scene.render.engine = "HYBRID_RT_TEST_EXTRACT"
        scene.render.resolution_x = scene.render.resolution_y = 8
        cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
        scene.collection.objects.link(cam)
        scene.camera = cam
        bpy.ops.render.render()
    finally:
        bpy.utils.unregister_class(ExtractOnlyEngine)
    assert seen["names"] == ["shown"]


# ---------------------------------------------------------------------------------------
# speed
@pytest.mark.slow
def test_one_million_triangles_extract_within_budget(addon):
    """A ~0.5M-triangle subdivided grid plus four collection instances of a ~125k-triangle
    grid: about one million triangles, best of several runs after a warm-up."""
    clear_scene()
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=501, y_subdivisions=501, size=10)
    bpy.context.object.data.shade_smooth()
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=251, y_subdivisions=251, size=2)
    part = bpy.context.object
    source = bpy.data.collections.new("parts")
    for owner in part.users_collection:
        owner.objects.unlink(part)
    source.objects.link(part)
    for i in range(4):
        empty = bpy.data.objects.new(f"inst{i}", None)
        empty.instance_type, empty.instance_collection = "COLLECTION", source
        empty.location = (12 + 3 * i, 0, 0)
        bpy.context.scene.collection.objects.link(empty)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    extract_scene = addon.blender_adapter.scene_cache.extract_scene
    count = extract_scene(depsgraph).geometry.triangle_count  # warm-up: Blender's lazy caches
    timings = []
    for _ in range(BENCH_REPEATS):
        start = time.perf_counter()
        extract_scene(depsgraph)
        timings.append((time.perf_counter() - start) * 1e3)
    best = min(timings)
    print(f"\nextract_scene: {count} triangles, best {best:.1f} ms, runs {np.round(timings, 1)}")
    assert count == 2 * 501 * 501 + 4 * 2 * 251 * 251  # grid subdivisions count quads per side
    assert best <= EXTRACT_BUDGET_MS


# ---------------------------------------------------------------------------------------
# image textures
# Byte images come back as value / 255 in their colour space; the expected linear values
# are decoded here with the sRGB formula (IEC 61966-2-1), independently of the engine's.
def srgb_decode(values):
    values = np.asarray(values, np.float64)
    return np.where(values <= 0.04045, values / 12.92, ((values + 0.055) / 1.055) ** 2.4)


def uv_plane(name="plane"):
    """A unit quad in z = 0 whose render UV map equals its xy coordinates."""
    obj = mesh_object(name, [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [(0, 1, 2, 3)])
    uv_map = obj.data.uv_layers.new(name="render")
    uv_map.uv.foreach_set("vector", [0, 0, 1, 0, 1, 1, 0, 1])
    return obj


def image_of(name, pixels, float_buffer=False):
    """A generated image holding ``pixels`` ((H, W, 4), row 0 at the bottom)."""
    pixels = np.asarray(pixels, np.float32)
    image = bpy.data.images.new(name, pixels.shape[1], pixels.shape[0], float_buffer=float_buffer)
    image.pixels.foreach_set(pixels.reshape(-1))
    return image


def textured_material(name, image, socket="Base Color"):
    """A Principled material whose ``socket`` is fed by an Image Texture of ``image``."""
    material = bpy.data.materials.new(name)
    tree = material.node_tree
    principled = tree.nodes["Principled BSDF"]
    principled.inputs[socket].default_value = (1.0, 0.0, 0.0, 1.0)  # ignored once linked
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = image
    tree.links.new(tex.outputs["Color"], principled.inputs[socket])
    return material


@pytest.fixture
def fresh_images(addon):
    addon.blender_adapter.export.images.forget_image_pixels()
    yield addon
    addon.blender_adapter.export.images.forget_image_pixels()


def test_image_texture_on_base_color_becomes_a_texture_sampled_through_the_render_uv_map(fresh_images, rng):
    clear_scene()
    pixels = np.ones((3, 4, 4), np.float32)
    pixels[..., :3] = rng.uniform(0, 1, (3, 4, 3))
    image = image_of("checker", pixels)
    obj = uv_plane()
    obj.data.materials.append(textured_material("textured", image))
    scene = extract(fresh_images)
    table = scene.materials
    k = table.names.index("textured")
    assert len(scene.textures) == 1 and table.base_color_texture[k] == 0 and table.emission_texture[k] == -1
    np.testing.assert_allclose(table.base_color[k], (1, 1, 1))  # Blender ignores the linked socket's red
    stored = np.round(pixels[..., :3] * 255) / 255  # 8-bit storage
    # OpenColorIO evaluates the sRGB curve in float32: within 3e-5 of the exact curve.
    np.testing.assert_allclose(scene.textures[0][..., :3], srgb_decode(stored), atol=3e-5)
    corners = {tuple(np.round(c, 6)) for c in scene.geometry.uvs.reshape(-1, 2)}
    assert corners == {(0, 0), (1, 0), (1, 1), (0, 1)}


def test_float_image_on_emission_color_is_read_linear_and_scaled_by_the_strength(fresh_images, rng):
    clear_scene()
    pixels = np.ones((2, 2, 4), np.float32)
    pixels[..., :3] = rng.uniform(0, 4, (2, 2, 3))  # HDR values survive
    material = textured_material("glow", image_of("hdr", pixels, float_buffer=True), socket="Emission Color")
    material.node_tree.nodes["Principled BSDF"].inputs["Emission Strength"].default_value = 3.0
    uv_plane().data.materials.append(material)
    scene = extract(fresh_images)
    k = scene.materials.names.index("glow")
    assert scene.materials.emission_texture[k] == 0 and scene.materials.base_color_texture[k] == -1
    np.testing.assert_allclose(scene.materials.emission[k], (3, 3, 3))
    np.testing.assert_array_equal(scene.textures[0], pixels)


@pytest.mark.parametrize("factor, expected", [(1.0, (0.5, 0.25, 1.0)), (0.5, (0.75, 0.625, 1.0))])
def test_multiply_mix_of_an_image_and_a_colour_gives_the_factor_blender_computes(fresh_images, factor, expected):
    """Blender's Multiply mix is A (1 - f + f B): the image in A is scaled by 1 - f + f B."""
    clear_scene()
    material = bpy.data.materials.new("tinted")
    tree = material.node_tree
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type, mix.blend_type = "RGBA", "MULTIPLY"
    inputs = {s.identifier: s for s in mix.inputs}  # several inputs are named "A" and "B"
    inputs["Factor_Float"].default_value = factor
    inputs["B_Color"].default_value = (0.5, 0.25, 1.0, 1.0)
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = image_of("grey", np.full((2, 2, 4), 0.5, np.float32))
    tree.links.new(tex.outputs["Color"], inputs["A_Color"])
    result = next(s for s in mix.outputs if s.identifier == "Result_Color")
    tree.links.new(result, tree.nodes["Principled BSDF"].inputs["Base Color"])
    uv_plane().data.materials.append(material)
    scene = extract(fresh_images)
    k = scene.materials.names.index("tinted")
    assert scene.materials.base_color_texture[k] == 0
    np.testing.assert_allclose(scene.materials.base_color[k], expected, atol=1e-6)


def test_non_color_byte_images_are_not_decoded(fresh_images):
    clear_scene()
    image = bpy.data.images.new("data", 2, 2)
    image.colorspace_settings.name = "Non-Color"  # before the pixels: Blender regenerates on change
    image.pixels.foreach_set(np.full(16, 0.4, np.float32))
    uv_plane().data.materials.append(textured_material("data", image))
    scene = extract(fresh_images)
    np.testing.assert_allclose(scene.textures[0][..., :3], np.round(0.4 * 255) / 255, atol=1e-6)


def test_an_image_without_pixels_warns_and_renders_magenta_as_in_blender(fresh_images, caplog):
    clear_scene()
    image = bpy.data.images.new("missing", 4, 4)
    image.source = "FILE"
    image.filepath = "/nonexistent/missing_texture.png"
    uv_plane().data.materials.append(textured_material("broken", image))
    with caplog.at_level("WARNING"):
        scene = extract(fresh_images)
    k = scene.materials.names.index("broken")
    texture = scene.textures[scene.materials.base_color_texture[k]]
    np.testing.assert_array_equal(texture.reshape(-1, 4), [[1.0, 0.0, 1.0, 1.0]])
    np.testing.assert_allclose(scene.materials.base_color[k], (1.0, 1.0, 1.0))  # Blender ignores the socket
    assert any("missing" in r.getMessage() and "no pixels" in r.getMessage() for r in caplog.records)


def test_image_pixels_are_read_once_and_again_only_when_the_image_changes(fresh_images):
    """Two extractions (two playback frames) share the very same pixel array; resizing the
    image gives a new one."""
    clear_scene()
    image = image_of("cached", np.full((4, 4, 4), 0.5, np.float32))
    uv_plane().data.materials.append(textured_material("cached", image))
    first = extract(fresh_images).textures[0]
    assert extract(fresh_images).textures[0] is first
    assert not first.flags.writeable  # shared: nobody may change it in place
    image.scale(8, 8)
    second = extract(fresh_images).textures[0]
    assert second is not first and second.shape == (8, 8, 4)


# ---------------------------------------------------------------------------------------
# closed surfaces (hybrid_engine/scene/solids.py: their back faces may be culled)
def test_closed_meshes_are_marked_for_back_face_culling_and_open_or_mirrored_ones_right(addon):
    clear_scene()
    bpy.ops.mesh.primitive_cube_add(location=(0, 0, 0))
    bpy.context.object.name = "cube"
    bpy.ops.mesh.primitive_cube_add(location=(4, 0, 0))
    bpy.context.object.name = "mirrored_cube"
    bpy.context.object.scale = (-1.0, 1.0, 1.0)  # the extractor swaps corners: still outward
    bpy.ops.mesh.primitive_uv_sphere_add(location=(0, 4, 0))
    bpy.context.object.name = "sphere"
    bpy.ops.mesh.primitive_plane_add(location=(0, 0, -2))
    bpy.context.object.name = "plane"
    mesh_object("open_tetra", TETRA_VERTS, TETRA_FACES[:3], trs((0, -4, 0), (0, 0, 0), (1, 1, 1)))
    inward = [tuple(reversed(face)) for face in TETRA_FACES]
    mesh_object("inward_tetra", TETRA_VERTS, inward, trs((0, -8, 0), (0, 0, 0), (1, 1, 1)))
    geometry = extract(addon).geometry
    closed = dict(zip(geometry.object_names, geometry.object_closed.tolist()))
    assert closed == {"cube": True, "mirrored_cube": True, "sphere": True, "plane": False,
                      "open_tetra": False, "inward_tetra": False}
