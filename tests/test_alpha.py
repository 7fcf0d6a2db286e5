# SPDX-License-Identifier: GPL-3.0-or-later
"""Alpha as Blender defines it (gpu_shaders/include/alpha.glsl): a leaf card's holes are
holes in the G-buffer, the shadow maps, the BVH's any-hit traversal and the cube map; a
plane of Alpha 0.3 covers 30 % of its pixels over samples; an opaque scene compiles none of
it. The Cycles comparisons through Blender's render path are at the end."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine import Camera, Geometry, Lights, MaterialTable, RenderSettings, SceneData, Sky
from hybrid_engine.gpu import shader_loader
from hybrid_engine.scene.camera import look_at
from test_textures import textured_quad

SMALL = dict(cube_resolution=64, shadow_resolution=2048, near_size=4.0, shadow_cascades=0)
DISC_RADIUS = 0.35  # in UV units, around the UV square's centre


def disc_image(size: int = 64) -> np.ndarray:
    """White RGBA whose alpha is 1 inside a disc around the centre and 0 elsewhere."""
    centres = (np.arange(size) + 0.5) / size - 0.5
    x, y = np.meshgrid(centres, centres)
    image = np.ones((size, size, 4), np.float32)
    image[..., 3] = (x * x + y * y <= DISC_RADIUS ** 2).astype(np.float32)
    return image


def card_scene(card_row: dict, floor_emission: float = 0.25, lights=(), floor_z: float = -1.0) -> SceneData:
    """A 2 x 2 card at z = 0 (material 0, UVs over [0, 1]^2) above a wide floor."""
    card, card_uv = textured_quad((-1, -1, 0), (2, 0, 0), (0, 2, 0), (0, 0), (1, 1))
    floor, floor_uv = textured_quad((-6, -6, floor_z), (12, 0, 0), (0, 12, 0), (0, 0), (1, 1))
    geo = Geometry.from_objects([(card, None, 0), (floor, None, 1)])
    geo = Geometry(geo.triangles, geo.normals, geo.material_ids, geo.object_ranges, geo.object_bounds,
                   geo.object_names, uvs=np.concatenate([card_uv, floor_uv]))
    floor_row = dict(base_color=(0.0, 0.0, 0.0), emission=(floor_emission,) * 3) if not lights else \
        dict(base_color=(0.8, 0.8, 0.8), specular=0.0)
    rows = [card_row, floor_row]
    return SceneData(geo, MaterialTable.from_rows(rows), Lights.from_rows(list(lights)), Sky(color=(0.0, 0.0, 0.0)))


def top_camera(size: int = 64) -> Camera:
    return Camera(matrix_world=look_at((0, 0, 5), (0, 0, 0), up=(0, 1, 0)), width=size, height=size,
                  projection="ORTHO", ortho_scale=2.0)


def disc_mask(size: int = 64) -> np.ndarray:
    """Where the card's pixel centres (the top view of top_camera) lie inside the disc."""
    centres = (np.arange(size) + 0.5) / size - 0.5
    x, y = np.meshgrid(centres, centres)
    return x * x + y * y <= DISC_RADIUS ** 2


EMISSIVE_CARD = dict(base_color=(0.0, 0.0, 0.0), emission=(1.0, 1.0, 1.0), alpha_texture=disc_image())


def test_a_leaf_cards_holes_show_what_lies_behind_in_the_primary_view(renderer):
    image = renderer.render(card_scene(EMISSIVE_CARD), top_camera(), RenderSettings(mode="RASTER", **SMALL)).image
    covered = image[..., 0] > 0.6
    assert np.isclose(image[~covered, 0], 0.25, atol=0.02).all()  # the floor, seen through the holes
    assert (covered != disc_mask()).mean() <= 0.02


def test_without_alpha_the_card_is_an_opaque_square(renderer):
    row = {k: v for k, v in EMISSIVE_CARD.items() if k != "alpha_texture"}
    image = renderer.render(card_scene(row), top_camera(), RenderSettings(mode="RASTER", **SMALL)).image
    assert (image[..., 0] > 0.6).all()


def test_a_plane_of_alpha_0_3_converges_to_30_percent_coverage(renderer):
    row = dict(base_color=(0.0, 0.0, 0.0), emission=(1.0, 1.0, 1.0), alpha=0.3)
    scene, camera = card_scene(row, floor_emission=0.0), top_camera(32)
    settings = RenderSettings(mode="RASTER", **SMALL)
    samples = [renderer.render(scene, camera, settings, sample=s).image[..., 0] for s in range(48)]
    first = samples[0]
    assert set(np.unique(np.round(first, 3))) <= {0.0, 1.0}  # one sample: dithered, all or nothing
    assert abs(first.mean() - 0.3) < 0.05
    mean = np.mean(samples, axis=0)
    assert abs(mean.mean() - 0.3) < 0.01
    # Each pixel converges on its own (fresh numbers per sample), not a fixed dither pattern.
    assert np.abs(mean - 0.3).max() < 0.3
    assert mean.std() < 0.1


def shadow_view(renderer, card_row: dict) -> np.ndarray:
    """The floor 3 units below and beside the card, where a sun at 45 degrees casts the
    card's shadow, seen from above (the card itself out of view); red channel."""
    sun = dict(kind="SUN", direction=(1, 0, -1), color=(3, 3, 3), radius=0.0)
    camera = Camera(matrix_world=look_at((3, 0, 5), (3, 0, -3), up=(0, 1, 0)), width=64, height=64,
                    projection="ORTHO", ortho_scale=2.0)
    scene = card_scene(card_row, lights=[sun], floor_z=-3.0)
    return renderer.render(scene, camera, RenderSettings(mode="RASTER", **SMALL)).image[..., 0]


def test_the_leaf_cards_shadow_has_its_holes(renderer):
    image = shadow_view(renderer, dict(base_color=(0.8, 0.8, 0.8), alpha_texture=disc_image()))
    lit = image > 0.5 * image.max()
    assert (lit != ~disc_mask()).mean() <= 0.02


def test_without_alpha_the_cards_shadow_is_a_square(renderer):
    image = shadow_view(renderer, dict(base_color=(0.8, 0.8, 0.8)))
    assert image[4:-4, 4:-4].max() < 0.02  # all in shadow (the edges: the shadow filter)
