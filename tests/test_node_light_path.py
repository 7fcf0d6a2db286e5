# SPDX-License-Identifier: GPL-3.0-or-later
"""Light Path (include/node_program.glsl NODE_OP_LIGHT_PATH) as Cycles sets it: Is Camera Ray
and Ray Depth where the camera sees a surface directly and where a mirror shows it, at the
tracer's BVH and cube-map hits. Is Shadow Ray, which only a shadow ray's view of a coverage
reads, is in tests/test_closure_alpha.py."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine.scene.settings import RenderSettings
from hybrid_engine.scene.shader_graph import Link, ShaderGraph
from test_node_program_render import plane_scene
from test_textures import textured_quad, top_down_camera


def light_path_emission() -> ShaderGraph:
    """Emission of (Is Camera Ray, Ray Depth / 2, 0.25)."""
    graph = ShaderGraph()
    path = graph.add("LIGHT_PATH")
    half = graph.add("MATH", settings={"operation": "MULTIPLY"}, Value=Link(path, "Ray Depth"), Value_001=0.5)
    color = graph.add("COMBINE_COLOR", Red=Link(path, "Is Camera Ray"), Green=Link(half, "Value"), Blue=0.25)
    graph.surface = Link(graph.add("EMISSION", Color=Link(color, "Color"), Strength=1.0), "Emission")
    return graph


def test_the_camera_sees_a_surface_with_is_camera_ray_and_depth_0(renderer):
    tris, uvs = textured_quad((-1, -1, 0), (2, 0, 0), (0, 2, 0), (0.0, 0.0), (1.0, 1.0))
    image = renderer.render(plane_scene([(tris, uvs, 0)], [light_path_emission()]), top_down_camera(scale=1.9),
                            RenderSettings(mode="RASTER")).image[..., :3]
    np.testing.assert_allclose(image, np.broadcast_to([1.0, 0.0, 0.25], image.shape), atol=2e-3)


@pytest.mark.parametrize("trace_variant", ["cpu", "gpu"], indirect=True)
@pytest.mark.parametrize(("ceiling_z", "near_size"), [(4.0, 5.0), (6.0, 1.0)], ids=["bvh", "cube_map"])
def test_a_mirror_shows_a_surface_with_ray_depth_1_and_not_a_camera_ray(renderer, trace_variant, ceiling_z,
                                                                         near_size):
    """A mirror floor seen from above shows the ceiling over the camera (test_node_program_render
    mirror_scene's layout), met in the BVH or in the cube map."""
    floor, floor_uvs = textured_quad((-4, -4, 0), (8, 0, 0), (0, 8, 0), (0.0, 0.0), (1.0, 1.0))
    ceiling, ceiling_uvs = textured_quad((-1, -1, ceiling_z), (0, 2, 0), (2, 0, 0), (0.0, 0.0), (1.0, 1.0))
    rows = [dict(base_color=(1.0, 1.0, 1.0), reflectivity=1.0, roughness=0.0), dict()]
    scene = plane_scene([(floor, floor_uvs, 0), (ceiling, ceiling_uvs, 1)], [None, light_path_emission()], rows)
    settings = RenderSettings(mode="HYBRID", near_size=near_size, cube_far=20.0, cube_resolution=256, max_depth=1)
    image = renderer.render(scene, top_down_camera(size=48, scale=1.6), settings).image[..., :3]
    np.testing.assert_allclose(image, np.broadcast_to([0.0, 0.5, 0.25], image.shape), atol=0.01)
