# SPDX-License-Identifier: GPL-3.0-or-later
"""The cube-map march (gpu_shaders/include/cube_march.glsl, paper §3.4) against an
independent numpy march (tests/cube_march_reference.py) on the same rasterized atlas, plus
the geometric properties the paper states (Figure 3: diagonal rays keep their face; x/y
exits switch faces; z > 1 is the sky; z < -1 returns to the BVH)."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hybrid_engine import Geometry, Lights, MaterialTable, RenderSettings, SceneData, Sky
from hybrid_engine.passes.cube_map.cube_map import CubeFaces, CubeMapPass
from hybrid_engine.passes.scene_upload.scene_buffers import GPUScene
from hybrid_engine.passes.gbuffer.gbuffer import GBufferPass
from hybrid_engine.scene.solids import closed_outward
from cube_march_probe import MARCH_HIT, MARCH_SKY, MARCH_TO_BVH, probe_cube_march
from cube_march_reference import HIT, SKY, TO_BVH, CubeMapReference, face_matrices
from scenes_analytic import box, quad, uv_sphere

CENTER = np.array([0.3, -0.2, 0.1])
NEAR, FAR, RES = 1.0, 60.0, 64
# Rays whose GPU (float32) and numpy (float64) marches may legitimately part: a sample that
# lands within rounding of a texel edge or of the hit threshold. Measured: well under 1%.
MIN_AGREEMENT = 0.97
# Hits agree to within this many texels (a bisection step straddling a texel edge).
TEXEL_TOLERANCE = 1


def boxes_scene(thickness: float = 0.5) -> SceneData:
    objects = [
        (box(CENTER + (3, -1, -1), CENTER + (4, 1, 1)), None, 0),
        (box(CENTER + (-2, 2, -0.5), CENTER + (-1, 6, 0.5)), None, 1),
        (box(CENTER + (-1, -1, -8), CENTER + (1, 1, -7)), None, 0),
        (quad(CENTER + (0, 0, -3), (20, 0, 0), (0, 20, 0)), None, 1),
        (box(CENTER + (1.5, 1.5, 1.5), CENTER + (2.5, 2.5, 5.0)), None, 0),
    ]
    mats = MaterialTable.from_rows([dict(base_color=(0.8, 0.2, 0.2), thickness=thickness),
                                    dict(base_color=(0.2, 0.8, 0.2), thickness=1.0 - thickness)])
    geometry = Geometry.from_objects(objects)
    # The boxes are closed solids (their far sides form the cube map's back layer).
    geometry = dataclasses.replace(geometry, object_closed=[closed_outward(tris) for tris, _, _ in objects])
    return SceneData(geometry, mats, Lights.empty(), Sky())


@pytest.fixture(scope="module")
def cube_setup(gl):
    raster = GBufferPass(gl)
    gpu = GPUScene(gl)
    cube = CubeMapPass(gl, raster)
    yield gl, raster, gpu, cube
    cube.release()
    raster.release()
    gpu.release()


def march_both(cube_setup, scene, origins, dirs, t_start, march="HIERARCHICAL", res=RES, **kw):
    """The GPU march and the numpy reference march of the same rays through the same atlas."""
    ctx, raster, gpu, cube = cube_setup
    settings = RenderSettings(near_size=NEAR, cube_far=FAR, cube_resolution=res, cube_march=march, **kw)
    gpu.upload(scene)
    gpu.transform()
    cube.render(gpu, scene, CENTER, settings)
    gpu_rows = probe_cube_march(ctx, cube, gpu.materials.buffer, settings, origins, dirs, t_start)
    w, h = cube.targets.size
    depth = np.frombuffer(cube.targets.depth.read(), np.float32).reshape(h, w)
    nm = np.frombuffer(cube.targets.normal_material.read(), np.float32).reshape(h, w, 4)
    ref = CubeMapReference(depth, nm, scene.materials.thickness, CENTER, NEAR, FAR,
                           settings.n_min, settings.n_max, hierarchical=march == "HIERARCHICAL",
                           back_layer=settings.cube_back_layer, hidden_exit=settings.cube_hidden_exit)
    t_start = np.broadcast_to(np.asarray(t_start, float), (len(origins),))
    refs = [ref.march(o, d, t) for o, d, t in zip(origins, dirs, t_start)]
    return gpu_rows, refs


def test_reference_face_matrices_equal_the_engine_cube_faces():
    faces = CubeFaces.at(CENTER, NEAR, FAR)
    np.testing.assert_allclose(face_matrices(CENTER, NEAR, FAR), faces.view_proj, atol=1e-12)


@pytest.mark.parametrize("march, res, back_layer", [("SAMPLED", RES, False), ("HIERARCHICAL", RES, False),
                                                     ("HIERARCHICAL", 48, False), ("SAMPLED", RES, True),
                                                     ("HIERARCHICAL", RES, True)])
def test_march_agrees_with_the_numpy_reference_on_random_rays(cube_setup, rng, march, res, back_layer):
    """Rays from inside the near cube (entering the map at its faces) and from outside it
    (starting in the map), in all directions. The hierarchical march walks a pyramid; the
    reference tests every texel crossed, so agreement proves the pyramid skips no hit (also
    for faces that are not a power of two, padded in the pyramid). With the back layer, rays
    from outside also hit the far sides of the boxes."""
    count = 300
    inside = CENTER + rng.uniform(-0.9, 0.9, (count // 2, 3)) * NEAR
    outside = CENTER + rng.uniform(-6, 6, (count - count // 2, 3))
    outside = outside[np.abs(outside - CENTER).max(axis=1) > 1.2 * NEAR]
    # And rays from behind the far red box and the tall box, heading back at them.
    box_centres = CENTER + np.array([[3.5, 0.0, 0.0], [2.0, 2.0, 3.25]])
    which = rng.integers(0, 2, 60)
    behind = (CENTER + (box_centres[which] - CENTER) * rng.uniform(1.6, 2.2, (60, 1))
              + rng.uniform(-0.3, 0.3, (60, 3)))
    origins = np.concatenate([inside, outside, behind])
    dirs = rng.normal(size=origins.shape)
    dirs[-len(behind):] = box_centres[which] + rng.uniform(-0.4, 0.4, (60, 3)) - behind
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    # Start inside rays where they leave the near cube (as the tracer does).
    with np.errstate(divide="ignore"):
        t_faces = np.where(dirs > 0, (CENTER + NEAR - origins) / dirs, (CENTER - NEAR - origins) / dirs)
    t_start = np.where(np.arange(len(origins)) < len(inside), np.min(np.abs(t_faces), axis=1), 0.0)
    gpu_rows, refs = march_both(cube_setup, boxes_scene(), origins, dirs, t_start, march, res,
                                cube_back_layer=back_layer)
    kinds = np.array([r.kind for r in refs])
    assert {HIT, SKY} <= set(kinds.tolist())  # the sample covers hits and misses
    if back_layer:  # the sample covers back-layer hits
        assert sum(r.kind == HIT and r.texel[1] >= res for r in refs) >= 20
    same_kind = gpu_rows["kind"] == kinds
    assert same_kind.mean() >= MIN_AGREEMENT, same_kind.mean()
    hits = same_kind & (kinds == HIT)
    ref_texels = np.array([r.texel for r in refs])[hits]
    texel_ok = (np.abs(gpu_rows["texel"][hits] - ref_texels) <= TEXEL_TOLERANCE).all(axis=1)
    assert texel_ok.mean() >= MIN_AGREEMENT
    assert (gpu_rows["face"][hits] == np.array([r.face for r in refs])[hits]).mean() >= MIN_AGREEMENT
    if march == "SAMPLED":
        # The march's step counter (the diagnostic view of march steps) counts the samples
        # the reference takes, face by face, up to the hit.
        steps = np.array([r.steps for r in refs])
        assert (steps > 0).mean() > 0.9
        assert (gpu_rows["steps"][same_kind] == steps[same_kind]).mean() >= MIN_AGREEMENT


@pytest.mark.parametrize("march", ["SAMPLED", "HIERARCHICAL"])
@pytest.mark.parametrize("hidden_exit", [False, True])
def test_a_ray_leaving_the_map_hidden_under_the_ground_hits_the_ground_only_with_the_hidden_exit_rule(
        cube_setup, rng, hidden_exit, march):
    """Rays that start under the ground quad (a sheet: thickness 0) and head down and away
    never cross a surface the map holds; they leave through the far plane at points hidden
    by the ground. The paper's rule gives them the sky; the hidden-exit rule, the ground
    stored at their exit texels. The reference agrees ray by ray either way."""
    origins = CENTER + np.c_[rng.uniform(-4, 4, (80, 2)), np.full(80, -3.5)]
    dirs = np.c_[rng.uniform(-0.4, 0.4, (80, 2)), -np.ones(80)]
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    gpu_rows, refs = march_both(cube_setup, boxes_scene(1.0), origins, dirs, 0.0, march,
                                cube_hidden_exit=hidden_exit)
    kinds = np.array([r.kind for r in refs])
    assert (gpu_rows["kind"] == kinds).mean() >= MIN_AGREEMENT
    if not hidden_exit:
        assert (gpu_rows["kind"] == MARCH_SKY).all()
        return
    hits = gpu_rows["kind"] == MARCH_HIT
    assert hits.mean() > 0.9
    assert (gpu_rows["material"][hits] == 1).all()  # the ground, the only surface stored below
    both = hits & (kinds == HIT)
    ref_texels = np.array([r.texel for r in refs])[both]
    assert (np.abs(gpu_rows["texel"][both] - ref_texels) <= TEXEL_TOLERANCE).all()
    # Hit where the ray left: on the ground's stored surface, far below the ray's origin.
    assert (gpu_rows["position"][hits][:, 2] == pytest.approx(CENTER[2] - 3.0, abs=1e-3))


@pytest.mark.parametrize("march", ["SAMPLED", "HIERARCHICAL"])
@pytest.mark.parametrize("thickness", [0.0, 1.0])
def test_thickness_rule_agrees_with_the_reference_for_rays_passing_behind_objects(cube_setup, rng, thickness,
                                                                                   march):
    """Rays that start beside the far red box and pass behind it: thin (0) lets them through,
    solid (1) stops them, in both marches."""
    origins = CENTER + np.array([[3.5, -2.5, 0.0]]) + rng.uniform(-0.2, 0.2, (60, 3))
    targets = CENTER + np.array([4.5, 1.5, 0.0]) + rng.uniform(-0.3, 0.3, (60, 3))
    dirs = targets - origins
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    gpu_rows, refs = march_both(cube_setup, boxes_scene(thickness), origins, dirs, 0.0, march)
    kinds = np.array([r.kind for r in refs])
    assert (gpu_rows["kind"] == kinds).mean() >= MIN_AGREEMENT
    hit_share = (gpu_rows["kind"] == MARCH_HIT).mean()
    if thickness == 1.0:
        assert hit_share > 0.8
    else:
        assert hit_share < 0.2


def test_rays_from_the_centre_keep_their_face_even_on_the_diagonal_planes(cube_setup):
    """Figure 3: with 90.2° faces every ray from the centre lies in one face and never
    switches, including rays exactly on the diagonal planes and the cube's corners."""
    diagonals = np.array([[1, 1, 0], [1, -1, 0], [-1, 1, 0], [0, 1, 1], [0, -1, 1], [1, 0, -1],
                          [1, 1, 1], [-1, -1, -1], [1, -1, 1], [-1, 1, -1]], float)
    dirs = diagonals / np.linalg.norm(diagonals, axis=1, keepdims=True)
    origins = np.broadcast_to(CENTER, dirs.shape)
    empty = SceneData(Geometry.empty(), MaterialTable.default(), Lights.empty(), Sky())
    exit_t = NEAR / np.abs(dirs).max(axis=1)  # where each ray leaves the near cube
    gpu_rows, refs = march_both(cube_setup, empty, origins, dirs, exit_t)
    assert (gpu_rows["face"] >= 0).all()  # every ray found a face
    assert (gpu_rows["kind"] == MARCH_SKY).all()
    assert (gpu_rows["switches"] == 0).all()
    assert all(r.kind == SKY and r.switches == 0 for r in refs)


def test_a_ray_crossing_three_faces_switches_twice_and_ends_in_the_sky(cube_setup):
    """From beside the -Y face, moving +Y at x = 3: -Y face, then +X, then +Y, whose far
    plane it leaves."""
    origins = CENTER + np.array([[3.0, -6.0, 0.5], [3.0, -6.0, 0.5], [-6.0, -3.0, -0.4]])
    dirs = np.array([[0, 1, 0.01], [0, 1, -0.01], [1.0, 0.02, 0.0]])
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    empty = SceneData(Geometry.empty(), MaterialTable.default(), Lights.empty(), Sky())
    gpu_rows, refs = march_both(cube_setup, empty, origins, dirs, 0.0)
    assert (gpu_rows["kind"] == MARCH_SKY).all()
    np.testing.assert_array_equal(gpu_rows["face"][:2], [2, 2])  # +Y at the end
    assert (gpu_rows["switches"][:2] == 2).all()
    assert [r.switches for r in refs] == gpu_rows["switches"].tolist()
    assert [r.face for r in refs] == gpu_rows["face"].tolist()


def test_a_ray_heading_into_the_near_cube_returns_to_the_bvh_at_its_face(cube_setup):
    origins = CENTER + np.array([[0.0, -6.0, 0.0], [5.0, 0.2, -0.3], [0.1, 0.1, 9.0]])
    dirs = np.array([[0, 1.0, 0], [-1.0, 0, 0], [0, 0, -1.0]])
    empty = SceneData(Geometry.empty(), MaterialTable.default(), Lights.empty(), Sky())
    gpu_rows, refs = march_both(cube_setup, empty, origins, dirs, 0.0)
    assert (gpu_rows["kind"] == MARCH_TO_BVH).all()
    assert all(r.kind == TO_BVH for r in refs)
    np.testing.assert_allclose(gpu_rows["t"], [5.0, 4.0, 8.0], rtol=1e-4)
    np.testing.assert_allclose([r.t for r in refs], [5.0, 4.0, 8.0], rtol=1e-9)


def test_the_sky_is_returned_past_the_far_plane_and_for_origins_beyond_it(cube_setup):
    origins = CENTER + np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 2 * FAR, 0.0]])
    dirs = np.array([[0.3, 0.2, 1.0], [-1.0, 0.1, 0.0], [0.0, -1.0, 0.0]])
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    empty = SceneData(Geometry.empty(), MaterialTable.default(), Lights.empty(), Sky())
    gpu_rows, refs = march_both(cube_setup, empty, origins, dirs, [NEAR * 1.2, NEAR * 1.2, 0.0])
    assert (gpu_rows["kind"] == MARCH_SKY).all()
    assert all(r.kind == SKY for r in refs)
    assert gpu_rows["face"][2] == -1  # beyond every far plane: no face at all


def test_hits_report_the_surface_position_normal_and_material(cube_setup):
    """A ray from the centre at the red box's face (x = 3 from the centre, outward normal
    -X) hits it at x = 3."""
    origins = np.array([CENTER])
    dirs = np.array([[1.0, 0.05, 0.02]])
    dirs /= np.linalg.norm(dirs)
    gpu_rows, refs = march_both(cube_setup, boxes_scene(), origins, dirs, NEAR / dirs[0, 0])
    row = gpu_rows[0]
    assert row["kind"] == MARCH_HIT and row["face"] == 0 and row["material"] == 0
    assert abs(row["position"][0] - (CENTER[0] + 3.0)) < 0.05
    np.testing.assert_allclose(row["normal"], [-1, 0, 0], atol=1e-5)
    assert refs[0].kind == HIT and abs(refs[0].position[0] - row["position"][0]) < 0.05


def test_the_hierarchical_march_hits_a_thin_pole_that_sparse_samples_step_over(cube_setup):
    """Every texel crossed is tested: a pole about two texels wide (0.3 at distance 4, texels
    of 2/64 rad) is hit by every ray passing through it, where two samples per face (the
    paper's march at n = 2) land on either side of it for some."""
    pole = box(CENTER + (-0.15, 4.0, -3.0), CENTER + (0.15, 4.3, 3.0))
    scene = SceneData(Geometry.from_objects([(pole, None, 0)]),
                      MaterialTable.from_rows([dict(base_color=(0.5, 0.5, 0.5), thickness=0.0)]),
                      Lights.empty(), Sky())
    origins = CENTER + np.array([[x, 2.0, 0.0] for x in np.linspace(-2.0, -1.5, 8)])
    dirs = CENTER + np.array([0.0, 4.0, 0.0]) - origins
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    exact, ref_exact = march_both(cube_setup, scene, origins, dirs, 0.0, "HIERARCHICAL")
    sparse, _ = march_both(cube_setup, scene, origins, dirs, 0.0, "SAMPLED", n_min=2, n_max=2)
    assert (exact["kind"] == MARCH_HIT).all()
    assert all(r.kind == HIT for r in ref_exact)
    assert (sparse["kind"] != MARCH_HIT).any()
    np.testing.assert_allclose(exact["position"][:, 1], CENTER[1] + 4.0, atol=0.05)


def test_reference_bias_is_one_texel_of_a_planes_axial_depth_change():
    """The reference's bias (the rule cube_march.glsl follows) against a finite difference
    through the face's own projection: a plane's view depth along the face axis changes
    across one texel by the bias less its relative term, for planes facing the centre
    off a face's centre (where the angle of incidence is 0 and the depth still changes)."""
    ref = CubeMapReference(np.ones((RES, 6 * RES)), np.zeros((RES, 6 * RES, 4)), [0.0],
                           CENTER, NEAR, FAR, 16, 64)
    vp = face_matrices(CENTER, NEAR, FAR)
    rng = np.random.default_rng(5)
    for face in range(6):
        for _ in range(5):
            ndc = np.r_[rng.uniform(-0.9, 0.9, 2), 0.9]
            point = ref.unproject(face, ndc)
            normal = CENTER - point + rng.normal(scale=0.3, size=3) * np.linalg.norm(point - CENTER)
            normal /= np.linalg.norm(normal)
            depth = (vp[face] @ np.r_[point, 1.0])[3]  # clip w: the view depth along the axis

            def plane_depth(xy):  # where the plane meets the line of sight through NDC xy
                far = ref.unproject(face, np.r_[xy, 1.0]) - CENTER
                t = normal @ (point - CENTER) / (normal @ far)
                return (vp[face] @ np.r_[CENTER + t * far, 1.0])[3]

            step = 2.0 / RES  # one texel in NDC
            grad = np.array([plane_depth(ndc[:2] + (step / 2) * e) - plane_depth(ndc[:2] - (step / 2) * e)
                             for e in np.eye(2)])
            expected = np.linalg.norm(grad) + depth * 1e-4  # BIAS_RELATIVE
            assert ref.bias(face, ndc, depth, normal) == pytest.approx(expected, rel=2e-3)


def test_mirror_rays_leaving_a_tessellated_sphere_where_it_faces_the_centre_miss_it(cube_setup, rng):
    """Mirror rays leaving a faceted sphere off a face's centre, where it faces the map's
    centre nearly head-on (under 12 degrees), each reflected about the smooth normal as the
    tracer spawns them: they head back past the centre and hit nothing the map holds. The
    bias follows the slope of the stored (axial) depth, which off a face's centre is not
    zero where the surface faces the centre; with the tangent of the angle of incidence
    instead, 15 % of them hit the sphere itself (measured, in the hierarchical march, which
    tests every texel crossed). The GPU and the reference agree ray by ray."""
    centre = CENTER + np.array([3.0, 6.0, 3.0])
    tris, normals = uv_sphere(tuple(centre), 1.0, segments=48, rings=24)
    scene = SceneData(Geometry.from_objects([(tris, normals, 0)]),
                      MaterialTable.from_rows([dict(base_color=(0.9, 0.9, 0.9), thickness=0.05)]),
                      Lights.empty(), Sky())
    which = rng.integers(0, len(tris), 40000)
    bary = rng.dirichlet(np.ones(3), len(which))
    points = np.einsum("tk,tkc->tc", bary, tris[which])
    smooth = np.einsum("tk,tkc->tc", bary, normals[which])
    smooth /= np.linalg.norm(smooth, axis=1, keepdims=True)
    view = points - CENTER
    view /= np.linalg.norm(view, axis=1, keepdims=True)
    cos = -(view * smooth).sum(axis=1)
    pick = rng.choice(np.flatnonzero(cos > np.cos(np.radians(12.0))), 120, replace=False)
    dirs = view[pick] + 2.0 * cos[pick, None] * smooth[pick]
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    origins = points[pick] + 1e-4 * np.abs(points[pick]).max(axis=1, keepdims=True) * smooth[pick]
    gpu_rows, refs = march_both(cube_setup, scene, origins, dirs, 0.0, "HIERARCHICAL", res=128)
    assert (gpu_rows["kind"] == np.array([r.kind for r in refs])).mean() >= MIN_AGREEMENT
    assert not (gpu_rows["kind"] == MARCH_HIT).any()
