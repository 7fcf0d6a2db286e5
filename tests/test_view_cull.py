# SPDX-License-Identifier: GPL-3.0-or-later
"""Per-triangle culling of raster draws (hybrid_engine/passes/view_cull/view_cull.py): the cube-map faces
drawn from the GPU-culled lists are bit-identical to drawing the object lists, while far
fewer triangles reach the rasterizer."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine import Camera, Geometry, Lights, MaterialTable, RenderSettings, SceneData, Sky
from hybrid_engine.scene.camera import look_at
from hybrid_engine.gpu.dispatch import forced_limits
from hybrid_engine.frame.renderer import Renderer
from benchmarks.scenes.chess import CHESS_CUBE_FAR, build_chess
from hybrid_engine.passes.view_cull.view_cull import CHUNK_ITEMS, CullView, view_segments
from scenes_analytic import box, quad, uv_sphere


@pytest.fixture(scope="module")
def renderer(gl):
    r = Renderer(gl)
    yield r
    r.release()


def face_targets(cube) -> dict[str, bytes]:
    t = cube.targets
    return {name: getattr(t, name).read() for name in ("depth", "normal_material", "surface", "geometric")}


def cube_maps_both_ways(renderer, scene, camera, settings):
    """The cube map of one frame drawn from the culled lists (as the renderer does) and
    from the object lists, on the same uploaded scene."""
    renderer.render(scene, camera, settings)
    cube_map, gpu = renderer.cube_map, renderer.gpu_scene
    center = np.asarray(camera.position, np.float64)
    submitted = cube_map.render(gpu, scene, center, settings, triangles=(gpu.positions.buffer, gpu.triangle_count))
    culled = cube_map.culled
    assert culled is not None, "the renderer's cube map must use the culled lists"
    drawn = culled.drawn()
    if settings.cube_back_layer:
        drawn += cube_map.culled_back.drawn()
    with_culling = face_targets(cube_map)
    direct_submitted = cube_map.render(gpu, scene, center, settings)
    assert cube_map.culled is None and cube_map.culled_back is None
    return with_culling, face_targets(cube_map), submitted, direct_submitted, drawn


def assert_identical(a: dict[str, bytes], b: dict[str, bytes]) -> None:
    for name in a:
        same = np.frombuffer(a[name], np.uint8) == np.frombuffer(b[name], np.uint8)
        assert same.all(), f"{name}: {np.count_nonzero(~same)} bytes differ"


@pytest.mark.parametrize("back_layer", [False, True])
def test_culled_cube_faces_equal_direct_draws_on_a_chess_frame(renderer, back_layer):
    """Closed pieces (back faces dropped; in the back layer the front faces), sub-texel
    triangles of distant pieces, the floor crossing every face (absent from the back layer):
    same depth, normals, materials and UVs, bit for bit."""
    scene, camera = build_chess(detail=0.03, frame=3, width=64, height=36)
    settings = RenderSettings(mode="HYBRID", near_size=3.5, cube_far=CHESS_CUBE_FAR, cube_resolution=128,
                              max_depth=2, cube_back_layer=back_layer)
    culled, direct, submitted, direct_submitted, drawn = cube_maps_both_ways(renderer, scene, camera, settings)
    assert_identical(culled, direct)
    assert submitted == direct_submitted
    if back_layer:
        back_rows = np.frombuffer(culled["normal_material"], np.float32).reshape(256, 768, 4)[128:, :, 3]
        assert (back_rows < 0).sum() > 1000  # back faces, seen from behind
        assert not (back_rows > 0).any()
    assert 0 < sum(drawn) < 0.6 * submitted, f"drew {sum(drawn)} of {submitted}"


def test_culled_cube_faces_equal_direct_draws_for_triangles_crossing_the_camera_plane(renderer):
    """A floor and a wall through the camera's position (vertices behind the face cameras),
    a closed box cut by a face's near plane (its back faces must stay: it is not wholly
    beyond the plane) and a closed ball (back faces dropped): the clipper's cases are kept,
    the result unchanged."""
    ball, ball_n = uv_sphere((4, 1, 0.5), 1.0, 24, 12)
    mats = MaterialTable.from_rows([dict(name="grey", base_color=(0.6, 0.6, 0.6)),
                                    dict(name="red", base_color=(0.8, 0.1, 0.1))])
    geometry = Geometry.from_objects([
        (quad((0, 0, -1), (30, 0, 0), (0, 30, 0)), None, 0),
        (quad((0, 6, 0), (30, 0, 0), (0, 0, 5)), None, 1),
        (box((-1, 0.1, -0.3), (1, 0.9, 0.3)), None, 1),
        (ball, ball_n, 0),
    ])
    closed = np.array([False, False, True, True])
    geometry = Geometry(geometry.triangles, geometry.normals, geometry.material_ids, geometry.object_ranges,
                        geometry.object_bounds, geometry.object_names, geometry.uvs, closed)
    scene = SceneData(geometry, mats, Lights.from_rows([]), Sky(color=(0.3, 0.4, 0.5)))
    camera = Camera(matrix_world=look_at((0.2, -0.3, 0.1), (4, 1, 0.5)), width=32, height=24, lens=30.0,
                    clip_start=0.05, clip_end=500.0)
    settings = RenderSettings(mode="HYBRID", near_size=0.5, cube_far=100.0, cube_resolution=64, max_depth=1)
    culled, direct, submitted, _, drawn = cube_maps_both_ways(renderer, scene, camera, settings)
    assert_identical(culled, direct)
    assert sum(drawn) < submitted


def test_lists_past_the_storage_block_limit_fall_back_to_direct_draws(renderer):
    """An index buffer larger than one storage block is not built: the faces are drawn
    from the object lists, with the same result."""
    scene, camera = build_chess(detail=0.02, frame=0, width=48, height=27)
    settings = RenderSettings(mode="HYBRID", near_size=3.5, cube_far=CHESS_CUBE_FAR, cube_resolution=64,
                              max_depth=1)
    normal = renderer.render(scene, camera, settings).image
    with forced_limits(max_block=4096):
        gpu = renderer.gpu_scene
        renderer.cube_map.render(gpu, scene, np.asarray(camera.position), settings,
                                 triangles=(gpu.positions.buffer, gpu.triangle_count))
        assert renderer.cube_map.culled is None
    # And the frame renders the same way through the whole renderer afterwards.
    np.testing.assert_array_equal(renderer.render(scene, camera, settings).image, normal)


def test_segments_merge_adjacent_objects_and_start_each_view_on_a_chunk():
    """Work list: per view, runs of visible objects split where the back-face class
    changes, each view padded to a multiple of CHUNK_ITEMS."""
    ranges = np.array([[0, 10], [10, 5], [15, 7], [40, 3]])
    near = np.array([[-1, -1, 5], [1, 1, 6]], float)
    far = np.array([[-1, -1, -50], [1, 1, -40]], float)  # behind a camera looking up +z
    bounds = np.stack([near, near, near, far])
    closed = np.array([False, False, True, False])
    up = look_at((0, 0, 0), (0, 0, 1), (0, 1, 0))
    from hybrid_engine.scene.camera import perspective_matrix
    vp = perspective_matrix(np.radians(90), 1.0, 0.1, 100.0) @ np.linalg.inv(up)
    segments, chunks = view_segments([CullView(vp, 8, 8), CullView(vp, 8, 8)], ranges, bounds, closed)
    assert segments["first"].tolist() == [0, 15, 0, 15]
    assert segments["count"].tolist() == [15, 7, 15, 7]
    assert (segments["tag"] & 0xFF).tolist() == [0, 0, 1, 1]
    assert (segments["tag"] >> 8).tolist() == [0, 1, 0, 1]
    assert segments["work"].tolist() == [0, 15, CHUNK_ITEMS, CHUNK_ITEMS + 15]
    assert chunks == [0, 1, 2]
