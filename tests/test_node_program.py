# SPDX-License-Identifier: GPL-3.0-or-later
"""The node-program compiler (scene/node_program.py): the words of small graphs, register
reuse, a graph too big for the register file, and the table's packing. No GL needed."""
from __future__ import annotations

import re
import struct
from pathlib import Path

import numpy as np
import pytest

from hybrid_engine.scene import node_codes as nc
from hybrid_engine.scene.node_program import (CLOSURE_REGISTERS, DISPATCH_NONE, NodeProgramError, compile_graph,
                                              compile_table,
                                              row_estimate)
from hybrid_engine.scene.shader_graph import Link, ShaderGraph

GLSL = Path(__file__).resolve().parents[1] / "gpu_shaders" / "include" / "node_program.glsl"


def f(value: float) -> int:
    return struct.unpack("<I", struct.pack("<f", value))[0]


def emission_of_uv(strength: float = 2.0) -> ShaderGraph:
    graph = ShaderGraph()
    coords = graph.add("TEX_COORD")
    shader = graph.add("EMISSION", Color=Link(coords, "UV"), Strength=strength)
    graph.surface = Link(shader, "Emission")
    return graph


def test_an_emission_of_the_uv_compiles_to_three_instructions_with_its_constant_inline():
    words = compile_graph(emission_of_uv(2.0)).words.tolist()
    no = nc.NO_REGISTER
    coord = [nc.OP_TEX_COORD | 7 << 8, no, no, 0, no, no, no, no]  # only UV is read: register 0
    # Emission's closure goes to registers 0-5: the UV's register is free once Emission read it.
    emission = [nc.OP_EMISSION | 6 << 8 | 2 << 24, 0, 1, 2, 3, 4, 5, nc.REGISTER | 0, nc.CONSTANT | 1, f(2.0)]
    output = [nc.OP_OUTPUT | 6 << 24, 0, 1, 2, 3, 4, 5]
    assert words == coord + emission + output


def test_a_value_edit_changes_only_the_constant_words():
    a, b = compile_graph(emission_of_uv(2.0)).words, compile_graph(emission_of_uv(5.0)).words
    assert len(a) == len(b)
    differ = np.flatnonzero(a != b)
    assert differ.tolist() == [int(np.flatnonzero(a == f(2.0))[0])] and b[differ[0]] == f(5.0)


def test_an_unlinked_normal_reads_the_shading_normal_and_a_colour_into_a_float_its_luminance():
    graph = ShaderGraph()
    rgb = graph.add("RGB", settings={"value": (1.0, 0.0, 0.0, 1.0)})
    fresnel = graph.add("FRESNEL", IOR=Link(rgb, "Color"))
    diffuse = graph.add("BSDF_DIFFUSE", Color=Link(fresnel, "Fac"))
    graph.surface = Link(diffuse, "BSDF")
    words = compile_graph(graph).words.tolist()
    assert nc.IMPLICIT | nc.IMPLICIT_NORMAL in words  # Fresnel's and Diffuse's Normal
    assert nc.REGISTER | nc.CONVERT_GRAY << 16 | 0 in words  # the colour into IOR
    assert nc.REGISTER | nc.CONVERT_SPLAT << 16 | 0 in words  # the factor into Color


def test_registers_are_reused_once_a_values_last_reader_has_run():
    """A chain of 200 Combine XYZ nodes, each reading the last: two registers at most,
    however long the chain."""
    graph = ShaderGraph()
    last = graph.add("VALUE", settings={"value": 0.25})
    for _ in range(200):
        last = graph.add("COMBXYZ", X=Link(last, "Vector" if graph.nodes[last].kind == "COMBXYZ" else "Value"))
    shader = graph.add("EMISSION", Color=Link(last, "Vector"))
    graph.surface = Link(shader, "Emission")
    program = compile_graph(graph)
    assert program.registers <= CLOSURE_PLUS_ONE


CLOSURE_PLUS_ONE = 7  # Emission's closure (six registers) while its colour is still read


def values_all_live(count: int) -> ShaderGraph:
    """``count`` Value nodes made first and read only afterwards, one Combine XYZ each that
    pairs it with the last value: all of them are live together."""
    graph = ShaderGraph()
    values = [graph.add("VALUE", settings={"value": float(i)}) for i in range(count)]
    sums = [graph.add("COMBXYZ", X=Link(v, "Value"), Y=Link(values[-1], "Value")) for v in values]
    total = graph.add("EMISSION", Color=Link(sums[0], "Vector"))
    for s in sums[1:]:
        shader = graph.add("EMISSION", Color=Link(s, "Vector"))
        out = "Emission" if graph.nodes[total].kind == "EMISSION" else "Shader"
        total = graph.add("ADD_SHADER", Shader=Link(total, out), Shader_001=Link(shader, "Emission"))
    graph.surface = Link(total, "Shader")
    return graph


def test_a_graph_with_more_live_values_than_registers_fails_with_its_name():
    assert compile_graph(values_all_live(20)).registers <= nc.REGISTERS
    with pytest.raises(NodeProgramError, match=r"lacquer: .*more than 32 values"):
        compile_graph(values_all_live(40), "lacquer")


def test_nodes_the_output_does_not_reach_are_left_out_and_unknown_kinds_are_listed():
    graph = emission_of_uv()
    graph.add("TEX_NOISE")  # not reached
    program = compile_graph(graph)
    assert program.unsupported == []
    graph = ShaderGraph()
    mystery = graph.add("TEX_SKY_OF_MARS")
    shader = graph.add("EMISSION", Color=Link(mystery, "Color"))
    graph.surface = Link(shader, "Emission")
    program = compile_graph(graph)
    assert program.unsupported == ["TEX_SKY_OF_MARS"]
    assert nc.CONSTANT | 4 in program.words.tolist()  # Emission's Color: Blender's default, white


def test_a_table_packs_programs_after_one_another_with_an_offset_per_material():
    a, b = emission_of_uv(1.0), emission_of_uv(3.0)
    table = compile_table([a, None, b], 3)
    n = len(compile_graph(a).words)
    assert table.offsets.tolist() == [1, -1, n + 2]  # each after its dispatch word
    assert table.words[0] == table.words[n + 1] == DISPATCH_NONE
    assert table.words[n + 2] == table.words[1]  # the second program's first header
    assert compile_table(None, 2).empty and compile_table([None, None], 2).empty


def test_the_rows_estimate_of_a_glass_mix_and_an_emission():
    graph = ShaderGraph()
    glass = graph.add("BSDF_GLASS", IOR=1.33)
    diffuse = graph.add("BSDF_DIFFUSE")
    mix = graph.add("MIX_SHADER", Fac=0.25, Shader=Link(glass, "BSDF"), Shader_001=Link(diffuse, "BSDF"))
    graph.surface = Link(mix, "Shader")
    estimate = row_estimate(graph)
    assert estimate["transmission"] == pytest.approx(0.75) and estimate["ior"] > 1.0
    assert row_estimate(emission_of_uv())["emission"] == pytest.approx((2.0, 2.0, 2.0))  # UV: unknown, white


def test_the_interpreters_opcodes_are_the_compilers():
    text = GLSL.read_text()
    defined = {name: int(value) for name, value in re.findall(r"#define NODE_OP_(\w+) (\d+)u", text)}
    assert defined == {name[3:]: value for name, value in nc.OPCODES.items()}
    assert f"#define NODE_REGISTERS {nc.REGISTERS}" in text
    assert f"#define NODE_CLOSURE_REGISTERS {CLOSURE_REGISTERS}" in text
