# SPDX-License-Identifier: GPL-3.0-or-later
"""Node programs through the real renderer (include/node_program.glsl run by the G-buffer's
fragment stage and at the tracer's BVH and cube-map hits): pixels against numpy expectations,
and the edit that must not compile a shader."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine.gpu import shader_loader
from hybrid_engine.gpu.bindings import layout
from hybrid_engine.scene.data import Lights, MaterialTable, SceneData, Sky
from hybrid_engine.scene.geometry import Geometry, InstancedGeometry
from hybrid_engine.scene.meshes import Instances
from hybrid_engine.scene.settings import RenderSettings
from hybrid_engine.scene.shader_graph import Link, ShaderGraph
from node_oracle import glsl_probe
from scenes_instanced import indexed, placed
from test_textures import plane_uv, textured_quad, top_down_camera


def uv_emission(strength: float = 2.0) -> ShaderGraph:
    graph = ShaderGraph()
    coords = graph.add("TEX_COORD")
    shader = graph.add("EMISSION", Color=Link(coords, "UV"), Strength=strength)
    graph.surface = Link(shader, "Emission")
    return graph


def plane_scene(objects, graphs, rows=None) -> SceneData:
    """objects: [(triangles, uvs, material)]; black World, no lamps."""
    geo = Geometry.from_objects([(t, None, m) for t, _, m in objects])
    geo = Geometry(geo.triangles, geo.normals, geo.material_ids, geo.object_ranges, geo.object_bounds,
                   geo.object_names, uvs=np.concatenate([uv for _, uv, _ in objects]))
    table = MaterialTable.from_rows(rows or [dict(base_color=(0.8, 0.8, 0.8)) for _ in graphs])
    table.node_graphs = list(graphs)
    return SceneData(geo, table, Lights.from_rows([]), Sky(color=(0.0, 0.0, 0.0)))


def floor_uv(camera):
    return plane_uv(camera, 0.0, lambda x, y: np.stack([(x + 1) / 2, (y + 1) / 2], -1))


@pytest.mark.parametrize("mode", ["RASTER", "HYBRID"])
def test_an_emission_of_the_uv_shows_the_uv_at_every_pixel(renderer, mode):
    tris, uvs = textured_quad((-1, -1, 0), (2, 0, 0), (0, 2, 0), (0.0, 0.0), (1.0, 1.0))
    scene = plane_scene([(tris, uvs, 0)], [uv_emission(2.0)])
    camera = top_down_camera(scale=1.9)
    image = renderer.render(scene, camera, RenderSettings(mode=mode)).image
    expected = 2.0 * floor_uv(camera)
    np.testing.assert_allclose(image[..., :2], expected, atol=4e-3)
    np.testing.assert_allclose(image[..., 2], 0.0, atol=1e-6)


def test_a_mix_of_emission_and_diffuse_weights_both(renderer):
    """Mix Shader at 0.25 of a red Emission and a white Diffuse, nothing to light the
    diffuse: the image is 0.75 red, the G-buffer's albedo the diffuse's share, 0.25."""
    graph = ShaderGraph()
    glow = graph.add("EMISSION", Color=(1.0, 0.0, 0.0, 1.0), Strength=1.0)
    diffuse = graph.add("BSDF_DIFFUSE", Color=(1.0, 1.0, 1.0, 1.0))
    mix = graph.add("MIX_SHADER", Fac=0.25, Shader=Link(glow, "Emission"), Shader_001=Link(diffuse, "BSDF"))
    graph.surface = Link(mix, "Shader")
    tris, uvs = textured_quad((-1, -1, 0), (2, 0, 0), (0, 2, 0), (0.0, 0.0), (1.0, 1.0))
    image = renderer.render(plane_scene([(tris, uvs, 0)], [graph]), top_down_camera(scale=1.9),
                            RenderSettings(mode="RASTER")).image
    np.testing.assert_allclose(image[..., :3], np.broadcast_to([0.75, 0.0, 0.0], image[..., :3].shape), atol=1e-3)
    albedo = renderer.gbuffer.primary.read_albedo()[..., :3]
    np.testing.assert_allclose(albedo, 0.25, atol=1e-3)


def test_white_noise_of_each_cells_location_is_the_hash_of_it(renderer):
    """A floor of 6 x 6 unit cells, instances of one quad at half-integer locations, with
    White Noise of Object Info Location as emission: each cell's colour is the hash of its
    location (nodes/tex_white_noise.glsl, equal to Cycles bit for bit), to the G-buffer's
    half precision."""
    n = 6
    tris, uvs = textured_quad((-0.5, -0.5, 0), (1, 0, 0), (0, 1, 0), (0.0, 0.0), (1.0, 1.0))
    mesh = indexed(tris, np.broadcast_to(np.float32([0, 0, 1]), tris.shape).copy(), uvs,
                   np.zeros(2, np.int32), closed=False)
    centres = [(i - n / 2 + 0.5, j - n / 2 + 0.5, 0.0) for j in range(n) for i in range(n)]
    instances = Instances(meshes=[mesh], mesh=np.zeros(n * n, np.int32),
                          matrices=np.array([placed(np.eye(3), c) for c in centres], np.float32),
                          slot_materials=[np.int32([0])] * (n * n))
    graph = ShaderGraph()
    info = graph.add("OBJECT_INFO")
    noise = graph.add("TEX_WHITE_NOISE", settings={"noise_dimensions": "3D"}, Vector=Link(info, "Location"))
    shader = graph.add("EMISSION", Color=Link(noise, "Color"))
    graph.surface = Link(shader, "Emission")
    table = MaterialTable.from_rows([dict()])
    table.node_graphs = [graph]
    scene = SceneData(InstancedGeometry(instances), table, Lights.from_rows([]), Sky(color=(0.0, 0.0, 0.0)))
    size = 60
    camera = top_down_camera(size=size, scale=float(n))
    image = renderer.render(scene, camera, RenderSettings(mode="RASTER")).image
    expected = glsl_probe(renderer.ctx, ["include/nodes/tex_white_noise.glsl"], """
        float value; vec3 color;
        node_tex_white_noise(3, p.xyz, 0.0, value, color);
        return vec4(color, 1.0);""", np.array(centres, np.float32))[..., :3]
    cell = size // n
    got = np.array([image[j * cell + cell // 2, i * cell + cell // 2, :3] for j in range(n) for i in range(n)])
    assert np.unique(expected[:, 0]).size == n * n  # a different colour per cell
    np.testing.assert_allclose(got, expected, atol=1e-3)


def mirror_scene(ceiling_z: float) -> tuple[SceneData, object]:
    """A mirror floor at z = 0 seen from above, and above the camera a ceiling facing down
    whose graph emits its UV: the mirror shows the ceiling's UV at each pixel."""
    floor, floor_uvs = textured_quad((-4, -4, 0), (8, 0, 0), (0, 8, 0), (0.0, 0.0), (1.0, 1.0))
    ceiling, ceiling_uvs = textured_quad((-1, -1, ceiling_z), (0, 2, 0), (2, 0, 0), (0.0, 0.0), (1.0, 1.0))
    ceiling_uvs = ceiling_uvs[..., ::-1].copy()  # u along x, v along y, as the floor's
    rows = [dict(base_color=(1.0, 1.0, 1.0), reflectivity=1.0, roughness=0.0), dict()]
    scene = plane_scene([(floor, floor_uvs, 0), (ceiling, ceiling_uvs, 1)], [None, uv_emission(1.0)], rows)
    return scene, top_down_camera(size=48, scale=1.6)


@pytest.mark.parametrize("trace_variant", ["cpu", "gpu"], indirect=True)
@pytest.mark.parametrize(("ceiling_z", "near_size", "where"), [(4.0, 5.0, "bvh"), (6.0, 1.0, "cube map")])
def test_a_mirror_shows_the_graphs_colour_at_bvh_and_cube_map_hits(renderer, trace_variant, ceiling_z, near_size,
                                                                   where):
    """The megakernel ("cpu") and the waves ("gpu", whose hit records carry the row)."""
    scene, camera = mirror_scene(ceiling_z)
    settings = RenderSettings(mode="HYBRID", near_size=near_size, cube_far=20.0, cube_resolution=256,
                              max_depth=1)
    image = renderer.render(scene, camera, settings).image
    expected = floor_uv(camera)
    # The camera at z = 3 looks down: it sees the ceiling above it only through the mirror.
    tolerance = 5e-3 if where == "bvh" else 0.03  # the cube map: its texels' UVs
    np.testing.assert_allclose(image[..., :2], expected, atol=tolerance, err_msg=where)


@pytest.fixture
def nodes_variant(request, renderer):
    renderer.gpu_scene.node_programs.generate = request.param == "generated"
    yield request.param
    renderer.gpu_scene.node_programs.generate = None


@pytest.mark.parametrize("nodes_variant", ["interpreter", "generated"], indirect=True)
def test_a_value_edit_renders_without_a_shader_compile(renderer, nodes_variant):
    """The interpreter and the generated code, which reads values from the words as the
    interpreter does."""
    tris, uvs = textured_quad((-1, -1, 0), (2, 0, 0), (0, 2, 0), (0.0, 0.0), (1.0, 1.0))
    scene = plane_scene([(tris, uvs, 0)], [uv_emission(1.0)])
    camera = top_down_camera(scale=1.9)
    settings = RenderSettings(mode="HYBRID")
    before = renderer.render(scene, camera, settings).image
    compiled = shader_loader.compiles
    uploads = renderer_uploads(renderer)
    scene.materials.node_graphs[0].nodes[1].inputs["Strength"] = 3.0
    after = renderer.render(scene, camera, settings).image
    assert shader_loader.compiles == compiled
    assert renderer_uploads(renderer) == uploads + 1
    assert ("NODE_GENERATED" in renderer_gpu(renderer).defines) == (nodes_variant == "generated")
    np.testing.assert_allclose(after[..., :2], 3.0 * before[..., :2], atol=1e-2)
    renderer.render(scene, camera, settings)
    assert renderer_uploads(renderer) == uploads + 1  # unchanged words are not sent again


def renderer_uploads(renderer) -> int:
    return renderer.gpu_scene.node_programs.word_uploads


def test_a_scene_without_graphs_compiles_the_shaders_without_the_interpreter(renderer):
    """A graph-free scene binds no program words and its shaders have no interpreter (the
    NodeProgram block is not in them); a scene with graphs gets both; rendering the
    graph-free scene again compiles nothing."""
    tris, uvs = textured_quad((-1, -1, 0), (2, 0, 0), (0, 2, 0), (0.0, 0.0), (1.0, 1.0))
    settings = RenderSettings(mode="HYBRID")
    renderer.render(plane_scene([(tris, uvs, 0)], [uv_emission()]), top_down_camera(scale=1.9), settings)
    assert renderer_gpu(renderer).defines.keys() == {"NODE_PROGRAMS", "NODE_GENERATED", "NODE_GENERATED_ONLY"}
    scene = plane_scene([(tris, uvs, 0)], [None])
    renderer.render(scene, top_down_camera(scale=1.9), settings)
    assert renderer_gpu(renderer).defines == {}
    for program in (renderer.gbuffer.program, renderer.tracer.program, renderer.deferred_shade.program):
        assert "NodeProgram" not in layout(program).blocks
    with_graphs = shader_loader.program(renderer.ctx, vertex="gbuffer/gbuffer.vert.glsl",
                                        fragment="gbuffer/gbuffer.frag.glsl", defines={"NODE_PROGRAMS": 1})
    assert "NodeProgram" in layout(with_graphs).blocks
    compiled = shader_loader.compiles
    renderer.render(scene, top_down_camera(scale=1.9), settings)
    assert shader_loader.compiles == compiled


def renderer_gpu(renderer):
    return renderer.gpu_scene
