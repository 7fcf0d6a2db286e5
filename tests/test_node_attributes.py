# SPDX-License-Identifier: GPL-3.0-or-later
"""Color Attribute and Attribute nodes through the renderer (scene/mesh_attributes.py,
passes/scene_upload/node_attributes.py, include/node_attributes.glsl): per-corner values
interpolated at the G-buffer's pixels and at the tracer's BVH and cube-map hits, instance
values per instance, and what a scene that reads none pays (nothing)."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine.gpu import variants
from hybrid_engine.scene.data import Lights, MaterialTable, SceneData, Sky
from hybrid_engine.scene.geometry import InstancedGeometry
from hybrid_engine.scene.mesh_attributes import AttributeRequests, as_rgba, interpolate
from hybrid_engine.scene.meshes import Instances
from hybrid_engine.scene.node_program import compile_table, graph_requests
from hybrid_engine.scene.settings import RenderSettings
from hybrid_engine.scene.shader_graph import Link, ShaderGraph
from scenes_instanced import grid_mesh, placed
from test_textures import top_down_camera


def linear_colour(points: np.ndarray) -> np.ndarray:
    """An RGBA that is linear in object x and y: interpolating its corner values gives it
    exactly at every point, so a wrong corner order or wrong barycentrics shows."""
    x, y = points[..., 0], points[..., 1]
    return np.stack([0.5 + 0.4 * x, 0.5 + 0.4 * y, 0.35 + 0.1 * x - 0.1 * y, 0.6 + 0.3 * y], -1).astype(np.float32)


def coloured_grid(name: str = "Col"):
    mesh = grid_mesh(3)
    corners = mesh.positions[mesh.corner_vertices]
    mesh.attributes = {name: linear_colour(corners)}
    return mesh


def emission_of(kind: str, output: str, settings: dict, strength: float = 1.0) -> ShaderGraph:
    graph = ShaderGraph()
    node = graph.add(kind, settings=settings)
    shader = graph.add("EMISSION", Color=Link(node, output), Strength=strength)
    graph.surface = Link(shader, "Emission")
    return graph


def scene_of(mesh, matrices, graphs, instance_attributes=None, rows=None, extra=None) -> SceneData:
    meshes, mesh_of, slots = [mesh], [0] * len(matrices), [np.int32([0, 0])] * len(matrices)
    if extra is not None:  # (mesh, matrix, slot materials)
        meshes.append(extra[0])
        mesh_of.append(1)
        matrices = [*matrices, extra[1]]
        slots = [*slots, extra[2]]
    instances = Instances(meshes=meshes, mesh=np.int32(mesh_of), matrices=np.array(matrices, np.float32),
                          slot_materials=slots, attributes=instance_attributes)
    table = MaterialTable.from_rows(rows or [dict() for _ in graphs])
    table.node_graphs = list(graphs)
    return SceneData(InstancedGeometry(instances), table, Lights.from_rows([]), Sky(color=(0.0, 0.0, 0.0)))


def object_points(camera, matrix) -> tuple[np.ndarray, np.ndarray]:
    """Each pixel's point on the plane z = 0 in the object space of ``matrix``, and whether it
    lies on the grid ([-1, 1]^2, away from its border by a pixel)."""
    origins, dirs = camera.pixel_rays()
    points = origins + dirs * (-origins[..., 2] / dirs[..., 2])[..., None]
    inverse = np.linalg.inv(np.asarray(matrix, np.float64))
    local = points @ inverse[:3, :3].T + inverse[:3, 3]
    return local, (np.abs(local[..., :2]) < 0.93).all(-1)


MATRICES = [placed(np.eye(3), (-1.1, 0.0, 0.0)), placed(np.diag([-1.0, 1.0, 1.0]), (1.1, 0.0, 0.0))]


@pytest.fixture
def kernel_variant(request):
    """Force one shape of a kernel ("vertices=gpu": the instanced indexed draws, whose
    fragments find their row from gl_PrimitiveID; "trace=gpu": the waves' hit records)."""
    variants.set_override(request.param)
    yield request.param
    variants.set_override(None)


@pytest.mark.parametrize("kernel_variant", ["vertices=cpu", "vertices=gpu"], indirect=True)
@pytest.mark.parametrize("output", ["Color", "Alpha"])
def test_a_corner_colour_is_interpolated_at_every_pixel_of_plain_and_mirrored_instances(renderer, output,
                                                                                        kernel_variant):
    scene = scene_of(coloured_grid(), MATRICES, [emission_of("VERTEX_COLOR", output, {"layer_name": "Col"})])
    camera = top_down_camera(size=64, scale=4.6)
    image = renderer.render(scene, camera, RenderSettings(mode="RASTER")).image
    for matrix in MATRICES:
        local, inside = object_points(camera, matrix)
        expected = linear_colour(local)
        want = expected[..., :3] if output == "Color" else np.repeat(expected[..., 3:], 3, -1)
        assert inside.sum() > 300
        np.testing.assert_allclose(image[inside][:, :3], want[inside], atol=2e-3)


def test_the_attribute_nodes_fac_is_the_mean_and_a_missing_name_reads_zero(renderer):
    fac = emission_of("ATTRIBUTE", "Fac", {"attribute_type": "GEOMETRY", "attribute_name": "Col"})
    missing = emission_of("ATTRIBUTE", "Color", {"attribute_type": "GEOMETRY", "attribute_name": "Nothing"}, 1.0)
    scene = scene_of(coloured_grid(), MATRICES[:1], [fac, missing],
                     extra=(coloured_grid(), MATRICES[1], np.int32([1, 1])))
    camera = top_down_camera(size=64, scale=4.6)
    image = renderer.render(scene, camera, RenderSettings(mode="RASTER")).image
    local, inside = object_points(camera, MATRICES[0])
    np.testing.assert_allclose(image[inside][:, 0], linear_colour(local)[inside][:, :3].mean(-1), atol=2e-3)
    _, inside = object_points(camera, MATRICES[1])
    np.testing.assert_allclose(image[inside][:, :3], 0.0, atol=1e-6)


def test_an_object_attribute_is_each_instances_own_value(renderer):
    values = np.float32([[0.9, 0.1, 0.2, 1.0], [0.1, 0.7, 0.3, 1.0]])
    graph = emission_of("ATTRIBUTE", "Color", {"attribute_type": "OBJECT", "attribute_name": "tint"})
    scene = scene_of(coloured_grid(), MATRICES, [graph], instance_attributes={("OBJECT", "tint"): values})
    camera = top_down_camera(size=64, scale=4.6)
    image = renderer.render(scene, camera, RenderSettings(mode="RASTER")).image
    for matrix, value in zip(MATRICES, values):
        _, inside = object_points(camera, matrix)
        np.testing.assert_allclose(image[inside][:, :3], np.broadcast_to(value[:3], (inside.sum(), 3)), atol=2e-3)


def mirror_scene(ceiling_z: float):
    """A mirror floor at z = 0 seen from above (camera at z = 3), and a coloured grid facing
    down at ``ceiling_z``, above the camera: only the mirror shows it."""
    floor = grid_mesh(1)
    flip = placed(np.diag([1.0, -1.0, -1.0]), (0.0, 0.0, ceiling_z))  # faces down, mirrors y
    graph = emission_of("VERTEX_COLOR", "Color", {"layer_name": ""})
    rows = [dict(), dict(base_color=(1.0, 1.0, 1.0), reflectivity=1.0, roughness=0.0)]
    scene = scene_of(coloured_grid(""), [flip], [graph, None], rows=rows,
                     extra=(floor, placed(np.eye(3) * 4.0, (0.0, 0.0, 0.0)), np.int32([1, 1])))
    return scene, flip


@pytest.mark.parametrize("kernel_variant", ["trace=cpu", "trace=gpu"], indirect=True)
@pytest.mark.parametrize(("ceiling_z", "near_size", "where"), [(4.0, 5.0, "bvh"), (6.0, 1.0, "cube map")])
def test_a_mirror_shows_the_interpolated_colour_at_bvh_and_cube_map_hits(renderer, ceiling_z, near_size, where,
                                                                         kernel_variant):
    scene, flip = mirror_scene(ceiling_z)
    camera = top_down_camera(size=48, scale=1.6)
    settings = RenderSettings(mode="HYBRID", near_size=near_size, cube_far=20.0, cube_resolution=256, max_depth=1)
    image = renderer.render(scene, camera, settings).image
    # The mirror at z = 0 shows the ceiling's point above each pixel's reflection: (x, y) at
    # the ceiling, whose object coordinates are (x, -y).
    origins, _ = camera.pixel_rays()
    local = np.stack([origins[..., 0], -origins[..., 1], np.zeros_like(origins[..., 0])], -1)
    expected = linear_colour(local)[..., :3]
    tolerance = 4e-3 if where == "bvh" else 0.03  # the cube map: its texels' positions
    np.testing.assert_allclose(image[4:-4, 4:-4, :3], expected[4:-4, 4:-4], atol=tolerance, err_msg=where)


def test_a_scene_whose_programs_read_no_attribute_compiles_binds_and_sends_none(renderer):
    """Meshes may carry attributes; without an attribute node none is sent, the interpreter has
    no attribute case and nothing of the store is bound."""
    graph = ShaderGraph()
    shader = graph.add("EMISSION", Color=(0.2, 0.3, 0.4, 1.0))
    graph.surface = Link(shader, "Emission")
    scene = scene_of(coloured_grid(), MATRICES, [graph])
    renderer.render(scene, top_down_camera(size=32, scale=4.6), RenderSettings(mode="RASTER"))
    gpu = renderer.gpu_scene
    assert "NODE_ATTRIBUTES" not in gpu.defines
    assert not gpu.node_attributes.active and gpu.node_attributes.bytes_written == 0
    assert "NodeAttributes" not in gpu.bindings().storage
    scene.materials.node_graphs = [emission_of("VERTEX_COLOR", "Color", {"layer_name": "Col"})]
    renderer.render(scene, top_down_camera(size=32, scale=4.6), RenderSettings(mode="RASTER"))
    assert gpu.defines.get("NODE_ATTRIBUTES") == 1 and "NodeAttributes" in gpu.bindings().storage


def test_an_attribute_edit_writes_that_meshs_values_only(renderer):
    graph = emission_of("VERTEX_COLOR", "Color", {"layer_name": "Col"})
    painted, other = coloured_grid(), coloured_grid()
    scene = scene_of(painted, MATRICES[:1], [graph], extra=(other, MATRICES[1], np.int32([0, 0])))
    camera = top_down_camera(size=32, scale=4.6)
    renderer.render(scene, camera, RenderSettings(mode="RASTER"))
    store = renderer.gpu_scene.node_attributes
    colour = np.tile(np.float32([0.3, 0.6, 0.9, 1.0]), (len(painted.slots) * 3, 1))
    repainted = painted.deformed(painted.positions, painted.normals, attributes={"Col": colour})
    scene.geometry.instances.meshes[0] = repainted
    image = renderer.render(scene, camera, RenderSettings(mode="RASTER")).image
    assert store.meshes_written == 1
    assert store.bytes_written == repainted.triangle_count * (3 + 3) * 16  # its corners and values, no table
    _, inside = object_points(camera, MATRICES[0])
    np.testing.assert_allclose(image[inside][:, :3], np.broadcast_to([0.3, 0.6, 0.9], (inside.sum(), 3)), atol=2e-3)


def test_the_requests_are_what_the_surface_reaches_each_once_in_a_fixed_order():
    used = emission_of("VERTEX_COLOR", "Color", {"layer_name": "b"})
    used.add("ATTRIBUTE", settings={"attribute_type": "GEOMETRY", "attribute_name": "unreached"})
    other = emission_of("ATTRIBUTE", "Fac", {"attribute_type": "GEOMETRY", "attribute_name": "a"})
    tint = emission_of("ATTRIBUTE", "Color", {"attribute_type": "OBJECT", "attribute_name": "tint"})
    again = emission_of("VERTEX_COLOR", "Alpha", {"layer_name": "b"})
    requests = graph_requests([used, other, tint, again, None])
    assert requests == AttributeRequests(("a", "b"), (("OBJECT", "tint"),))
    assert compile_table([used, other, tint], 3).attributes == requests
    assert not graph_requests([ShaderGraph()])


def test_attribute_types_become_rgba_as_cycles_reads_them():
    np.testing.assert_array_equal(as_rgba(np.float32([0.5])), [[0.5, 0.5, 0.5, 1.0]])
    np.testing.assert_array_equal(as_rgba(np.float32([[0.1, 0.2]])), np.float32([[0.1, 0.2, 0.0, 1.0]]))
    np.testing.assert_array_equal(as_rgba(np.float32([[0.1, 0.2, 0.3]])), np.float32([[0.1, 0.2, 0.3, 1.0]]))
    rgba = np.float32([[0.1, 0.2, 0.3, 0.4]])
    np.testing.assert_array_equal(as_rgba(rgba), rgba)
    corners = np.float32([[[1, 0, 0, 1], [0, 1, 0, 1], [0, 0, 1, 0]]])
    np.testing.assert_allclose(interpolate(corners, [[0.2, 0.3, 0.5]]), [[0.2, 0.3, 0.5, 0.5]])


def test_a_worlds_attribute_node_reads_as_missing_without_a_store(renderer):
    """A World has no mesh or object: its bake compiles without the store and an Attribute
    node there gives 0, as Cycles' does (the sky is the Background's Color times 0 plus 0.25)."""
    from test_world_graph import horizon_camera, sky_scene
    from hybrid_engine.scene.data import Sky

    graph = ShaderGraph()
    attribute = graph.add("ATTRIBUTE", settings={"attribute_type": "GEOMETRY", "attribute_name": "Col"})
    mix = graph.add("MATH", settings={"operation": "ADD"}, Value=Link(attribute, "Fac"), Value_001=0.25)
    background = graph.add("BACKGROUND", Color=Link(mix, "Value"), Strength=1.0)
    graph.surface = Link(background, "Background")
    image = renderer.render(sky_scene(Sky(graph=graph)), horizon_camera(),
                            RenderSettings(mode="RASTER", near_size=4.0)).image[..., :3]
    np.testing.assert_allclose(image[-1, 16], (0.25, 0.25, 0.25), rtol=0.01)
