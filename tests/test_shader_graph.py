# SPDX-License-Identifier: GPL-3.0-or-later
"""The flat shader graph: links only point backwards, and its topology key tells a value edit
from a change of shape."""
from __future__ import annotations

import pytest

from hybrid_engine.scene.shader_graph import Link, ShaderGraph, ShaderGraphError


def _graph(value: float, operation: str = "ADD") -> ShaderGraph:
    graph = ShaderGraph()
    coords = graph.add("TEX_COORD")
    math = graph.add("MATH", settings={"operation": operation}, Value=Link(coords, "UV"), Value_001=value)
    shader = graph.add("EMISSION", Color=Link(math, "Value"), Strength=1.0)
    graph.surface = Link(shader, "Emission")
    return graph


def test_a_link_to_a_later_node_is_rejected():
    graph = ShaderGraph()
    graph.add("MATH", Value=Link(1, "Value"))
    graph.add("VALUE")
    with pytest.raises(ShaderGraphError, match="not an earlier node"):
        graph.validate()
    _graph(0.5).validate()


def test_a_surface_link_to_a_missing_node_is_rejected():
    graph = _graph(0.5)
    graph.surface = Link(7, "BSDF")
    with pytest.raises(ShaderGraphError, match="missing node 7"):
        graph.validate()


def test_topology_key_ignores_constants_and_sees_settings_and_links():
    assert _graph(0.5).topology_key() == _graph(2.0).topology_key()
    assert _graph(0.5).topology_key() != _graph(0.5, "MULTIPLY").topology_key()
    relinked = _graph(0.5)
    relinked.nodes[1].inputs["Value_001"] = Link(0, "Object")
    assert relinked.topology_key() != _graph(0.5).topology_key()


def test_material_table_holds_one_graph_or_none_per_material():
    import numpy as np

    from hybrid_engine.scene.arrays import SceneDataError
    from hybrid_engine.scene.data import MaterialTable

    rows = dict(base_color=np.full((2, 3), 0.5), emission=np.zeros((2, 3)), reflectivity=[0, 0],
                transmission=[0, 0], ior=[1.5, 1.5], thickness=[0.5, 0.5])
    table = MaterialTable(**rows, node_graphs=[_graph(0.5), None])
    assert isinstance(table.node_graphs[0], ShaderGraph) and table.node_graphs[1] is None
    with pytest.raises(SceneDataError, match="2 entries, expected|1 entries, expected 2"):
        MaterialTable(**rows, node_graphs=[None])
    with pytest.raises(SceneDataError, match="not a ShaderGraph"):
        MaterialTable(**rows, node_graphs=[None, "graph"])


def test_the_addons_graphs_are_the_top_level_compilers_graphs(addon):
    """Scripts and benchmarks import the core as ``hybrid_engine`` beside the add-on's copy:
    a graph the add-on's reader builds must compile with either."""
    from hybrid_engine.scene import node_program, shader_graph

    theirs = addon.hybrid_engine.scene.shader_graph
    assert theirs.Link is shader_graph.Link and theirs.ShaderGraph is shader_graph.ShaderGraph
    graph = theirs.ShaderGraph()
    coords = graph.add("TEX_COORD")
    shader = graph.add("EMISSION", Color=theirs.Link(coords, "UV"), Strength=1.0)
    graph.surface = theirs.Link(shader, "Emission")
    assert len(node_program.compile_graph(graph).words) > 0
