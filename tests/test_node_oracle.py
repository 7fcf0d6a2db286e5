# SPDX-License-Identifier: GPL-3.0-or-later
"""The node oracle's two sides line up: Cycles' plane pixel and the GLSL probe's point are
the same object coordinate, so a node compared through them differs only in arithmetic."""
from __future__ import annotations

import numpy as np

from node_oracle import cycles_emission_plane, glsl_probe, plane_points


def test_cycles_probe_plane_shows_the_object_coordinates_the_glsl_probe_is_given(addon, ctx, tmp_path):
    size, extent = 32, 3.0
    cycles = cycles_emission_plane(lambda nodes, links, vector: vector, tmp_path, size, extent)
    glsl = glsl_probe(ctx, [], "return vec4(p.xyz, 1.0);", plane_points(size, extent))
    assert cycles.shape == (size, size, 3)
    np.testing.assert_allclose(cycles, glsl[..., :3], atol=1e-5)
    assert cycles[0, 0, 0] < 0 < cycles[-1, -1, 0]  # row 0 is the bottom, column 0 the left
