# SPDX-License-Identifier: GPL-3.0-or-later
"""Near-cube culling (paper §3.3) against an independent float64 numpy SAT test.

The GPU works in float32 and a triangle that grazes the cube's surface may legitimately go
either way, so each check brackets the GPU result between the reference with a slightly
smaller and a slightly larger cube: every triangle that overlaps the shrunken cube must be
kept, and nothing outside the grown cube may be.
"""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine.gpu import triangle_input
from hybrid_engine.gpu import dispatch as gpu_dispatch
from hybrid_engine.passes.near_cube_cull import near_cube
from hybrid_engine.passes.lbvh.lbvh import LBVHBuilder

# float32 rounding of vertex coordinates around 10 scene units is ~1e-6; 1e-4 is a comfortable
# band in which the GPU may decide either way without hiding a wrong test.
BOUNDARY_TOLERANCE = 1e-4


def sat_overlap(tris: np.ndarray, center: np.ndarray, half: float) -> np.ndarray:
    """Triangle/axis-aligned-cube overlap by the 13 separating axes, in float64."""
    p = np.asarray(tris, dtype=np.float64) - np.asarray(center, dtype=np.float64)
    finite = np.isfinite(p).all(axis=(1, 2))
    p = np.where(finite[:, None, None], p, 0.0)
    edges = np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 1], p[:, 0] - p[:, 2]], axis=1)
    axes = [np.broadcast_to(np.eye(3)[k], (len(p), 3)) for k in range(3)]
    axes.append(np.cross(edges[:, 0], edges[:, 1]))
    for k in range(3):
        for e in range(3):
            axes.append(np.cross(np.eye(3)[k], edges[:, e]))
    overlap = finite.copy()
    for axis in axes:
        proj = np.einsum("nvk,nk->nv", p, axis)
        radius = half * np.abs(axis).sum(axis=1)
        overlap &= ~((proj.min(axis=1) > radius) | (proj.max(axis=1) < -radius))
    return overlap


def scene_with_objects(rng: np.random.Generator, objects: int, per_object: int, spread: float):
    """Clusters of random triangles, one object each, with their ranges and bounds."""
    centers = rng.uniform(-spread, spread, (objects, 1, 1, 3))
    tris = centers + rng.normal(0.0, 0.6, (objects, per_object, 3, 3))
    tris = tris.reshape(-1, 3, 3).astype(np.float32)
    ranges = np.stack([np.arange(objects) * per_object, np.full(objects, per_object)], axis=1)
    per_obj = tris.reshape(objects, per_object * 3, 3)
    bounds = np.stack([per_obj.min(axis=1), per_obj.max(axis=1)], axis=1)
    return tris, ranges, bounds


def assert_bracketed(kept: np.ndarray, tris: np.ndarray, center, half: float) -> None:
    must = np.flatnonzero(sat_overlap(tris, center, half - BOUNDARY_TOLERANCE))
    may = sat_overlap(tris, center, half + BOUNDARY_TOLERANCE)
    missing = np.setdiff1d(must, kept)
    extra = kept[~may[kept]]
    assert missing.size == 0, f"{missing.size} overlapping triangles dropped, e.g. {missing[:5]}"
    assert extra.size == 0, f"{extra.size} triangles outside the cube kept, e.g. {extra[:5]}"


def test_culling_keeps_exactly_the_triangles_overlapping_the_cube(ctx, rng):
    """Objects inside, outside and straddling: the kept set equals the exact SAT set."""
    tris, ranges, bounds = scene_with_objects(rng, objects=40, per_object=300, spread=6.0)
    culler = near_cube.NearCubeCuller(ctx)
    center = np.array([0.5, -0.25, 0.0])
    near_size = 3.0
    result = culler.cull_array(tris, center, near_size, ranges, bounds, margin=0.0)
    kept = result.read_indices()
    assert np.all(np.diff(kept) > 0), "compacted indices must be ascending and unique"
    assert_bracketed(kept, tris, center, near_size)
    assert result.objects_inside + result.objects_straddling + result.objects_outside == 40
    assert result.objects_straddling > 0 and result.objects_outside > 0


def test_candidate_list_holds_every_triangle_of_touching_objects_and_of_no_object(rng):
    """The host's list for stage 2 against brute force: objects touching the (slightly
    grown) cube, objects with non-finite bounds, overlapping ranges and triangles that
    belong to no object; far objects are left out."""
    count = 10000
    ranges = np.array([[0, 100], [100, 100], [150, 100], [400, 50], [600, 100], [700, 50],
                       [1000, 9000]], np.int64)
    lo = np.array([[-1, -1, -1], [20, 20, 20], [0.5, 0, 0], [30, 0, 0], [np.nan, 0, 0], [2.0, 0, 0],
                   [0, 0, -50]])
    hi = lo + 0.5
    hi[5] = (2.5, 0.5, 0.5)
    bounds = np.concatenate([lo, hi], axis=1)
    center = np.zeros(3)
    got = near_cube.candidate_triangles(count, ranges, bounds, center, 2.0)
    expected = set(range(0, 100)) | set(range(150, 250)) | set(range(600, 700)) | set(range(700, 750))
    expected |= set(range(250, 400)) | set(range(450, 600)) | set(range(750, 1000))  # no object
    assert len(expected) < near_cube.CANDIDATE_MAX_SHARE * count
    assert got is not None and got.dtype == np.uint32
    assert got.tolist() == sorted(expected)
    # Touching only by the slack: the object just beyond the cube's face is a candidate.
    bounds_edge = bounds.copy()
    bounds_edge[5, 0] = 2.0 + 1e-5
    assert 700 in near_cube.candidate_triangles(count, ranges, bounds_edge, center, 2.0)
    # Most of the scene near the cube: no list, stage 2 walks everything.
    assert near_cube.candidate_triangles(1000, np.array([[0, 1000]]), np.array([[-1, -1, -1, 1, 1, 1.0]]),
                                         center, 2.0) is None


def test_culling_a_wide_scene_through_the_candidate_list_keeps_exactly_the_overlapping_triangles(ctx, rng):
    """200 objects spread far beyond the cube plus loose triangles of no object: stage 2
    walks only candidates, and the kept set is still the exact SAT set."""
    tris, ranges, bounds = scene_with_objects(rng, objects=200, per_object=50, spread=40.0)
    loose = rng.uniform(-3, 3, (300, 3, 3)).astype(np.float32)
    tris = np.concatenate([tris, loose])
    center = np.array([0.25, 0.5, -0.5])
    half = 3.0
    candidates = near_cube.candidate_triangles(len(tris), ranges.astype(np.int64),
                                               bounds.reshape(-1, 6).astype(np.float64), center, half)
    assert candidates is not None and len(candidates) < len(tris) // 4
    result = near_cube.NearCubeCuller(ctx).cull_array(tris, center, half, ranges, bounds, margin=0.0)
    kept = result.read_indices()
    assert np.all(np.diff(kept) > 0)
    assert_bracketed(kept, tris, center, half)
    assert np.isin(np.arange(10000, 10300)[sat_overlap(loose, center, half - BOUNDARY_TOLERANCE)], kept).all()


def test_large_triangle_crossing_the_cube_with_every_vertex_outside_is_kept(ctx):
    """A centroid or vertex test would drop this triangle; the SAT test must keep it."""
    tris = np.array([[[-10.0, -0.5, 0.0], [10.0, -0.5, 0.0], [0.0, 20.0, 0.0]],
                     [[5.0, 5.0, 5.0], [6.0, 5.0, 5.0], [5.0, 6.0, 5.0]],
                     # outside near a corner, but overlapping the cube's bounding slabs
                     [[1.2, 1.2, -3.0], [3.0, 1.2, 3.0], [1.2, 3.0, 3.0]]], np.float32)
    culler = near_cube.NearCubeCuller(ctx)
    result = culler.cull_array(tris, (0, 0, 0), 1.0, margin=0.0)
    assert result.read_indices().tolist() == [0]


def test_the_overlap_is_the_same_share_of_the_near_cube_at_every_scale():
    """The scale scene's near cube (half-size and centre) at 1 mm, 1 m and 1 km: the BVH's
    overlap past the near planes scales with it, so the boundary between traced and marched
    surfaces lies at the same place in the picture (a floor in scene units moved it)."""
    near_size, center = 4.75, np.array([0.5, -5.0, 2.5])
    at_1m = near_cube.overlap_margin(near_size, center)
    for scale in (1e-3, 1e3):
        assert near_cube.overlap_margin(near_size * scale, center * scale) / scale == pytest.approx(at_1m, rel=1e-6)
    # Several float32 steps of the cube's coordinates, even for a tiny cube far from the origin.
    far_off = np.array([1.0e4, 0.0, 0.0])
    assert near_cube.overlap_margin(1e-3, far_off) > 8 * np.spacing(np.float32(1.0e4))


def test_overlap_margin_keeps_triangles_just_beyond_the_near_planes(ctx):
    """The paper's overlap: a triangle slightly outside the near plane is still in the BVH."""
    near_size = 2.0
    gap = 0.5 * near_cube.overlap_margin(near_size)
    tri = np.array([[[near_size + gap, -1, -1], [near_size + gap, 1, -1], [near_size + gap, 0, 1]]],
                   np.float32)
    culler = near_cube.NearCubeCuller(ctx)
    assert culler.cull_array(tri, (0, 0, 0), near_size).count == 1
    assert culler.cull_array(tri, (0, 0, 0), near_size, margin=0.0).count == 0


@pytest.mark.parametrize("count", [0, 1, 255, 256, 257, 2049])
def test_culling_sizes_across_chunk_boundaries(ctx, rng, count):
    """Sizes around the chunk and workgroup sizes compact correctly (no object ranges)."""
    tris = (rng.uniform(-3, 3, (count, 1, 3)) + rng.normal(0, 0.3, (count, 3, 3))).astype(np.float32)
    culler = near_cube.NearCubeCuller(ctx, triangles_per_chunk=64)
    result = culler.cull_array(tris, (0.1, 0.2, 0.3), 1.5, margin=0.0)
    kept = result.read_indices()
    assert kept.size == result.count
    assert_bracketed(kept, tris, np.array([0.1, 0.2, 0.3]), 1.5)


def test_object_fully_inside_is_kept_without_per_triangle_test_and_outside_dropped(ctx, rng):
    """Stage 1 decides whole objects; the counts report it."""
    inside = rng.uniform(-0.5, 0.5, (50, 3, 3)).astype(np.float32)
    outside = (rng.uniform(-0.5, 0.5, (50, 3, 3)) + 10).astype(np.float32)
    tris = np.concatenate([inside, outside])
    ranges = np.array([[0, 50], [50, 50]])
    bounds = np.stack([[t.reshape(-1, 3).min(0), t.reshape(-1, 3).max(0)] for t in (inside, outside)])
    result = near_cube.NearCubeCuller(ctx).cull_array(tris, (0, 0, 0), 1.0, ranges, bounds)
    assert (result.objects_inside, result.objects_outside, result.objects_straddling) == (1, 1, 0)
    assert result.read_indices().tolist() == list(range(50))


def test_non_finite_triangles_are_culled_and_do_not_disturb_others(ctx, rng):
    tris = rng.uniform(-1, 1, (300, 3, 3)).astype(np.float32)
    tris[7, 1, 2] = np.nan
    tris[100, 0, 0] = np.inf
    result = near_cube.NearCubeCuller(ctx).cull_array(tris, (0, 0, 0), 2.0, margin=0.0)
    kept = result.read_indices()
    expected = np.setdiff1d(np.arange(300), [7, 100])
    assert np.array_equal(kept, expected)


def test_empty_culled_set_builds_an_empty_bvh_whose_rays_all_miss(ctx, rng):
    """Nothing near the camera: the LBVH over zero triangles is valid and every ray misses."""
    tris = (rng.uniform(-1, 1, (500, 3, 3)) + 50).astype(np.float32)
    culler = near_cube.NearCubeCuller(ctx)
    result = culler.cull_array(tris, (0, 0, 0), 1.0)
    assert result.count == 0
    builder = LBVHBuilder(ctx)
    tri_buffer = ctx.buffer(tris.tobytes())
    try:
        builder.build(tri_buffer, result.count, result.indices)
        origins = rng.uniform(-1, 1, (256, 3)).astype(np.float32)
        dirs = rng.normal(size=(256, 3)).astype(np.float32)
        t, tri = builder.trace(origins, dirs)
        assert np.all(tri == -1) and np.all(np.isinf(t))
    finally:
        builder.release()
        tri_buffer.release()


def test_culled_bvh_reports_original_triangle_indices(ctx, rng):
    """Rays against the BVH of the culled set hit the same triangles as against all of them."""
    tris, ranges, bounds = scene_with_objects(rng, objects=20, per_object=200, spread=4.0)
    culler = near_cube.NearCubeCuller(ctx)
    result = culler.cull_array(tris, (0, 0, 0), 2.0, ranges, bounds)
    kept = result.read_indices()
    builder = LBVHBuilder(ctx)
    tri_buffer = ctx.buffer(tris.tobytes())
    try:
        builder.build(tri_buffer, result.count, result.indices)
        origins = rng.uniform(-0.5, 0.5, (2000, 3)).astype(np.float32)
        dirs = rng.normal(size=(2000, 3)).astype(np.float32)
        t, tri = builder.trace(origins, dirs)
        builder.build_from_array(tris[kept])
        t_ref, tri_ref = builder.trace(origins, dirs)
        hit = tri_ref >= 0
        assert np.array_equal(tri[hit], kept[tri_ref[hit]])
        assert np.array_equal(tri[~hit], tri_ref[~hit])
        assert np.allclose(t, t_ref)
    finally:
        builder.release()
        tri_buffer.release()


def test_repeated_culls_of_the_same_size_allocate_nothing(ctx, rng):
    tris = rng.uniform(-2, 2, (3000, 3, 3)).astype(np.float32)
    culler = near_cube.NearCubeCuller(ctx)
    culler.cull_array(tris, (0, 0, 0), 1.0)
    before = [g.allocations for g in vars(culler).values() if hasattr(g, "allocations")]
    for _ in range(3):
        culler.cull_array(tris, (0.1, 0, 0), 1.0)
    after = [g.allocations for g in vars(culler).values() if hasattr(g, "allocations")]
    assert before == after


def test_invalid_cube_is_rejected_with_a_clear_error(ctx):
    culler = near_cube.NearCubeCuller(ctx)
    tris = np.zeros((1, 3, 3), np.float32)
    with pytest.raises(ValueError, match="near_size"):
        culler.cull_array(tris, (0, 0, 0), 0.0)
    with pytest.raises(ValueError, match="centre"):
        culler.cull_array(tris, (np.nan, 0, 0), 1.0)


# A forced 100 KiB block limit splits a 10,000-triangle input (360 KB) into 4 blocks of 2816
# triangles, the layout that a 128 MiB block gives a scene of 11-15M triangles.
SPLIT_BLOCK_BYTES = 100 * 1024


def test_culling_a_scene_split_over_storage_blocks_keeps_the_same_triangles(ctx, rng):
    """Objects straddling the block boundaries: the kept list equals the unsplit one."""
    tris, ranges, bounds = scene_with_objects(rng, objects=25, per_object=400, spread=5.0)
    center = np.array([0.3, -0.2, 0.1])
    culler = near_cube.NearCubeCuller(ctx)
    whole = culler.cull_array(tris, center, 3.0, ranges, bounds, margin=0.0).read_indices()
    with gpu_dispatch.forced_limits(max_block=SPLIT_BLOCK_BYTES):
        assert triangle_input.input_split(len(tris)).blocks == 4
        split = culler.cull_array(tris, center, 3.0, ranges, bounds, margin=0.0)
        kept = split.read_indices()
        # Without objects every triangle takes the SAT test, in every block.
        kept_sat = culler.cull_array(tris, center, 3.0, margin=0.0).read_indices()
    assert np.array_equal(kept, whole) and np.array_equal(kept_sat, whole)
    assert (kept >= 3 * 2816).any() and (kept < 2816).any(), "the kept set should span blocks"
    assert_bracketed(kept, tris, center, 3.0)


def test_culled_build_over_a_split_scene_hits_what_the_unsplit_one_hits(ctx, rng):
    tris, ranges, bounds = scene_with_objects(rng, objects=25, per_object=400, spread=3.0)
    origins = rng.uniform(-0.5, 0.5, (3000, 3)).astype(np.float32)
    dirs = rng.normal(size=(3000, 3)).astype(np.float32)
    culler = near_cube.NearCubeCuller(ctx)
    builder = LBVHBuilder(ctx)
    tri_buffer = ctx.buffer(tris.tobytes())
    try:
        result = culler.cull(tri_buffer, len(tris), (0, 0, 0), 1.5, ranges, bounds)
        builder.build(tri_buffer, result.count, result.indices, input_count=len(tris))
        t, tri = builder.trace(origins, dirs)
        with gpu_dispatch.forced_limits(max_block=SPLIT_BLOCK_BYTES):
            result = culler.cull(tri_buffer, len(tris), (0, 0, 0), 1.5, ranges, bounds)
            built = builder.build(tri_buffer, result.count, result.indices, input_count=len(tris))
            assert built.node_split.blocks > 1 and triangle_input.input_split(len(tris)).blocks == 4
            t_split, tri_split = builder.trace(origins, dirs)
    finally:
        builder.release()
        tri_buffer.release()
    assert np.mean(tri >= 0) > 0.1
    assert np.array_equal(tri_split, tri) and np.array_equal(t_split, t)


def test_scene_past_four_input_blocks_is_refused_with_the_numbers(ctx, rng):
    tris = rng.uniform(-1, 1, (300, 3, 3)).astype(np.float32)
    culler = near_cube.NearCubeCuller(ctx)
    with gpu_dispatch.forced_limits(max_block=2304):  # 64 triangles per block, 256 in four
        assert len(culler.cull_array(tris[:256], (0, 0, 0), 1.0).read_indices()) > 0
        with pytest.raises(ValueError, match="input triangle buffer .* 5 storage blocks"):
            culler.cull_array(tris, (0, 0, 0), 1.0)
    assert culler.cull_array(tris, (0, 0, 0), 1.0).count > 0


@pytest.mark.parametrize("layout", ["all_tested", "candidates"])
def test_the_kept_count_never_exceeds_its_capacity_and_reaches_it_when_all_are_kept(ctx, rng, layout):
    """The LBVH build is sized by the cull's capacity (the triangles it tested) and reads the
    kept count on the GPU: the bound is exact, so no build can overflow. A cube around the
    whole scene keeps every tested triangle (count == capacity); a small one keeps fewer."""
    tris, ranges, bounds = scene_with_objects(rng, objects=30, per_object=100, spread=12.0)
    culler = near_cube.NearCubeCuller(ctx, triangles_per_chunk=64)
    use_objects = layout == "candidates"
    args = (ranges, bounds) if use_objects else ()
    whole = culler.cull_array(tris, (0, 0, 0), 100.0, *args)
    assert whole.kept.capacity == len(tris) and whole.count == len(tris)
    small = culler.cull_array(tris, bounds[0].mean(axis=0), 1.0, *args)  # around one object
    if use_objects:
        assert small.kept.capacity < len(tris), "the candidate list should bound the small cube's work"
    assert 0 < small.count <= small.kept.capacity
    assert small.read_indices().size == small.count
