# SPDX-License-Identifier: GPL-3.0-or-later
"""Generated GLSL for node programs (passes/scene_upload/node_codegen.py): one function per
program topology, values read from the words, the interpreter's cases as its code. The
generated path renders what the interpreter renders, a value edit compiles nothing, a
topology edit compiles each program that runs node programs once, and what the generator
cannot follow stays with the interpreter."""
from __future__ import annotations

import numpy as np
import pytest

from benchmarks.node_cost import mirror_box, sphere, twenty_node_graph
from hybrid_engine.gpu import shader_loader
from hybrid_engine.passes.scene_upload import node_codegen as cg
from hybrid_engine.scene import node_codes as nc
from hybrid_engine.scene.camera import Camera, look_at
from hybrid_engine.scene.data import Lights, MaterialTable, SceneData, Sky
from hybrid_engine.scene.geometry import Geometry
from hybrid_engine.scene.node_program import DISPATCH_NONE, compile_table
from hybrid_engine.scene.settings import RenderSettings
from hybrid_engine.scene.shader_graph import Link, ShaderGraph


def emission(strength: float, blend: str = "MULTIPLY", linked: bool = True) -> ShaderGraph:
    graph = ShaderGraph()
    coords = graph.add("TEX_COORD")
    mix = graph.add("MIX", settings={"data_type": "RGBA", "blend_type": blend}, Factor_Float=0.5,
                    A_Color=Link(coords, "UV") if linked else (0.2, 0.3, 0.4, 1.0), B_Color=(0.9, 0.5, 0.1, 1.0))
    graph.surface = Link(graph.add("EMISSION", Color=Link(mix, "Result_Color"), Strength=strength), "Emission")
    return graph


# -- the generator, without GL ------------------------------------------------------------------
def test_every_opcode_the_compiler_emits_has_an_interpreter_case_the_generator_reads():
    cases = cg.interpreter_cases()
    missing = sorted(name for name, op in nc.OPCODES.items() if op != nc.OP_OUTPUT and op not in cases)
    assert missing == []


def test_a_case_keeps_the_preprocessor_branches_around_it():
    """A family's case compiles only under its define, in generated code as in the
    interpreter; an #else branch is the opposite condition."""
    cases = cg.interpreter_cases()
    assert [c.conditions for c in cases[nc.OP_MATH]] == [("#ifdef " + nc.FAMILY_VECTOR,)]
    assert [c.conditions for c in cases[nc.OP_ATTRIBUTE]] == [("#ifdef NODE_ATTRIBUTES",), ("#ifndef NODE_ATTRIBUTES",)]
    assert [c.conditions for c in cases[nc.OP_BSDF_PRINCIPLED]] == [()]


def test_values_and_enums_share_a_topology_and_a_new_link_makes_another():
    table = compile_table([emission(1.0), emission(7.0, "SCREEN"), emission(1.0, linked=False)], 3)
    generated = cg.generate(table)
    assert generated.dispatch.tolist() == [0, 0, 1]
    assert generated.topologies == 2 and generated.complete
    # The same topologies give the same source whatever the values: a value edit compiles nothing.
    again = cg.generate(compile_table([emission(2.5, "ADD"), emission(0.1), emission(4.0, linked=False)], 3))
    assert again.source == generated.source


def test_topologies_past_the_scenes_budget_of_instructions_stay_with_the_interpreter(monkeypatch):
    monkeypatch.setattr(cg, "MAX_GENERATED_INSTRUCTIONS", 4)  # one emission program: 3
    generated = cg.generate(compile_table([emission(1.0), emission(1.0, linked=False), emission(3.0)], 3))
    assert generated.dispatch.tolist() == [0, DISPATCH_NONE, 0]
    assert generated.topologies == 1 and not generated.complete


def test_a_program_with_an_opcode_the_generator_lacks_stays_with_the_interpreter():
    cases = {op: found for op, found in cg.interpreter_cases().items() if op != nc.OP_MIX}
    table = compile_table([emission(1.0), twenty_node_graph()], 2)
    generated = cg.generate(table, cases)
    assert generated.dispatch.tolist() == [DISPATCH_NONE, DISPATCH_NONE]
    assert not generated.complete and generated.topologies == 0


def test_the_generated_code_reads_constants_from_the_words_and_keeps_registers_named():
    generated = cg.generate(compile_table([twenty_node_graph()], 1))
    body = generated.bodies[0]
    assert "node_reg" not in body and "node_operand" not in body
    assert "uintBitsToFloat(node_words[g_at + " in body
    assert body.count("do {") >= 20  # every node of the graph written out


def test_an_output_nobody_reads_is_left_out_of_the_generated_code():
    """A Noise's Color is two fractal sums more than its Fac, and Generated and Object each
    search the instance table: the generated code computes an output only where a later node
    reads it, as Cycles' SVM does (``node_output_read`` becomes a constant of the topology; the
    Noise's Color is asked of its register word at run time, node_program.glsl says why)."""
    def noise_into_emission(output: str) -> str:
        graph = ShaderGraph()
        coords = graph.add("TEX_COORD")
        noise = graph.add("TEX_NOISE", Vector=Link(coords, "Object"), Scale=4.0)
        graph.surface = Link(graph.add("EMISSION", Color=Link(noise, output)), "Emission")
        return cg.generate(compile_table([graph], 1)).source

    fac_only, colour = noise_into_emission("Fac"), noise_into_emission("Color")
    assert "node_output_read" not in fac_only + colour
    for source in (fac_only, colour):  # the Noise asks whether its Color is read
        assert source.count("bool color_read = node_words[set_at - 1u] < uint(NODE_REGISTERS);") == 1
        assert "color_read ? 3 : 1" in source
    # Texture Coordinate: only Object (output 3) is read, so Generated's search is dropped.
    assert "if (false) g_out0 = vec4(node_generated(sp), 0.0);" in fac_only
    assert "if (true) g_out3 = " in fac_only


# -- through the renderer -------------------------------------------------------------------------
@pytest.fixture
def nodes_variant(request, renderer):
    """"generated" (the default) or "interpreter" for the module's renderer."""
    renderer.gpu_scene.node_programs.generate = request.param == "generated"
    yield request.param
    renderer.gpu_scene.node_programs.generate = None


def textured_graphs() -> list[ShaderGraph]:
    """Four materials: textures through ramps and maths, a Mix Shader by Layer Weight, a Bump
    of a Noise, a Brick and a Checker; the benchmark's 20-node graph."""
    a = ShaderGraph()
    checker = a.add("TEX_CHECKER", Scale=3.0)
    diffuse = a.add("BSDF_DIFFUSE", Color=Link(checker, "Color"))
    glossy = a.add("BSDF_GLOSSY", Color=(0.9, 0.9, 0.9, 1.0), Roughness=0.1)
    weight = a.add("LAYER_WEIGHT", Blend=0.4)
    mix = a.add("MIX_SHADER", Fac=Link(weight, "Facing"), Shader=Link(diffuse, "BSDF"), Shader_001=Link(glossy, "BSDF"))
    a.surface = Link(mix, "Shader")

    b = ShaderGraph()
    noise = b.add("TEX_NOISE", Scale=6.0, Detail=3.0)
    bump = b.add("BUMP", Strength=0.8, Distance=0.2, Height=Link(noise, "Fac"))
    brick = b.add("TEX_BRICK", Scale=4.0)
    ramp_table = np.concatenate([np.linspace([0.1, 0.2, 0.6], [0.9, 0.6, 0.2], 257), np.ones((257, 1))], 1)
    ramp = b.add("VALTORGB", settings={"color_ramp": ramp_table.astype(np.float32)}, Fac=Link(brick, "Fac"))
    principled = b.add("BSDF_PRINCIPLED", **{"Base Color": Link(ramp, "Color"), "Normal": Link(bump, "Normal"),
                                             "Roughness": 0.3, "Metallic": 0.5})
    b.surface = Link(principled, "BSDF")

    c = ShaderGraph()
    wave = c.add("TEX_WAVE", Scale=2.0, Distortion=3.0)
    voronoi = c.add("TEX_VORONOI", Scale=5.0)
    glow = c.add("EMISSION", Color=Link(wave, "Color"), Strength=0.6)
    glass = c.add("BSDF_GLOSSY", Color=Link(voronoi, "Color"), Roughness=0.05)
    add = c.add("ADD_SHADER", Shader=Link(glow, "Emission"), Shader_001=Link(glass, "BSDF"))
    c.surface = Link(add, "Shader")
    return [a, b, c, twenty_node_graph()]


def textured_scene() -> SceneData:
    box = mirror_box(2.0)
    ball, ball_n = sphere(0.9, 24, 12)
    objects = [(box[0:4], None, 0), (box[4:8], None, 1), (box[8:12], None, 2), (ball, ball_n, 3)]
    geo = Geometry.from_objects(objects, names=["x", "y", "z", "ball"])
    table = MaterialTable.from_rows([dict(base_color=(0.8, 0.8, 0.8)) for _ in range(4)])
    table.node_graphs = textured_graphs()
    lights = Lights.from_rows([dict(kind="POINT", position=(1.0, -1.0, 1.2), color=(40.0, 40.0, 40.0), radius=0.1)])
    return SceneData(geo, table, lights, Sky(color=(0.1, 0.1, 0.1)))


CAMERA = Camera(matrix_world=look_at((0.4, -1.9, 0.5), (0.0, 0.0, 0.0)), width=48, height=32, lens=20.0,
                clip_start=0.05, clip_end=20.0)
SETTINGS = RenderSettings(mode="HYBRID", max_depth=2, near_size=1.0)
_images: dict[str, np.ndarray] = {}


@pytest.mark.parametrize("nodes_variant", ["interpreter", "generated"], indirect=True)
def test_generated_code_renders_what_the_interpreter_renders(renderer, nodes_variant):
    """The same scene (G-buffer, BVH and cube-map hits, bounces) both ways; generated, every
    program has its function, so the interpreter is not even compiled in."""
    image = renderer.render(textured_scene(), CAMERA, SETTINGS).image
    defines = renderer.gpu_scene.defines
    assert ("NODE_GENERATED_ONLY" in defines) == (nodes_variant == "generated")
    assert image[..., :3].std() > 0.05
    _images[nodes_variant] = image
    if len(_images) == 2:
        generated, interpreted = _images["generated"], _images["interpreter"]
        np.testing.assert_allclose(generated, interpreted, atol=2e-3)
        assert np.abs(generated - interpreted).mean() < 1e-5


def assert_compiled_once(renderer, scene, key: str, compiled: int) -> None:
    """The edit just rendered made a new topology (not ``key``) and compiled each program that
    runs node programs once since ``compiled`` compiles, and the next frame compiles nothing."""
    new_key = renderer.gpu_scene.defines["NODE_GENERATED"]
    assert new_key != key

    def programs_with(k: str) -> int:
        return len([c for c in shader_loader._cache if ("NODE_GENERATED", k) in c[2]])
    assert 0 < shader_loader.compiles - compiled == programs_with(new_key) <= programs_with(key)
    renderer.render(scene, CAMERA, SETTINGS)
    assert shader_loader.compiles - compiled == programs_with(new_key)  # once, not every frame


@pytest.mark.parametrize("nodes_variant", ["generated"], indirect=True)
def test_a_value_edit_compiles_nothing_and_a_topology_edit_each_program_once(renderer, nodes_variant):
    graphs = [emission(1.0), emission(2.0)]
    scene = textured_scene()
    scene.materials.node_graphs = [graphs[0], graphs[1], None, None]
    renderer.render(scene, CAMERA, SETTINGS)
    key = renderer.gpu_scene.defines["NODE_GENERATED"]
    compiled = shader_loader.compiles
    graphs[0].nodes[2].inputs["Strength"] = 5.0   # a value
    graphs[1].nodes[1].settings["blend_type"] = "SCREEN"  # an enum
    before = renderer.render(scene, CAMERA, SETTINGS).image
    assert shader_loader.compiles == compiled
    assert renderer.gpu_scene.defines["NODE_GENERATED"] == key
    # A new link (the UV's mean as the factor): a new topology, the same closure estimate.
    graphs[1].nodes[1].inputs["Factor_Float"] = Link(0, "UV")
    after = renderer.render(scene, CAMERA, SETTINGS).image
    assert np.abs(after - before).max() > 0.01
    assert_compiled_once(renderer, scene, key, compiled)


# -- settings that change a node's sockets ---------------------------------------------------------
def textures_with(noise: dict | None = None, voronoi: dict | None = None, white: dict | None = None) -> str:
    """Generated source of one material: a Noise, a White Noise and a Voronoi summed into an
    emission, with the given settings."""
    graph = ShaderGraph()
    a = graph.add("TEX_NOISE", settings=dict(noise or {}), Scale=4.0)
    b = graph.add("TEX_WHITE_NOISE", settings=dict(white or {}))
    c = graph.add("TEX_VORONOI", settings=dict(voronoi or {}), Scale=3.0)
    ab = graph.add("MATH", settings={"operation": "ADD"}, Value=Link(a, "Fac"), Value_001=Link(b, "Value"))
    abc = graph.add("MATH", settings={"operation": "ADD"}, Value=Link(ab, "Value"), Value_001=Link(c, "Distance"))
    graph.surface = Link(graph.add("EMISSION", Strength=Link(abc, "Value")), "Emission")
    return cg.generate(compile_table([graph], 1)).source


def test_a_setting_that_changes_sockets_is_a_literal_of_the_topology_and_others_stay_words():
    """Noise's and White Noise's dimensions, Noise's type, Voronoi's dimensions, feature and
    metric show or hide sockets in Blender: each is a literal of the generated code (the
    driver compiles only its branch), so an edit is a new topology. Noise's normalize and
    Voronoi's normalize change no socket: read from the words, one topology."""
    base = textures_with()
    assert "node_tex_noise_channels(int(3u), int(0u), int(node_words[set_at + 2u])" in base
    assert "node_tex_white_noise(int(3u)," in base
    assert "node_tex_voronoi(int(3u), int(0u), int(0u),\n" in base
    for edit in (dict(noise={"noise_dimensions": "2D"}), dict(noise={"noise_type": "RIDGED_MULTIFRACTAL"}),
                 dict(white={"noise_dimensions": "4D"}), dict(voronoi={"voronoi_dimensions": "1D"}),
                 dict(voronoi={"feature": "F2"}), dict(voronoi={"distance": "MINKOWSKI"})):
        assert textures_with(**edit) != base, edit
    assert textures_with(noise={"normalize": False}, voronoi={"normalize": True}) == base


def test_wave_settings_change_no_socket_and_stay_words():
    def wave(settings: dict) -> str:
        graph = ShaderGraph()
        w = graph.add("TEX_WAVE", settings=settings)
        graph.surface = Link(graph.add("EMISSION", Color=Link(w, "Color")), "Emission")
        return cg.generate(compile_table([graph], 1)).source
    base = wave({})
    assert "node_tex_wave(int(node_words[set_at]), int(node_words[set_at + 1u])" in base
    assert wave({"wave_type": "RINGS", "bands_direction": "Y", "wave_profile": "SAW"}) == base


def socket_edited(scene: SceneData) -> SceneData:
    """``scene`` with its Bump's Noise in 2D ridged, its Voronoi 2D F2 under Minkowski."""
    noise = scene.materials.node_graphs[1].nodes[0]
    voronoi = scene.materials.node_graphs[2].nodes[1]
    noise.settings.update(noise_dimensions="2D", noise_type="RIDGED_MULTIFRACTAL")
    voronoi.settings.update(voronoi_dimensions="2D", feature="F2", distance="MINKOWSKI")
    return scene


_socket_images: dict[str, np.ndarray] = {}


@pytest.mark.parametrize("nodes_variant", ["interpreter", "generated"], indirect=True)
def test_generated_code_with_socket_settings_as_literals_renders_what_the_interpreter_renders(
        renderer, nodes_variant):
    image = renderer.render(socket_edited(textured_scene()), CAMERA, SETTINGS).image
    if nodes_variant == "generated":  # the literals are what ran
        source = renderer.gpu_scene.node_programs.generated.source
        assert "node_tex_noise_channels(int(2u), int(3u)," in source
        assert "node_tex_voronoi(int(2u), int(1u), int(3u)," in source
    _socket_images[nodes_variant] = image
    if len(_socket_images) == 2:
        generated, interpreted = _socket_images["generated"], _socket_images["interpreter"]
        np.testing.assert_allclose(generated, interpreted, atol=2e-3)
        assert np.abs(generated - interpreted).mean() < 1e-5


@pytest.mark.parametrize("nodes_variant", ["generated"], indirect=True)
def test_a_socket_setting_edit_compiles_each_program_once_and_a_wave_enum_edit_nothing(renderer, nodes_variant):
    scene = textured_scene()
    before = renderer.render(scene, CAMERA, SETTINGS).image
    key = renderer.gpu_scene.defines["NODE_GENERATED"]
    compiled = shader_loader.compiles
    scene.materials.node_graphs[2].nodes[0].settings["wave_type"] = "RINGS"  # no socket changes
    waves = renderer.render(scene, CAMERA, SETTINGS).image
    assert shader_loader.compiles == compiled and renderer.gpu_scene.defines["NODE_GENERATED"] == key
    assert np.abs(waves - before).max() > 0.01
    scene.materials.node_graphs[1].nodes[0].settings["noise_dimensions"] = "2D"  # W and Vector change
    after = renderer.render(scene, CAMERA, SETTINGS).image
    assert np.abs(after - waves).max() > 0.01
    assert_compiled_once(renderer, scene, key, compiled)
