# SPDX-License-Identifier: GPL-3.0-or-later
"""benchmarks/node_cost.py measures what it says: a graph of exactly 20 nodes, each of them
compiled and reached by the surface, on a box whose every face looks at the sphere inside."""
from __future__ import annotations

import numpy as np

from benchmarks import node_cost


def test_the_benchmark_graph_has_twenty_nodes_all_compiled_and_reaching_the_surface():
    facts = node_cost.program_facts()  # raises if the compiler leaves a node out
    assert facts["graph20_nodes"] == 20
    assert facts["graph20_nodes_reached"] == 20


def test_every_face_of_the_mirror_box_faces_its_centre():
    triangles = node_cost.mirror_box(2.0)
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    to_centre = -triangles.mean(axis=1)
    assert len(triangles) == 12
    assert (np.einsum("ij,ij->i", normals, to_centre) > 0).all()
