# SPDX-License-Identifier: GPL-3.0-or-later
"""hybrid_engine/scene/solids.py: only closed, outward-wound surfaces qualify for back-face
culling, and culling them changes no image."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hybrid_engine.scene.geometry import InstancedGeometry
from hybrid_engine import RenderSettings
from hybrid_engine.frame.renderer import Renderer
from benchmarks.scenes.chess import box, build_chess, piece_templates, quad
from hybrid_engine.scene.solids import closed_outward

CUBE = box((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))


def test_a_box_is_closed_and_outward():
    assert closed_outward(CUBE)


@pytest.mark.parametrize("case", ["inward", "hole", "open_quad", "nan", "flipped_face", "mirrored"])
def test_surfaces_that_would_show_holes_when_culled_are_rejected(case):
    tris = CUBE.copy()
    if case == "inward":
        tris = tris[:, ::-1]
    elif case == "hole":
        tris = tris[1:]
    elif case == "open_quad":
        tris = quad((0, 0, 0), (1, 0, 0), (0, 1, 0))
    elif case == "nan":
        tris[3, 1, 2] = np.nan
    elif case == "flipped_face":
        tris[5] = tris[5][::-1]
    else:
        tris = tris * np.array([-1.0, 1.0, 1.0])  # a mirror keeps the winding, flips the outside
    assert not closed_outward(tris)


def test_separate_and_interpenetrating_closed_parts_count_as_closed():
    two = np.concatenate([CUBE, box((0.5, 0.5, 0.5), (2.0, 2.0, 2.0))])
    assert closed_outward(two)


@pytest.mark.parametrize("detail", [0.02, 1.0])
def test_every_chess_template_is_closed(detail):
    assert all(closed_outward(tris) for tris, _ in piece_templates(detail).values())


def test_chess_marks_pieces_and_spheres_closed_and_boards_open():
    scene, _ = build_chess(0.02, 0, 32, 18)
    geo = scene.geometry
    closed = dict(zip(geo.object_names, geo.object_closed))
    assert not closed["floor"]
    assert not closed["board_0"] and closed["sphere_0"]
    assert sum(closed.values()) == len(closed) - 1 - 2 * 9  # all but floor, boards and frames


@pytest.mark.parametrize("mode", ["RASTER", "HYBRID"])
def test_culling_back_faces_of_closed_objects_leaves_the_image_unchanged(gl, mode):
    scene, camera = build_chess(0.05, 30, 160, 90)
    geo = scene.geometry
    open_meshes = [dataclasses.replace(mesh, closed=False) for mesh in geo.instances.meshes]
    instances = dataclasses.replace(geo.instances, meshes=open_meshes)
    two_sided = dataclasses.replace(scene, geometry=InstancedGeometry(instances, geo.object_names))
    assert geo.object_closed.any() and not two_sided.geometry.object_closed.any()
    settings = RenderSettings(mode=mode, near_size=3.5, cube_far=100.0, cube_resolution=128,
                              shadow_resolution=512, max_depth=3)
    images = []
    for variant in (scene, two_sided):
        renderer = Renderer(gl)
        try:
            images.append(renderer.render(variant, camera, settings).image)
        finally:
            renderer.release()
    differing = (np.abs(images[0] - images[1]).max(axis=2) > 1e-4).sum()
    # Rasterization rules may move a silhouette texel; and a traced diffuse ray that leaves a
    # surface where a closed object stands on it (a piece's base on the board) may meet that
    # object's back face, culled in one image only: a few texels of 14,400, no more.
    assert differing <= 8


def test_culling_is_active_a_face_turned_away_and_wrongly_marked_closed_disappears(gl):
    from hybrid_engine.scene.camera import Camera, look_at
    from hybrid_engine.scene.geometry import Geometry, flat_normals
    from hybrid_engine.scene.data import Lights, MaterialTable, SceneData, Sky

    # A square in the z = 0 plane, counter-clockwise seen from below; the camera looks down.
    away = quad((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), (1.0, 0.0, 0.0)).astype(np.float32)
    geometry = Geometry(triangles=away, normals=flat_normals(away), material_ids=np.zeros(2, np.int32),
                        object_ranges=np.array([[0, 2]]),
                        object_bounds=np.array([[[-1.0, -1.0, 0.0], [1.0, 1.0, 0.0]]]),
                        object_closed=np.array([True]))
    # A red face under a blue sky: the World lights it black, unlike the sky behind it.
    scene = SceneData(geometry=geometry, materials=MaterialTable.from_rows([dict(base_color=(1, 0, 0))]),
                      lights=Lights.from_rows([]), sky=Sky(color=(0.0, 0.0, 1.0)))
    camera = Camera(matrix_world=look_at((0.0, -0.5, 3.0), (0.0, 0.0, 0.0)), width=32, height=32)
    renderer = Renderer(gl)
    try:
        culled = renderer.render(scene, camera, RenderSettings(mode="RASTER")).image
        geometry.object_closed = np.array([False])
        drawn = renderer.render(scene, camera, RenderSettings(mode="RASTER")).image
    finally:
        renderer.release()
    sky = np.array([0.0, 0.0, 1.0])
    assert np.allclose(culled[16, 16, :3], sky, atol=1e-3)  # its only face is a back face
    assert not np.allclose(drawn[16, 16, :3], sky, atol=1e-3)
