# SPDX-License-Identifier: GPL-3.0-or-later
"""Node programs at cube-map hits (trace_ray.glsl, include/cube_tangent.glsl): a
tangent-space Normal Map and a Bump whose Height reads the UV bend the normal where a mirror's
rays meet a ceiling beyond the near cube (HYBRID: a cube hit) as where they meet it in the BVH
(FULL_BVH) and as the camera sees it directly: the faces keep each texel's UV directions, and
the hit reads the UV where the ray meets the texel's plane. Each graph shows its normal as an
emission colour (normal * 0.5 + 0.5), so the images compare the normal itself."""
from __future__ import annotations

import math

import numpy as np
import pytest

from hybrid_engine.gpu import variants
from hybrid_engine.scene.camera import Camera, look_at
from hybrid_engine.scene.settings import RenderSettings
from hybrid_engine.scene.shader_graph import Link, ShaderGraph
from test_node_program_render import plane_scene
from test_textures import textured_quad, top_down_camera

CEILING_Z = 6.0
SIZE = 48
UV_TURN = math.radians(60.0)  # the UVs turned on the ceiling: its tangent is not an axis
MEAN_BAR, P99_BAR = 1e-3, 3e-3
BORDER = 3


def shown_normal(graph: ShaderGraph, normal: Link) -> ShaderGraph:
    """Emission of ``normal * 0.5 + 0.5``: the normal as a colour."""
    shown = graph.add("VECT_MATH", settings={"operation": "MULTIPLY_ADD"}, Vector=normal,
                      Vector_001=(0.5, 0.5, 0.5), Vector_002=(0.5, 0.5, 0.5))
    graph.surface = Link(graph.add("EMISSION", Color=Link(shown, "Vector"), Strength=1.0), "Emission")
    return graph


def tangent_normal_map() -> ShaderGraph:
    """A tangent-space Normal Map whose colour varies over the UV (a distorted Wave mixing two
    tilted normals)."""
    graph = ShaderGraph()
    uv = Link(graph.add("TEX_COORD"), "UV")
    wave = graph.add("TEX_WAVE", settings={"bands_direction": "DIAGONAL"}, Vector=uv, Scale=1.0, Distortion=4.0)
    mix = graph.add("MIX", settings={"data_type": "RGBA"}, Factor_Float=Link(wave, "Fac"),
                    A_Color=(0.2, 0.7, 0.8, 1.0), B_Color=(0.8, 0.35, 0.7, 1.0))
    normal_map = graph.add("NORMAL_MAP", settings={"space": "TANGENT"}, Color=Link(mix, "Result_Color"))
    return shown_normal(graph, Link(normal_map, "Normal"))


def uv_bump() -> ShaderGraph:
    """A Bump whose Height is a Noise of the UV."""
    graph = ShaderGraph()
    uv = Link(graph.add("TEX_COORD"), "UV")
    noise = graph.add("TEX_NOISE", Vector=uv, Scale=6.0, Detail=2.0)
    bump = graph.add("BUMP", Distance=0.3, Height=Link(noise, "Fac"))
    return shown_normal(graph, Link(bump, "Normal"))


GRAPHS = {"normal map": tangent_normal_map, "bump": uv_bump}


def ceiling() -> tuple[np.ndarray, np.ndarray]:
    """A 2 m square at CEILING_Z facing down, its UVs turned by UV_TURN about their centre."""
    tris, uvs = textured_quad((-1, -1, CEILING_Z), (0, 2, 0), (2, 0, 0), (0.0, 0.0), (1.0, 1.0))
    c, s = math.cos(UV_TURN), math.sin(UV_TURN)
    centred = uvs - 0.5
    turned = np.stack([c * centred[..., 0] - s * centred[..., 1], s * centred[..., 0] + c * centred[..., 1]], -1)
    return tris, (turned + 0.5).astype(np.float32)


def mirrored(renderer, graph: ShaderGraph, mode: str) -> np.ndarray:
    """The ceiling in a mirror floor at z = 0, seen from above at z = 3: with a near cube of
    half-size 1 the ceiling lies in the cube map in HYBRID."""
    floor, floor_uvs = textured_quad((-4, -4, 0), (8, 0, 0), (0, 8, 0), (0.0, 0.0), (1.0, 1.0))
    tris, uvs = ceiling()
    rows = [dict(base_color=(1.0, 1.0, 1.0), reflectivity=1.0, roughness=0.0), dict()]
    scene = plane_scene([(floor, floor_uvs, 0), (tris, uvs, 1)], [None, graph], rows)
    settings = RenderSettings(mode=mode, near_size=1.0, cube_far=20.0, cube_resolution=256, max_depth=1)
    return renderer.render(scene, top_down_camera(size=SIZE, scale=1.6), settings).image[..., :3]


def direct(renderer, graph: ShaderGraph) -> np.ndarray:
    """The ceiling seen from below by the mirror image of the camera above, flipped to the
    mirror's view (a camera looking up has x to its left)."""
    tris, uvs = ceiling()
    camera = Camera(matrix_world=look_at((0, 0, -3), (0, 0, 0), up=(0, 1, 0)), width=SIZE, height=SIZE,
                    projection="ORTHO", ortho_scale=1.6, clip_start=0.1, clip_end=20.0)
    image = renderer.render(plane_scene([(tris, uvs, 0)], [graph]), camera, RenderSettings(mode="RASTER")).image
    return image[:, ::-1, :3]


def inner(image: np.ndarray) -> np.ndarray:
    return image[BORDER:-BORDER, BORDER:-BORDER].astype(np.float64)


def difference(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    d = np.abs(inner(a) - inner(b))
    return float(d.mean()), float(np.percentile(d, 99))


@pytest.fixture
def trace_variant(request):
    variants.set_override(f"trace={request.param}")
    yield request.param
    variants.set_override(None)


@pytest.mark.parametrize("trace_variant", ["cpu", "gpu"], indirect=True)
@pytest.mark.parametrize("graph", sorted(GRAPHS))
def test_a_uv_bent_normal_at_a_cube_hit_matches_the_bvh_hit_and_the_direct_view(renderer, trace_variant, graph):
    """The megakernel ("cpu") and the waves ("gpu", whose hit records carry the frame)."""
    seen = direct(renderer, GRAPHS[graph]())
    assert inner(seen).std(axis=(0, 1)).max() > 0.02, "the graph bends no normal"
    cube = mirrored(renderer, GRAPHS[graph](), "HYBRID")
    bvh = mirrored(renderer, GRAPHS[graph](), "FULL_BVH")
    for name, image in (("cube map", cube), ("BVH", bvh)):
        mean, p99 = difference(image, seen)
        assert mean <= MEAN_BAR and p99 <= P99_BAR, f"{graph}, {name} against the direct view: {mean:.4f}, {p99:.4f}"
    mean, p99 = difference(cube, bvh)
    assert mean <= MEAN_BAR and p99 <= P99_BAR, f"{graph}, cube map against BVH: {mean:.4f}, {p99:.4f}"
