# SPDX-License-Identifier: GPL-3.0-or-later
"""GPU LBVH (paper §3.3) against independent oracles.

* the numpy reference build (benchmarks/lbvh_reference.py): Morton codes bit for bit, the
  same Karras tree node for node;
* structural invariants checked on the GPU tree alone (reachability, box containment,
  permutation), which would catch a bug shared by both implementations;
* embreex closest hits for random soups, a tessellated scene and duplicate centroids.
"""
from __future__ import annotations

import numpy as np
import pytest

from benchmarks import lbvh_reference
from hybrid_engine.gpu import triangle_input, variants
from hybrid_engine.gpu import dispatch as gpu_dispatch
from hybrid_engine.passes.lbvh import lbvh
from benchmarks.bench import hit_agreement, mesh_like_scene, reflection_rays
from hybrid_engine.passes.lbvh.lbvh import NODE_DTYPE, TRIANGLE_DTYPE, LBVHBuilder, trace_closest

# The brief's bar for agreement with Embree: rays grazing a shared edge may pick either
# neighbour, a few in ten thousand at most.
MIN_AGREEMENT = 0.999
# Below this fraction of hitting rays an agreement figure would mostly count misses.
MIN_HIT_FRACTION = 0.1
SIZES = [0, 1, 2, 255, 256, 257, 2049, 100_003]
# The radix sort's shapes (hybrid_engine/gpu/radix_sort.py), forced through LBVHBuilder.
SORT_FAMILIES = ["cpu", "gpu"]


@pytest.fixture(scope="module")
def builder(gl):
    b = LBVHBuilder(gl)
    yield b
    b.release()


def random_soup(rng: np.random.Generator, count: int, size: float = 0.02) -> np.ndarray:
    centers = rng.random((count, 1, 3))
    return (centers + size * rng.standard_normal((count, 3, 3))).astype(np.float32)


def duplicate_centroid_scene(rng: np.random.Generator, count: int) -> np.ndarray:
    """Many triangles share one of a few centroids (equal Morton codes, Karras' tie-break)."""
    centers = rng.random((8, 3))[rng.integers(0, 8, count)]
    offsets = rng.standard_normal((count, 3, 3)) * 0.05
    offsets -= offsets.mean(axis=1, keepdims=True)  # the centroid is exactly the centre
    return (centers[:, None, :] + offsets).astype(np.float32)


def embree_closest(tris: np.ndarray, origins: np.ndarray, dirs: np.ndarray):
    from embreex import rtcore_scene
    from embreex.mesh_construction import TriangleMesh

    scene = rtcore_scene.EmbreeScene()
    TriangleMesh(scene, tris)
    res = scene.run(origins, dirs, output=1)
    return np.asarray(res["tfar"], np.float32), np.asarray(res["primID"], np.int32)


def assert_agrees_with_embree(tris: np.ndarray, origins: np.ndarray, dirs: np.ndarray,
                              t: np.ndarray, tri: np.ndarray) -> None:
    """The closest hits (t, tri) of these rays agree with Embree's, on rays enough of which
    hit something for the agreement to mean more than shared misses."""
    t_ref, tri_ref = embree_closest(tris, origins, dirs)
    assert np.mean(tri_ref >= 0) > MIN_HIT_FRACTION, "too few hits for a meaningful comparison"
    assert hit_agreement(t, tri, t_ref, tri_ref) >= MIN_AGREEMENT


def gpu_codes_per_triangle(built: lbvh.BuiltLBVH) -> np.ndarray:
    codes = np.empty(built.leaf_count, np.uint32)
    codes[built.read_leaf_primitives()] = built.read_sorted_keys()
    return codes


# -- Morton codes and the reference tree ----------------------------------------------------

@pytest.mark.parametrize("scene", ["soup", "flat", "huge", "tiny", "duplicates"])
def test_morton_codes_are_bit_identical_to_numpy(ctx, builder, rng, scene):
    """Every triangle's 30-bit code equals the reference's (only exact float ops are used)."""
    tris = random_soup(rng, 3000)
    if scene == "flat":
        tris[:, :, 2] = 0.25  # zero extent on z
    elif scene == "huge":
        tris = tris * np.float32(3e30) - np.float32(1e30)
    elif scene == "tiny":
        tris = tris * np.float32(1e-20)
    elif scene == "duplicates":
        tris = duplicate_centroid_scene(rng, 3000)
    built = builder.build_from_array(tris)
    np.testing.assert_array_equal(gpu_codes_per_triangle(built), lbvh_reference.morton_codes(tris))


@pytest.mark.parametrize("count", SIZES)
def test_tree_equals_reference_build(ctx, builder, rng, count):
    """Sizes straddling workgroups (64), sort chunks and blocks: same leaves, topology, boxes."""
    tris = random_soup(rng, count)
    built = builder.build_from_array(tris)
    ref = lbvh_reference.build(tris)
    nodes = built.read_nodes()
    np.testing.assert_array_equal(built.read_sorted_keys(), ref.sorted_codes)
    np.testing.assert_array_equal(built.read_leaf_primitives(), ref.leaf_primitives)
    np.testing.assert_array_equal(nodes["left_child"], ref.left_child)
    np.testing.assert_array_equal(nodes["right_child"], ref.right_child)
    np.testing.assert_array_equal(nodes["parent"], ref.parent)
    np.testing.assert_array_equal(nodes["left_min"], ref.child_min[:, 0])
    np.testing.assert_array_equal(nodes["left_max"], ref.child_max[:, 0])
    np.testing.assert_array_equal(nodes["right_min"], ref.child_min[:, 1])
    np.testing.assert_array_equal(nodes["right_max"], ref.child_max[:, 1])


@pytest.mark.parametrize("count", [1, 2, 257, 2049, 100_003])
@pytest.mark.parametrize("scene", ["soup", "duplicates"])
def test_either_sort_shape_builds_the_same_tree_as_the_reference(ctx, rng, scene, count):
    """The chunk-shaped and the tile-shaped radix sort (each with either histogram scan for
    the latter) give the same sorted codes, leaf order, nodes and leaf triangles, byte for
    byte, and the reference's: both are stable, so equal codes keep the triangles' order."""
    tris = random_soup(rng, count) if scene == "soup" else duplicate_centroid_scene(rng, count)
    ref = lbvh_reference.build(tris)
    results = []
    for sort_family, scan_family in (("cpu", None), ("gpu", "gpu"), ("gpu", "cpu")):
        builder = LBVHBuilder(ctx, sort_family=sort_family, scan_family=scan_family)
        try:
            built = builder.build_from_array(tris)
            assert builder.sorter.family == sort_family
            results.append((built.read_sorted_keys(), built.read_leaf_primitives(),
                            built.read_nodes().tobytes(), built.read_triangles().tobytes()))
        finally:
            builder.release()
    np.testing.assert_array_equal(results[0][0], ref.sorted_codes)
    np.testing.assert_array_equal(results[0][1], ref.leaf_primitives)
    for other in results[1:]:
        np.testing.assert_array_equal(other[0], results[0][0])
        np.testing.assert_array_equal(other[1], results[0][1])
        assert other[2] == results[0][2] and other[3] == results[0][3]


def test_a_builder_sorts_with_the_shape_the_variants_choose(ctx):
    renderer = ctx.info["GL_RENDERER"]
    variants.set_override("sort=gpu,scan=gpu")
    try:
        forced = LBVHBuilder(ctx)
    finally:
        variants.set_override(None)
    automatic = LBVHBuilder(ctx)
    try:
        assert (forced.sorter.family, forced.sorter.scan.family) == ("gpu", "gpu")
        assert automatic.sorter.family == variants.choose("sort", renderer=renderer)
    finally:
        forced.release()
        automatic.release()


# -- invariants on the GPU tree alone -------------------------------------------------------

def check_invariants(built: lbvh.BuiltLBVH, tris: np.ndarray) -> None:
    """Every leaf once, two children per inner node, parent box = union, leaves a permutation."""
    n = len(tris)
    nodes = built.read_nodes()
    bvh_tris = built.read_triangles()
    prims = built.read_leaf_primitives()
    assert sorted(prims.tolist()) == list(range(n)), "leaves are not a permutation of the input"
    np.testing.assert_array_equal(bvh_tris["prim"], prims)
    np.testing.assert_array_equal(np.stack([bvh_tris["v0"], bvh_tris["v1"], bvh_tris["v2"]], 1),
                                  tris[prims])
    if n < 2:
        return
    assert len(nodes) == n - 1
    leaf_visits = np.zeros(n, int)
    node_visits = np.zeros(n - 1, int)
    stack = [0]
    while stack:
        index = stack.pop()
        node_visits[index] += 1
        node = nodes[index]
        for side in ("left", "right"):
            ref = int(node[f"{side}_child"])
            lo, hi = node[f"{side}_min"], node[f"{side}_max"]
            if ref < 0:
                leaf_visits[~ref] += 1
                tri = tris[prims[~ref]]
                np.testing.assert_array_equal(lo, tri.min(axis=0))
                np.testing.assert_array_equal(hi, tri.max(axis=0))
            else:
                child = nodes[ref]
                assert int(child["parent"]) == index
                np.testing.assert_array_equal(lo, np.minimum(child["left_min"], child["right_min"]))
                np.testing.assert_array_equal(hi, np.maximum(child["left_max"], child["right_max"]))
                stack.append(ref)
    assert np.all(leaf_visits == 1), "some leaf is unreachable or reached twice"
    assert np.all(node_visits == 1), "some inner node is unreachable or reached twice"
    assert int(nodes[0]["parent"]) == -1
    assert int(nodes[0]["leaf_count"]) == n


@pytest.mark.parametrize("scene", ["soup", "mesh", "duplicates"])
def test_hierarchy_invariants(ctx, builder, rng, scene):
    if scene == "soup":
        tris = random_soup(rng, 5000)
    elif scene == "mesh":
        tris = mesh_like_scene(5000, rng, triangles_per_object=1200)
    else:
        tris = duplicate_centroid_scene(rng, 5000)
    check_invariants(builder.build_from_array(tris), tris)


def test_node_struct_bytes_read_back_at_documented_offsets(ctx, builder):
    """Two hand-placed triangles: the raw bytes match bvh_layout.glsl's offset table."""
    tris = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]],
                     [[5, 5, 5], [6, 5, 5], [5, 7, 5]]], np.float32)
    assert NODE_DTYPE.itemsize == 64 and TRIANGLE_DTYPE.itemsize == 48
    built = builder.build_from_array(tris)
    raw = built.nodes.read(size=64)
    words_f = np.frombuffer(raw, "<f4")
    words_i = np.frombuffer(raw, "<i4")
    # Two leaves, one root: left = leaf 0 (the lower Morton code: triangle 0), right = leaf 1.
    assert words_i[3] == ~0 and words_i[7] == ~1 and words_i[11] == -1 and words_i[15] == 2
    np.testing.assert_array_equal(words_f[0:3], [0, 0, 0])
    np.testing.assert_array_equal(words_f[4:7], [1, 1, 0])
    np.testing.assert_array_equal(words_f[8:11], [5, 5, 5])
    np.testing.assert_array_equal(words_f[12:15], [6, 7, 5])
    tri_raw = built.triangles.read(size=96)
    tri_f = np.frombuffer(tri_raw, "<f4")
    tri_i = np.frombuffer(tri_raw, "<i4")
    np.testing.assert_array_equal(tri_f[12 + 4:12 + 7], [6, 5, 5])  # leaf 1, v1
    assert tri_i[3] == 0 and tri_i[12 + 3] == 1 and tri_i[7] == 0 and tri_i[11] == 0


# -- closest hits against Embree ------------------------------------------------------------

@pytest.mark.parametrize("scene", ["soup", "mesh", "duplicates"])
def test_closest_hits_agree_with_embree(ctx, rng, scene):
    if scene == "soup":
        tris = random_soup(rng, 20_000)
        origins = rng.random((20_000, 3)).astype(np.float32)
        dirs = rng.standard_normal((20_000, 3)).astype(np.float32)
    elif scene == "mesh":
        tris = mesh_like_scene(40_000, rng, triangles_per_object=4_000)
        origins, dirs = reflection_rays(tris, 20_000, rng)
    else:
        tris = duplicate_centroid_scene(rng, 20_000)
        origins = rng.random((20_000, 3)).astype(np.float32)
        dirs = rng.standard_normal((20_000, 3)).astype(np.float32)
    t, tri = trace_closest(tris, origins, dirs)
    assert t.dtype == np.float32 and tri.dtype == np.int32
    assert np.all(np.isinf(t[tri == -1])) and np.all(np.isfinite(t[tri >= 0]))
    assert_agrees_with_embree(tris, origins, dirs, t, tri)


@pytest.mark.parametrize("count", SIZES)
def test_closest_hits_agree_with_embree_across_sizes(ctx, rng, count):
    tris = random_soup(rng, count, size=0.05)
    origins = rng.random((3000, 3)).astype(np.float32)
    dirs = rng.standard_normal((3000, 3)).astype(np.float32)
    t, tri = trace_closest(tris, origins, dirs)
    if count == 0:
        assert np.all(tri == -1) and np.all(np.isinf(t))
        return
    t_ref, tri_ref = embree_closest(tris, origins, dirs)
    assert hit_agreement(t, tri, t_ref, tri_ref) >= MIN_AGREEMENT


def test_ray_through_a_shared_edge_hits_exactly_one_triangle(ctx):
    """Watertightness: rays aimed exactly at the diagonal of a quad never slip through."""
    quad = np.array([[[0, 0, 0], [1, 0, 0], [1, 1, 0]], [[0, 0, 0], [1, 1, 0], [0, 1, 0]]],
                    np.float32)
    s = np.linspace(0.01, 0.99, 99, dtype=np.float32)
    origins = np.stack([s, s, np.ones_like(s)], axis=1)
    dirs = np.tile(np.array([[0, 0, -1]], np.float32), (len(s), 1))
    t, tri = trace_closest(quad, origins, dirs)
    assert np.all(tri >= 0)
    np.testing.assert_allclose(t, 1.0)


def test_non_finite_and_degenerate_triangles_do_not_poison_other_rays(ctx, rng):
    """NaN/inf vertices and zero-area triangles: the build survives, other hits are unchanged."""
    good = random_soup(rng, 4000)
    bad = good.copy()
    bad[10, 0, 0] = np.nan
    bad[20, 1, 1] = np.inf
    bad[30, 2, 2] = -np.inf
    bad[40] = bad[40, 0]  # a point
    bad[50, 2] = bad[50, 0] + 2 * (bad[50, 1] - bad[50, 0])  # collinear
    origins = rng.random((5000, 3)).astype(np.float32)
    dirs = rng.standard_normal((5000, 3)).astype(np.float32)
    t, tri = trace_closest(bad, origins, dirs)
    assert not np.isin(tri, [10, 20, 30, 40, 50]).any()
    keep = np.setdiff1d(np.arange(4000), [10, 20, 30, 40, 50])
    t_ref, tri_ref = embree_closest(good[keep], origins, dirs)
    tri_ref = np.where(tri_ref >= 0, keep[np.maximum(tri_ref, 0)], -1).astype(np.int32)
    assert hit_agreement(t, tri, t_ref, tri_ref) >= MIN_AGREEMENT
    # Rays with NaN components simply miss.
    t_nan, tri_nan = trace_closest(good, np.full((3, 3), np.nan, np.float32), dirs[:3])
    assert np.all(tri_nan == -1)


@pytest.mark.parametrize("sort_family", SORT_FAMILIES)
def test_sorted_and_unsorted_ray_orders_give_the_same_hits_as_embree(ctx, rng, sort_family):
    """Tracing the rays in their origins' Morton order (ray_keys.comp.glsl) changes only the
    order in which the invocations run: every ray's hit is bit for bit the same, and Embree's,
    whichever shape of radix sort ordered the triangles and the rays."""
    tris = mesh_like_scene(40_000, rng, triangles_per_object=4_000)
    origins, dirs = reflection_rays(tris, 8000, rng)
    builder = LBVHBuilder(ctx, sort_family=sort_family)
    try:
        builder.build_from_array(tris)
        t_sorted, tri_sorted = builder.trace(origins, dirs, sort_rays=True)
        t_plain, tri_plain = builder.trace(origins, dirs, sort_rays=False)
    finally:
        builder.release()
    np.testing.assert_array_equal(tri_sorted, tri_plain)
    np.testing.assert_array_equal(t_sorted, t_plain)
    assert_agrees_with_embree(tris, origins, dirs, t_sorted, tri_sorted)


def ray_keys_reference(origins: np.ndarray, root) -> np.ndarray:
    """ray_keys.comp.glsl in numpy: 8 bits per axis of the origin in the root box (float32
    arithmetic as on the GPU; a flat axis gets cell 0), interleaved x y z from the top bit;
    non-finite origins get 0."""
    lo = np.minimum(root["left_min"], root["right_min"]).astype(np.float32)
    hi = np.maximum(root["left_max"], root["right_max"]).astype(np.float32)
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        scale = np.float32(256.0) / (hi - lo)
        scale = np.where((hi - lo > 0) & np.isfinite(scale), scale, np.float32(0.0))
        cells = np.clip((origins - lo) * scale, np.float32(0.0), np.float32(255.0))
    q = np.nan_to_num(cells).astype(np.uint32)
    keys = np.zeros(len(origins), np.uint32)
    for bit in range(8):
        for axis in range(3):
            keys |= ((q[:, axis] >> bit) & 1) << (3 * bit + 2 - axis)
    return np.where(np.isfinite(origins).all(axis=1), keys, 0).astype(np.uint32)


@pytest.mark.parametrize("sort_family", SORT_FAMILIES)
@pytest.mark.parametrize("scene", ["soup", "flat"])
def test_ray_order_sorts_the_rays_stably_by_the_morton_code_of_their_origins(ctx, rng, scene, sort_family):
    """The order the sorted trace uses is a permutation of the rays, stably sorted by a Morton
    code recomputed in numpy; origins outside the root box clamp to it, non-finite ones go
    first, and a flat scene (zero extent in z) puts every ray in cell 0 along z."""
    tris = random_soup(rng, 5000)
    if scene == "flat":
        tris[:, :, 2] = 0.5
    origins = rng.uniform(-0.3, 1.3, (5000, 3)).astype(np.float32)
    origins[::500] = np.nan
    builder = LBVHBuilder(ctx, sort_family=sort_family)
    origin_buffer = ctx.buffer(origins.tobytes())
    try:
        built = builder.build_from_array(tris)
        order_buffer = builder._order_rays(origin_buffer, len(origins))
        order = np.frombuffer(order_buffer.read(size=len(origins) * 4), np.uint32)
        root = built.read_nodes()[0]
    finally:
        builder.release()
        origin_buffer.release()
    keys = ray_keys_reference(origins, root)
    assert len(np.unique(keys)) > 1000, "the keys should tell the rays apart"
    np.testing.assert_array_equal(np.sort(order), np.arange(len(origins)))
    np.testing.assert_array_equal(order, np.argsort(keys, kind="stable"))


def test_trace_closest_rejects_bad_shapes(ctx):
    with pytest.raises(ValueError, match="triangles"):
        trace_closest(np.zeros((4, 3)), np.zeros((1, 3)), np.ones((1, 3)))
    with pytest.raises(ValueError, match="origins"):
        trace_closest(np.zeros((1, 3, 3)), np.zeros((1, 4)), np.ones((1, 3)))
    with pytest.raises(ValueError, match="differ"):
        trace_closest(np.zeros((1, 3, 3)), np.zeros((2, 3)), np.ones((1, 3)))


# -- limits and buffer reuse ----------------------------------------------------------------

def test_dispatch_grid_splits_beyond_the_workgroup_limit():
    with gpu_dispatch.forced_limits(max_groups=7):
        assert gpu_dispatch.grid_for(7) == (7, 1)
        assert gpu_dispatch.grid_for(8) == (7, 2)
        assert gpu_dispatch.grid_for(49) == (7, 7)
        with pytest.raises(ValueError, match="exceeds"):
            gpu_dispatch.grid_for(50)


def test_build_and_trace_with_split_dispatches_match_unsplit(ctx, rng):
    """Forcing 3 groups per dimension turns every pass into a 2D dispatch; results are equal."""
    tris = random_soup(rng, 9000)
    origins = rng.random((6000, 3)).astype(np.float32)
    dirs = rng.standard_normal((6000, 3)).astype(np.float32)
    builder = LBVHBuilder(ctx)
    try:
        built = builder.build_from_array(tris)
        nodes, keys = built.read_nodes(), built.read_sorted_keys()
        t, tri = builder.trace(origins, dirs)
        with gpu_dispatch.forced_limits(max_groups=12):
            split = builder.build_from_array(tris)
            np.testing.assert_array_equal(split.read_nodes(), nodes)
            np.testing.assert_array_equal(split.read_sorted_keys(), keys)
            t_split, tri_split = builder.trace(origins, dirs)
    finally:
        builder.release()
    np.testing.assert_array_equal(tri_split, tri)
    np.testing.assert_array_equal(t_split, t)


def test_repeated_builds_of_the_same_size_allocate_nothing(ctx, rng):
    builder = LBVHBuilder(ctx)
    try:
        tris = random_soup(rng, 5000)
        builder.build_from_array(tris)
        builder.trace(tris[:100, 0], np.ones((100, 3), np.float32))
        grows = [g for g in vars(builder).values() if isinstance(g, gpu_dispatch.GrowBuffer)]
        grows += [g for pair in (builder._keys, builder._values, builder._rays, builder._hits)
                  for g in pair]
        before = [g.allocations for g in grows]
        for _ in range(3):
            builder.build_from_array(random_soup(rng, 5000))
            builder.build_from_array(random_soup(rng, 3000))  # smaller: reuses too
            builder.trace(tris[:100, 0], np.ones((100, 3), np.float32))
        assert [g.allocations for g in grows] == before
    finally:
        builder.release()


# -- arrays split over several storage blocks ------------------------------------------------
# A forced block limit makes a small scene span several blocks, which exercises exactly the
# code that a 128 MiB block needs beyond 2.1M triangles: 200 KiB blocks hold 3200 nodes,
# 4224 BVH triangles or 5632 input triangles, so 10,000 triangles take 4, 3 and 2 blocks.
SPLIT_BLOCK_BYTES = 200 * 1024
# 120 KiB: 1920 nodes / 2560 triangles / 3392 inputs per block -> 6,000 triangles take 4, 3, 2.
SPLIT_BLOCK_BYTES_SMALL = 120 * 1024


def test_block_split_covers_the_array_with_aligned_ranges():
    with gpu_dispatch.forced_limits(max_block=SPLIT_BLOCK_BYTES):
        nodes = gpu_dispatch.split_blocks(9_999, 64, "nodes")
        assert (nodes.blocks, nodes.items_per_block) == (4, 3200)
        ranges = nodes.ranges()
        assert [offset for offset, _ in ranges] == [0, 3200 * 64, 6400 * 64, 9600 * 64]
        assert sum(size for _, size in ranges) == 9_999 * 64
        assert all(offset % 256 == 0 and size <= SPLIT_BLOCK_BYTES for offset, size in ranges)
        assert gpu_dispatch.split_blocks(3200, 64, "nodes").blocks == 1  # exactly one block
        assert gpu_dispatch.split_blocks(3200, 64, "nodes").defines("A", "B") == {}
        assert nodes.defines("A", "B") == {"A": 4, "B": 3200}
        with pytest.raises(ValueError, match="needs 5 storage blocks"):
            gpu_dispatch.split_blocks(4 * 3200 + 1, 64, "nodes")


@pytest.mark.parametrize(("scene", "block_bytes", "blocks"), [
    ("soup", SPLIT_BLOCK_BYTES, (4, 3, 2)),
    ("mesh", SPLIT_BLOCK_BYTES, (4, 3, 2)),
    ("soup", 240 * 1024, (3, 2, 2)),
    ("soup", 320 * 1024, (2, 2, 2)),
])
def test_build_split_over_storage_blocks_equals_the_unsplit_build_and_embree(
        ctx, rng, scene, block_bytes, blocks):
    """Nodes, BVH triangles and input in (nodes, triangles, input) blocks: same tree, same hits,
    bit for bit."""
    if scene == "soup":
        tris = random_soup(rng, 10_000)
        origins = rng.random((8000, 3)).astype(np.float32)
        dirs = rng.standard_normal((8000, 3)).astype(np.float32)
    else:
        tris = mesh_like_scene(10_000, rng, triangles_per_object=2_000)
        origins, dirs = reflection_rays(tris, 8000, rng)
    builder = LBVHBuilder(ctx)
    try:
        whole = builder.build_from_array(tris)
        assert whole.traversal_defines() == {}
        nodes, bvh_tris, prims = whole.read_nodes(), whole.read_triangles(), whole.read_leaf_primitives()
        t, tri = builder.trace(origins, dirs)
        with gpu_dispatch.forced_limits(max_block=block_bytes):
            split = builder.build_from_array(tris)
            assert (split.node_split.blocks, split.triangle_split.blocks,
                    triangle_input.input_split(len(tris)).blocks) == blocks
            assert split.traversal_defines()["BVH_NODE_BLOCKS"] == blocks[0]
            t_split, tri_split = builder.trace(origins, dirs)
            np.testing.assert_array_equal(split.read_nodes(), nodes)
            np.testing.assert_array_equal(split.read_triangles(), bvh_tris)
            np.testing.assert_array_equal(split.read_leaf_primitives(), prims)
            check_invariants(split, tris)
    finally:
        builder.release()
    np.testing.assert_array_equal(tri_split, tri)
    np.testing.assert_array_equal(t_split, t)
    assert_agrees_with_embree(tris, origins, dirs, t_split, tri_split)


def test_split_build_over_an_index_list_reads_the_split_input(ctx, rng):
    """A culled-style build (indices into a larger input) with the input in 3 blocks and the
    BVH in 2-3: hits equal those of the unsplit build, in original triangle indices."""
    tris = random_soup(rng, 10_000)
    picked = np.sort(rng.choice(len(tris), 6_000, replace=False)).astype(np.uint32)
    origins = rng.random((6000, 3)).astype(np.float32)
    dirs = rng.standard_normal((6000, 3)).astype(np.float32)
    builder = LBVHBuilder(ctx)
    tri_buffer = ctx.buffer(tris.tobytes())
    index_buffer = ctx.buffer(picked.tobytes())
    try:
        builder.build(tri_buffer, len(picked), index_buffer, input_count=len(tris))
        t, tri = builder.trace(origins, dirs)
        with gpu_dispatch.forced_limits(max_block=SPLIT_BLOCK_BYTES_SMALL):
            split = builder.build(tri_buffer, len(picked), index_buffer, input_count=len(tris))
            assert triangle_input.input_split(len(tris)).blocks == 3
            assert split.node_split.blocks == 4 and split.triangle_split.blocks == 3
            t_split, tri_split = builder.trace(origins, dirs)
    finally:
        builder.release()
        tri_buffer.release()
        index_buffer.release()
    assert np.isin(tri[tri >= 0], picked).all() and np.mean(tri >= 0) > MIN_HIT_FRACTION
    np.testing.assert_array_equal(tri_split, tri)
    np.testing.assert_array_equal(t_split, t)


def test_repeated_split_builds_compile_nothing_new(ctx, rng):
    """Programs are cached per block count: the second and later frames compile nothing."""
    from hybrid_engine.gpu import shader_loader

    builder = LBVHBuilder(ctx)
    try:
        with gpu_dispatch.forced_limits(max_block=SPLIT_BLOCK_BYTES):
            builder.build_from_array(random_soup(rng, 10_000))
            builder.trace(np.zeros((4, 3), np.float32), np.ones((4, 3), np.float32))
            programs = len(shader_loader._cache)
            for _ in range(3):
                builder.build_from_array(random_soup(rng, 10_000))
                builder.trace(np.zeros((4, 3), np.float32), np.ones((4, 3), np.float32))
            assert len(shader_loader._cache) == programs
    finally:
        builder.release()


def test_build_past_four_blocks_fails_cleanly_and_the_builder_stays_usable(ctx, rng):
    """With a (forced) 8 KiB block limit, four blocks hold 512 BVH triangles (128 per block)
    and 513 leaves' nodes; 600 triangles are refused with the numbers."""
    builder = LBVHBuilder(ctx)
    try:
        with gpu_dispatch.forced_limits(max_block=8192):
            assert lbvh.max_build_triangles() == 512
            fits = random_soup(rng, 512)
            built = builder.build_from_array(fits)
            assert built.node_split.blocks == 4 and built.triangle_split.blocks == 4
            check_invariants(built, fits)
            with pytest.raises(ValueError, match="GL_MAX_SHADER_STORAGE_BLOCK_SIZE"):
                builder.build_from_array(random_soup(rng, 600))
        tris = random_soup(rng, 300)
        check_invariants(builder.build_from_array(tris), tris)
    finally:
        builder.release()


@pytest.mark.slow
def test_real_size_scene_culls_at_10_5m_and_builds_6_5m_triangles_agreeing_with_embree(ctx):
    """The sizes the project renders: a 10.5M-triangle scene (input in 3 real 128 MiB blocks)
    culled and built, and a 6.5M-triangle BVH (nodes in 4 blocks, triangles in 3) traced
    against Embree. About 30 s and 3 GiB on llvmpipe."""
    from hybrid_engine.passes.near_cube_cull import near_cube
    from test_near_cube import BOUNDARY_TOLERANCE, sat_overlap

    # Drivers with larger blocks (2 GiB on some) bind these arrays whole; the checks of the
    # results hold either way.
    limit = gpu_dispatch.max_block_bytes()
    scene_count, per_object, bvh_count = 10_500_000, 20_000, 6_500_000
    rng = np.random.default_rng(7)
    tris = mesh_like_scene(scene_count, rng, triangles_per_object=per_object)
    objects = scene_count // per_object
    ranges = np.stack([np.arange(objects) * per_object, np.full(objects, per_object)], 1)
    per_obj = tris.reshape(objects, per_object * 3, 3)
    bounds = np.stack([per_obj.min(1), per_obj.max(1)], 1)
    tri_buffer = ctx.buffer(tris.tobytes())
    culler = near_cube.NearCubeCuller(ctx)
    builder = LBVHBuilder(ctx)
    try:
        # Culling: every sampled triangle decided as the float64 SAT test decides it.
        center, near_size = np.array([0.5, -0.5, 0.25]), 6.0
        result = culler.cull(tri_buffer, scene_count, center, near_size, ranges, bounds)
        assert triangle_input.input_split(scene_count).blocks == -(-scene_count * 36 // limit) or limit > 2**27
        kept = result.read_indices()
        assert np.all(np.diff(kept) > 0)
        half = near_size + near_cube.overlap_margin(near_size)
        sample = np.sort(rng.choice(scene_count, 300_000, replace=False))
        must = sample[sat_overlap(tris[sample], center, half - BOUNDARY_TOLERANCE)]
        may = sample[sat_overlap(tris[sample], center, half + BOUNDARY_TOLERANCE)]
        assert np.isin(must, kept).all() and np.isin(sample[np.isin(sample, kept)], may).all()
        assert kept.max() > 2 * scene_count // 3, "kept triangles should lie in every block"
        # The culled BVH over the split scene, in original indices.
        builder.build(tri_buffer, result.count, result.indices, input_count=scene_count)
        culled = tris[kept]
        origins, dirs = reflection_rays(culled, 50_000, rng)
        t, tri = builder.trace(origins, dirs)
        t_ref, tri_ref = embree_closest(culled, origins, dirs)
        tri_ref = np.where(tri_ref >= 0, kept[np.maximum(tri_ref, 0)], -1).astype(np.int32)
        assert np.mean(tri_ref >= 0) > MIN_HIT_FRACTION
        assert hit_agreement(t, tri, t_ref, tri_ref) >= MIN_AGREEMENT
        del culled
        # A 6.5M-triangle BVH: nodes and triangles split.
        built = builder.build(tri_buffer, bvh_count)
        assert (built.node_split.blocks, built.triangle_split.blocks) == (4, 3) or limit > 2**27
        big = tris[:bvh_count]
        origins, dirs = reflection_rays(big, 50_000, rng)
        t, tri = builder.trace(origins, dirs)
        t_ref, tri_ref = embree_closest(big, origins, dirs)
        assert np.mean(tri_ref >= 0) > MIN_HIT_FRACTION
        assert hit_agreement(t, tri, t_ref, tri_ref) >= MIN_AGREEMENT
    finally:
        builder.release()
        culler.release()
        tri_buffer.release()


# -- a count that stays on the GPU ----------------------------------------------------------

def built_arrays(built: lbvh.BuiltLBVH) -> dict[str, np.ndarray]:
    return {"nodes": built.read_nodes(), "keys": built.read_sorted_keys(), "leaves": built.read_leaf_primitives(),
            "triangles": built.read_triangles()}


@pytest.mark.parametrize("count, capacity", [(0, 0), (0, 5), (1, 1), (1, 300), (2, 2), (2, 7), (257, 257),
                                             (300, 5000), (4097, 4500)])
def test_build_from_a_gpu_resident_count_equals_the_build_from_the_host_count(ctx, builder, rng, count, capacity):
    """The cull's kept count stays on the GPU: a build sized for a larger capacity, reading the
    count where it lies, gives the same tree, keys, leaves and triangles as a build given the
    count on the host, whatever the index list holds past the count."""
    from hybrid_engine.gpu.device_count import DeviceCount

    tris = random_soup(rng, 6000)
    tri_buffer = ctx.buffer(tris.tobytes())
    # The first `count` indices are the kept triangles; the rest is what a cull leaves behind.
    indices = rng.choice(len(tris), size=max(capacity, 1), replace=False).astype(np.uint32)
    index_buffer = ctx.buffer(indices.tobytes())
    count_buffer = ctx.buffer(np.array([7, 9, count, 11], np.uint32).tobytes())
    try:
        expected = built_arrays(builder.build(tri_buffer, count, index_buffer, input_count=len(tris)))
        built = builder.build(tri_buffer, DeviceCount(count_buffer, 8, capacity), index_buffer, input_count=len(tris))
        assert built.known_count is None and built.capacity == capacity
        assert built.leaf_count == count
        got = built_arrays(built)
    finally:
        for buffer in (tri_buffer, index_buffer, count_buffer):
            buffer.release()
    for name in expected:
        np.testing.assert_array_equal(got[name], expected[name], err_msg=name)
    if count >= 2:
        check_invariants_of(got, tris[indices[:count]], indices[:count])


def check_invariants_of(arrays: dict[str, np.ndarray], tris: np.ndarray, prims: np.ndarray) -> None:
    """The tree over ``tris`` (the build's elements, original indices ``prims``) reaches every
    leaf once and its root covers them all."""
    nodes = arrays["nodes"]
    assert sorted(arrays["leaves"].tolist()) == sorted(prims.tolist())
    assert int(nodes[0]["leaf_count"]) == len(tris)
    lo = np.minimum(nodes[0]["left_min"], nodes[0]["right_min"])
    hi = np.maximum(nodes[0]["left_max"], nodes[0]["right_max"])
    np.testing.assert_array_equal(lo, tris.reshape(-1, 3).min(axis=0))
    np.testing.assert_array_equal(hi, tris.reshape(-1, 3).max(axis=0))


def test_a_gpu_count_build_traces_the_same_hits_as_the_host_count_build(ctx, builder, rng):
    """Rays see only the first `count` elements of a capacity-sized build."""
    from hybrid_engine.gpu.device_count import DeviceCount

    tris = random_soup(rng, 3000, size=0.05)
    origins = rng.random((2000, 3)).astype(np.float32)
    dirs = rng.standard_normal((2000, 3)).astype(np.float32)
    tri_buffer = ctx.buffer(tris.tobytes())
    index_buffer = ctx.buffer(np.arange(len(tris), dtype=np.uint32).tobytes())
    count_buffer = ctx.buffer(np.array([1800], np.uint32).tobytes())
    try:
        builder.build(tri_buffer, 1800, index_buffer, input_count=len(tris))
        expected = builder.trace(origins, dirs)
        builder.build(tri_buffer, DeviceCount(count_buffer, 0, len(tris)), index_buffer, input_count=len(tris))
        got = builder.trace(origins, dirs)
    finally:
        for buffer in (tri_buffer, index_buffer, count_buffer):
            buffer.release()
    assert np.mean(expected[1] >= 0) > MIN_HIT_FRACTION
    np.testing.assert_array_equal(got[0], expected[0])
    np.testing.assert_array_equal(got[1], expected[1])
    assert expected[1].max() < 1800
