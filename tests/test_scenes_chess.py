# SPDX-License-Identifier: GPL-3.0-or-later
"""The procedural Chess scene (benchmarks/scenes/chess.py): the paper's pathological case.

Oracles: counting (pieces per set and type, the paper's 288 + 9), geometry that has a closed
form (a sphere's normals point away from its centre; a piece stands on the board), numpy
recomputation of what the builder vectorises (object bounds), the animation's own contract
(periodic, static board), and FULL_BVH for the FLIP bound of HYBRID (as the paper compares).
"""
from __future__ import annotations

import dataclasses
import time
from collections import Counter

import numpy as np
import pytest

from hybrid_engine import RenderSettings
from hybrid_engine.frame.renderer import Renderer
from hybrid_engine.passes.cube_map.cube_map import CubeMapPass
from hybrid_engine.scene.geometry import finite_bounds, flat_normals
from benchmarks.scenes import CHESS_CUBE_FAR, CHESS_FRAMES, build_chess, chess_triangle_count
from benchmarks.scenes import chess
from conftest import save_failure_images
from whitted_reference import flip_mean

TINY = 0.02  # ~35 k triangles: the floor of the tessellation, for fast tests
# Triangle count is linear in detail (both tessellation axes scale with sqrt(detail)); rounding
# the ring and segment counts to integers moves a ratio by a few percent.
LINEARITY_TOLERANCE = 0.05
# The paper's Chess scene has 2,149,944 triangles; ours at detail 1 must be of that size.
PAPER_TRIANGLES = 2_149_944
PAPER_TRIANGLES_TOLERANCE = 0.05
# Building 2.15 M triangles takes 0.6-0.9 s on the 2-core test machine; the bound is generous
# for a loaded machine yet far below what a per-triangle Python loop would take (minutes).
MAX_BUILD_SECONDS_AT_DETAIL_1 = 5.0
# Normals are float32 unit vectors.
UNIT_TOLERANCE = 1e-4


@pytest.fixture(scope="module")
def tiny():
    return build_chess(TINY, 0, 64, 36)


def object_index(scene) -> dict[str, int]:
    return {name: k for k, name in enumerate(scene.geometry.object_names)}


def object_triangles(scene, name: str) -> np.ndarray:
    first, count = scene.geometry.object_ranges[object_index(scene)[name]]
    return scene.geometry.triangles[first:first + count]


# -- size -------------------------------------------------------------------------------------

def test_triangle_count_is_linear_in_detail_and_matches_the_built_scene():
    counts = {d: chess_triangle_count(d) for d in (0.25, 0.5, 1.0)}
    assert abs(counts[1.0] / counts[0.5] / 2.0 - 1.0) < LINEARITY_TOLERANCE
    assert abs(counts[0.5] / counts[0.25] / 2.0 - 1.0) < LINEARITY_TOLERANCE
    assert abs(counts[1.0] / PAPER_TRIANGLES - 1.0) < PAPER_TRIANGLES_TOLERANCE
    for detail in (TINY, 0.1):
        scene, _ = build_chess(detail)
        assert scene.geometry.triangle_count == chess_triangle_count(detail)
    assert 20_000 <= chess_triangle_count(TINY) <= 50_000, "the quick size of the benchmark"


def test_paper_sized_scene_builds_fast():
    start = time.perf_counter()
    scene, _ = build_chess(1.0, 37)
    elapsed = time.perf_counter() - start
    assert scene.geometry.triangle_count > 2_000_000
    assert elapsed < MAX_BUILD_SECONDS_AT_DETAIL_1, f"{elapsed:.2f} s"


@pytest.mark.parametrize("detail", [0.0, -1.0, float("nan"), chess.MAX_DETAIL * 2])
def test_bad_detail_is_refused(detail):
    with pytest.raises(ValueError, match="detail"):
        build_chess(detail)


# -- objects ----------------------------------------------------------------------------------

def test_pieces_spheres_and_boards_are_separate_objects(tiny):
    scene, _ = tiny
    names = scene.geometry.object_names
    assert len(names) == len(set(names)) == len(scene.geometry.object_ranges)
    pieces = [n for n in names if n.startswith("set")]
    assert len(pieces) == 288
    assert len([n for n in names if n.startswith("sphere_")]) == 9
    assert len([n for n in names if n.startswith("board_frame_")]) == 9
    assert len([n for n in names if n.startswith("board_") and not n.startswith("board_frame")]) == 9
    assert "floor" in names
    per_set = Counter(n.split("_")[0] for n in pieces)
    assert set(per_set.values()) == {32}
    kinds = Counter(n.split("_")[2] for n in pieces)
    assert kinds == {"pawn": 144, "rook": 36, "knight": 36, "bishop": 36, "queen": 18, "king": 18}
    # Object ranges tile the triangle array without gaps or overlaps.
    ranges = scene.geometry.object_ranges[np.argsort(scene.geometry.object_ranges[:, 0])]
    assert ranges[0, 0] == 0
    np.testing.assert_array_equal(ranges[1:, 0], ranges[:-1, 0] + ranges[:-1, 1])
    assert ranges[-1].sum() == scene.geometry.triangle_count


def test_object_bounds_enclose_exactly_their_triangles(tiny):
    """The builder computes bounds per batch of instances; recompute them object by object."""
    scene, _ = tiny
    geo = scene.geometry
    for (first, count), bounds in zip(geo.object_ranges, geo.object_bounds):
        np.testing.assert_array_equal(bounds, finite_bounds(geo.triangles[first:first + count]))


def test_pieces_stand_on_their_squares_and_spheres_are_round(tiny):
    scene, _ = tiny
    geo = scene.geometry
    names = object_index(scene)
    # Set 4 is the middle board (centre at the origin); its white king stands on e1.
    king = object_triangles(scene, "set4_white_king_e1").reshape(-1, 3)
    assert abs(king[:, 2].min()) < 1e-6, "a resting piece stands on the board top (z = 0)"
    np.testing.assert_allclose(king[:, :2].mean(axis=0), (0.5, -3.5), atol=0.05)
    # A sphere's shading normals point from its centre through each corner.
    first, count = geo.object_ranges[names["sphere_0"]]
    corners = geo.triangles[first:first + count].reshape(-1, 3).astype(np.float64)
    normals = geo.normals[first:first + count].reshape(-1, 3)
    centre = (corners.min(axis=0) + corners.max(axis=0)) / 2
    radial = (corners - centre) / np.linalg.norm(corners - centre, axis=1, keepdims=True)
    assert np.einsum("ij,ij->i", radial, normals).min() > 0.999


def test_faces_wind_outwards_like_their_shading_normals(tiny):
    """Lathe, prism and box triangles are counter-clockwise seen from outside: the face normal
    agrees with the interpolated shading normal (smooth normals only bend at profile corners)."""
    scene, _ = tiny
    face = flat_normals(scene.geometry.triangles)[:, 0]
    shading = scene.geometry.normals.mean(axis=1)
    agree = np.einsum("ij,ij->i", face, shading) > 0
    assert agree.all(), f"{np.count_nonzero(~agree)} triangles wound inwards"


# -- animation --------------------------------------------------------------------------------

def test_camera_and_some_objects_move_while_the_boards_stay():
    first, cam0 = build_chess(TINY, 0)
    later, cam1 = build_chess(TINY, 60)
    assert not np.allclose(cam0.matrix_world, cam1.matrix_world)
    geo0, geo1 = first.geometry, later.geometry
    assert geo0.object_names == geo1.object_names
    moved = []
    for name, (start, count) in zip(geo0.object_names, geo0.object_ranges):
        same = np.array_equal(geo0.triangles[start:start + count], geo1.triangles[start:start + count])
        if name.startswith(("board", "floor")):
            assert same, f"{name} moved"
        if not same:
            moved.append(name)
    assert len([n for n in moved if n.startswith("sphere_")]) == 9
    moving_pieces = [n for n in moved if n.startswith("set")]
    assert len(moving_pieces) == 18, "one pawn and one knight per set"
    # The middle sphere deforms (squash and stretch): its height changes, not only its place.
    def height(geo, name):
        first, count = geo.object_ranges[geo.object_names.index(name)]
        z = geo.triangles[first:first + count, :, 2]
        return z.max() - z.min()
    assert abs(height(geo0, "sphere_4") - height(geo1, "sphere_4")) > 0.05
    assert abs(height(geo0, "sphere_0") - height(geo1, "sphere_0")) < 1e-4


def test_animation_is_periodic_over_the_papers_200_frames():
    scene0, cam0 = build_chess(TINY, 0)
    scene200, cam200 = build_chess(TINY, CHESS_FRAMES)
    np.testing.assert_allclose(cam0.matrix_world, cam200.matrix_world, atol=1e-9)
    np.testing.assert_array_equal(scene0.geometry.triangles, scene200.geometry.triangles)


@pytest.mark.parametrize("frame", [0, 33, 100, 171])
def test_every_frame_is_finite_with_unit_normals(frame):
    scene, camera = build_chess(TINY, frame, 32, 18)
    geo = scene.geometry
    assert np.isfinite(geo.triangles).all() and np.isfinite(geo.normals).all()
    np.testing.assert_allclose(np.linalg.norm(geo.normals, axis=-1), 1.0, atol=UNIT_TOLERANCE)
    assert np.isfinite(camera.view_projection()).all()
    # The camera never sits inside an object: clear of every object's box.
    eye = camera.position
    inside = ((geo.object_bounds[:, 0] <= eye) & (eye <= geo.object_bounds[:, 1])).all(axis=1)
    assert not inside.any(), [geo.object_names[k] for k in np.flatnonzero(inside)]


# -- materials --------------------------------------------------------------------------------

def test_most_pieces_are_mirrors_and_some_are_glass(tiny):
    scene, _ = tiny
    geo, mats = scene.geometry, scene.materials
    first_material = {name: int(geo.material_ids[first])
                      for name, (first, _) in zip(geo.object_names, geo.object_ranges)}
    pieces = [m for n, m in first_material.items() if n.startswith("set")]
    mirror = [m for m in pieces if 0.6 <= mats.reflectivity[m] <= 0.9]
    glass = [m for m in pieces if mats.transmission[m] == 1.0 and mats.ior[m] > 1.0]
    assert len(mirror) > len(pieces) / 2
    assert 0 < len(glass) < len(pieces) / 4
    spheres = [m for n, m in first_material.items() if n.startswith("sphere_")]
    assert all(mats.reflectivity[m] >= 0.85 for m in spheres), "dense mirror spheres"
    # Both piece colours: white-tinted and dark-tinted mirrors.
    tints = {float(mats.base_color[m].mean()) for m in mirror}
    assert min(tints) < 0.5 < max(tints)
    assert ((mats.reflectivity + mats.transmission) <= 1.0).all()
    assert len(scene.lights) == 2 and sorted(scene.lights.kind.tolist()) == [0, 1]  # point, sun


# -- rendering --------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def renderer(gl):
    r = Renderer(gl)
    yield r
    r.release()


def settings(mode: str, near_size: float, cube_resolution: int = 64) -> RenderSettings:
    # The screen-space World light: these tests compare where reflections go, which one
    # sample of traced diffuse light would cover with its noise.
    return RenderSettings(mode=mode, near_size=near_size, max_depth=4,
                          cube_resolution=cube_resolution, shadow_resolution=512,
                          cube_far=CHESS_CUBE_FAR, world_light="SCREEN")


def test_tiny_chess_renders_in_hybrid_without_nan(renderer, tiny):
    scene, camera = tiny
    result = renderer.render(scene, camera, settings("HYBRID", 3.5))
    assert np.isfinite(result.image).all()
    assert result.image[..., :3].max() > 0.1
    assert 0 < result.counts["triangles_bvh"] < scene.geometry.triangle_count
    assert result.counts["rays_cube_map"] > 0


# HYBRID against FULL_BVH on a reduced Chess scene (detail 0.05: 95 k triangles, 160x90, cube
# faces of 256 texels). The scene is the paper's pathological case: mirror pieces reflecting
# each other, which the single-layer cube map can only approximate (§4.1, Figure 7), so the
# error depends on how much of the grid the near cube holds. Measured at frames 0-150:
# near size 10 (the near cube holds the camera's four nearest board corners, ~40% of the
# triangles; half of the secondary rays still march the cube map): FLIP 0.039-0.047, which
# meets the 0.05;
MAX_FLIP_REDUCED_CHESS = 0.05
# near size 3.5 (the benchmark's: about 20 pieces near, 5% of the triangles): 0.093 at
# frame 0 -- the method's approximation of distant inter-reflections, bounded here against
# regressions of the cube-map march with ~30% headroom.
MAX_FLIP_REDUCED_CHESS_SMALL_NEAR = 0.12


@pytest.mark.parametrize("near_size,bound", [(10.0, MAX_FLIP_REDUCED_CHESS),
                                              (3.5, MAX_FLIP_REDUCED_CHESS_SMALL_NEAR)])
def test_hybrid_stays_close_to_full_bvh_on_a_reduced_chess_scene(renderer, near_size, bound):
    scene, camera = build_chess(0.05, 0, 160, 90)
    full = renderer.render(scene, camera, settings("FULL_BVH", near_size, 256))
    hybrid = renderer.render(scene, camera, settings("HYBRID", near_size, 256))
    # The cube map does real work: distant geometry is not in the BVH and rays march it.
    assert hybrid.counts["triangles_bvh"] < 0.5 * scene.geometry.triangle_count
    assert hybrid.counts["rays_cube_map"] > 0.3 * hybrid.counts["rays_traced"]
    error = flip_mean(full.image, hybrid.image)
    if error > bound:
        save_failure_images(f"chess_near_{near_size}", test=hybrid.image, reference=full.image)
    assert error <= bound, f"near size {near_size}: FLIP {error:.4f}"


def test_the_hidden_exit_rule_brings_hybrid_closer_to_full_bvh_on_chess(renderer, monkeypatch):
    """Distant mirror spheres and pieces reflect the board beneath and behind them, which
    they hide from the camera: those rays pass under the board and leave the scene hidden.
    The paper's rule gives them the sky; the hidden-exit rule (cube_march.glsl) the board
    that hides them. Reduced chess, frame 3, near size 3.5, FLIP against FULL_BVH, with the
    paper's march (measured: one layer 0.0640 -> 0.0591, back layer 0.0638 -> 0.0529). The
    surface footprints (on by default) stop some of those rays at the board's frames before
    they leave: there the rule gains less with one layer (0.0536 -> 0.0519) and as much
    with the back layer (0.0504 -> 0.0455)."""
    scene, camera = build_chess(0.05, 3, 160, 90)
    full = renderer.render(scene, camera, settings("FULL_BVH", 3.5, 256)).image
    flip = {}
    for footprints in (False, True):
        monkeypatch.setattr(CubeMapPass, "footprints", footprints)
        for back in (False, True):
            for hidden_exit in (False, True):
                s = dataclasses.replace(settings("HYBRID", 3.5, 256), cube_back_layer=back,
                                        cube_hidden_exit=hidden_exit)
                flip[footprints, back, hidden_exit] = flip_mean(full, renderer.render(scene, camera, s).image)
    assert flip[False, False, True] < 0.95 * flip[False, False, False], flip
    assert flip[False, True, True] < 0.9 * flip[False, True, False], flip
    assert flip[True, False, True] < flip[True, False, False], flip
    assert flip[True, True, True] < 0.95 * flip[True, True, False], flip
