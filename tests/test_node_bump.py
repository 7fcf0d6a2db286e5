# SPDX-License-Identifier: GPL-3.0-or-later
"""The Bump node (node_program.py ``_bump_steps``, node_program.glsl ``node_bump``): its
Height sub-graph runs at the shading point and one filter width along the footprint's two
axes, and the three heights bend the normal as Cycles' bump does. Held to Cycles through
Blender's render path on sun-lit planes, and to its own primary view in a HYBRID mirror
(the ray hits' footprint)."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine.scene import node_codes as nc
from hybrid_engine.scene.node_program import compile_graph
from hybrid_engine.scene.shader_graph import Link, ShaderGraph
from normal_scenes import (bump_chain, difference, inner, mirror_scene, primary_and_mirrored, render_both,
                           row_scene, tile_pixels)

MEAN_BAR, P99_BAR = 0.01, 0.02


def _opcodes(words: np.ndarray) -> list[int]:
    """The opcodes of a program's instructions, in order (walking the headers)."""
    found, pc = [], 0
    while pc < len(words):
        header = int(words[pc])
        op, n_out, n_set, n_in = header & 0xFF, (header >> 8) & 0xFF, (header >> 16) & 0xFF, header >> 24
        found.append(op)
        pc += 1 + n_out + n_set
        for _ in range(n_in):
            word = int(words[pc])
            pc += 1 + (word & 7 if word & nc.CONSTANT else 0)
        if op == nc.OP_OUTPUT:
            break
    return found


def _bumped(height_linked: bool = True) -> ShaderGraph:
    graph = ShaderGraph()
    inputs = {}
    if height_linked:
        mapping = graph.add("MAPPING")
        noise = graph.add("TEX_NOISE", Vector=Link(mapping, "Vector"))
        inputs["Height"] = Link(noise, "Fac")
    bump = graph.add("BUMP", Distance=0.1, **inputs)
    graph.surface = Link(graph.add("BSDF_DIFFUSE", Normal=Link(bump, "Normal")), "BSDF")
    return graph


def test_a_bumps_height_sub_graph_runs_three_times_around_offset_instructions():
    ops = _opcodes(compile_graph(_bumped()).words)
    assert ops.count(nc.OP_TEX_NOISE) == 3 and ops.count(nc.OP_MAPPING) == 3
    offsets = [i for i, op in enumerate(ops) if op == nc.OP_BUMP_OFFSET]
    assert len(offsets) == 3  # along dP/dx, along dP/dy, back to the point
    assert offsets[-1] < ops.index(nc.OP_BUMP)
    # each shifted copy runs between its offset and the next one
    assert ops[offsets[0] + 1:offsets[1]] == [nc.OP_MAPPING, nc.OP_TEX_NOISE]
    assert ops[offsets[1] + 1:offsets[2]] == [nc.OP_MAPPING, nc.OP_TEX_NOISE]


def test_a_bump_without_a_height_link_compiles_no_shifted_copies():
    ops = _opcodes(compile_graph(_bumped(height_linked=False)).words)
    assert nc.OP_BUMP in ops and nc.OP_BUMP_OFFSET not in ops


CASES = {
    "noise": dict(kinds=("noise",)),
    "wave": dict(kinds=("wave",)),
    "chained": dict(kinds=("wave", "noise")),       # the second Bump's Normal from the first
    "half_inverted": dict(kinds=("noise",), strength=0.5, invert=True),
}
_rendered: dict[str, tuple[np.ndarray, np.ndarray]] = {}


@pytest.fixture
def sunlit(addon, tmp_path):
    """Both engines' render of a row of bumped Diffuse planes under a sun (once per module)."""
    import bpy

    if "row" not in _rendered:
        builds = {name: (lambda n, l, c=case: bump_chain(n, l, **c)) for name, case in CASES.items()}
        scene, _ = row_scene(bpy, builds, lit=True)
        _rendered["row"] = render_both(bpy, scene, tmp_path)
    return _rendered["row"]


@pytest.mark.parametrize("case", list(CASES))
def test_a_bumped_plane_lit_by_a_sun_matches_cycles(sunlit, case):
    ours, cycles = sunlit
    k = list(CASES).index(case)
    a, b = tile_pixels(ours, k), tile_pixels(cycles, k)
    assert b.std() > 0.01, f"{case}: Cycles shows no bump (std {b.std():.4f})"
    mean, p99 = difference(a, b)
    assert mean <= MEAN_BAR and p99 <= P99_BAR, f"{case}: mean {mean:.4f}, p99 {p99:.4f} against Cycles"


@pytest.mark.parametrize("tracer", ["cpu", "gpu"])
def test_a_bump_seen_in_a_hybrid_mirror_matches_its_primary_view(addon, tmp_path, monkeypatch, tracer):
    """The mirror's rays shade the tile at BVH hits, with the ray cone's footprint for dP:
    the bent normal (shown as a colour) is the primary view's, with either tracer (the wave
    tracer's hits carry the footprint through their records)."""
    import bpy

    monkeypatch.setenv("HYBRID_RT_KERNELS", f"trace={tracer}")

    scene, camera = mirror_scene(bpy, lambda n, l: bump_chain(n, l, ("noise",)))
    primary, mirrored = primary_and_mirrored(bpy, scene, camera, tmp_path)
    assert inner(primary)[..., :2].std() > 0.02  # the bump bends the normal
    mean, p99 = difference(inner(mirrored), inner(primary))
    assert mean <= MEAN_BAR and p99 <= P99_BAR, (mean, p99)


def test_a_bump_is_evaluated_and_not_reported_to_the_artist(addon):
    """The reader's list of nodes not evaluated yet (materials._graph_row) no longer names it."""
    import bpy

    material = bpy.data.materials.new("Bumpy")
    material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    bump = nodes.new("ShaderNodeBump")
    links.new(nodes.new("ShaderNodeTexNoise").outputs["Fac"], bump.inputs["Height"])
    links.new(bump.outputs["Normal"], nodes["Principled BSDF"].inputs["Normal"])
    materials = addon.blender_adapter.export.materials
    with addon.blender_adapter.messages.collecting() as told:
        row = materials.material_params(material)
    assert told == []
    assert "BUMP" in {n.kind for n in row["node_graph"].nodes}


def test_a_bump_whose_height_reads_a_colour_attribute_reads_it_in_every_shifted_copy():
    """The shifted copies of the Height's sub-graph are nodes the graph does not hold: an
    Attribute among them still finds its slot (the same as the original's)."""
    graph = ShaderGraph()
    colour = graph.add("VERTEX_COLOR", settings={"layer_name": "Paint"})
    bump = graph.add("BUMP", Distance=0.1, Height=Link(colour, "Fac"))
    graph.surface = Link(graph.add("BSDF_DIFFUSE", Normal=Link(bump, "Normal")), "BSDF")
    ops = _opcodes(compile_graph(graph).words)
    assert ops.count(nc.OP_ATTRIBUTE) == 3 and ops.count(nc.OP_BUMP) == 1
