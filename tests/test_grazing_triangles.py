# SPDX-License-Identifier: GPL-3.0-or-later
"""The near cube's grazing triangles (hybrid_engine/passes/diffuse_light/grazing.py) against a
numpy oracle over the built BVH's leaves: the list holds exactly the leaves that reach far
beyond the near cube in a plane close to its centre, and counts them past its capacity."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine.passes.diffuse_light import grazing
from hybrid_engine.passes.diffuse_light.grazing import GrazingTriangles
from hybrid_engine.passes.lbvh.lbvh import LBVHBuilder

CENTER = np.array([0.3, -0.2, 0.1])
HALF = 2.0


@pytest.fixture(scope="module")
def builder(gl):
    b = LBVHBuilder(gl)
    yield b
    b.release()


@pytest.fixture(scope="module")
def lists(gl):
    g = GrazingTriangles(gl)
    yield g
    g.release()


def plane_reach(tris: np.ndarray) -> np.ndarray:
    """How far each triangle's plane passes from CENTER."""
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    return np.abs(np.einsum("ij,ij->i", n, tris[:, 0] - CENTER)) / np.linalg.norm(n, axis=1)


def outside_and_steps(tris: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """How far each triangle reaches outside the near cube, and its plane's distance from the
    centre in the list's bin steps (GRAZING_BINS steps make PLANE_REACH), in float64."""
    tris = tris.astype(np.float64)
    lo, hi = tris.min(axis=1) - CENTER, tris.max(axis=1) - CENTER
    outside = np.maximum(hi - HALF, -HALF - lo).max(axis=1)
    return outside, plane_reach(tris) / (grazing.PLANE_REACH * HALF) * grazing.GRAZING_BINS


def grazing_bins(leaves: np.ndarray) -> np.ndarray:
    """grazing.py's rule over the leaves (rows of (3, 3) corners, leaf order): each leaf's bin
    of its plane's distance from the centre, -1 where it does not graze."""
    outside, steps = outside_and_steps(leaves)
    bins = np.minimum(steps.astype(int), grazing.GRAZING_BINS - 1)
    return np.where((outside > grazing.BEYOND * HALF) & (steps <= grazing.GRAZING_BINS), bins, -1)


def oracle(leaves: np.ndarray) -> set[int]:
    return set(np.flatnonzero(grazing_bins(leaves) >= 0).tolist())


def leaf_corners(built) -> np.ndarray:
    rows = built.read_triangles()
    return np.stack([rows["v0"], rows["v1"], rows["v2"]], axis=1)


def plane_triangle(rng, reach: float, size: float) -> np.ndarray:
    """A triangle of about ``size`` in a random plane ``reach`` from CENTER."""
    normal = rng.standard_normal(3)
    normal /= np.linalg.norm(normal)
    u = np.cross(normal, rng.standard_normal(3))
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    foot = CENTER + reach * normal
    corners = [foot + size * (a * u + b * v) for a, b in rng.uniform(-1.0, 1.0, (3, 2))]
    return np.array(corners)


def mixed_scene(rng, grazing_count: int) -> np.ndarray:
    """Small triangles inside the near cube, large ones in planes far from its centre, and
    large ones in planes near it (about ``grazing_count`` of them grazing), kept only where
    they stand clear of the rule's two thresholds, so that float rounding cannot decide."""
    tris = [CENTER + rng.uniform(-1.5, 1.5, (1, 3)) + 0.05 * rng.standard_normal((3, 3)) for _ in range(300)]
    tris += [plane_triangle(rng, rng.uniform(0.8, 1.8), rng.uniform(3.0, 8.0)) for _ in range(40)]
    tris += [plane_triangle(rng, rng.uniform(0.0, 0.4), rng.uniform(2.0, 8.0)) for _ in range(grazing_count)]
    scene = np.array(tris)
    outside, steps = outside_and_steps(scene)
    clear = (np.abs(outside - grazing.BEYOND * HALF) > 1e-3) & (np.abs(steps - np.round(steps)) > 1e-3)
    return scene[clear].astype(np.float32)


def test_the_list_holds_exactly_the_leaves_that_reach_far_beyond_the_near_cube_in_a_plane_near_its_centre(builder, lists):
    rng = np.random.default_rng(7)
    built = builder.build_from_array(mixed_scene(rng, 30))
    lists.collect(built, CENTER, HALF)
    expected = oracle(leaf_corners(built))
    # The scene holds all three kinds: grazing, straddling in a plane far from the centre,
    # and inside.
    assert 5 <= len(expected) <= grazing.GRAZING_CAPACITY, len(expected)
    listed = lists.read()
    assert lists.read_count() == len(expected)
    assert len(set(listed.tolist())) == len(listed)
    assert set(listed.tolist()) == expected


def test_nothing_is_listed_where_no_triangle_reaches_beyond_the_near_cube(builder, lists):
    rng = np.random.default_rng(3)
    # Large triangles in planes through the centre, but wholly inside the near cube.
    inside = [plane_triangle(rng, 0.0, 0.5) for _ in range(50)]
    built = builder.build_from_array(np.array(inside, np.float32))
    assert oracle(leaf_corners(built)) == set()
    lists.collect(built, CENTER, HALF)
    assert lists.read_count() == 0


def test_a_list_past_its_capacity_keeps_the_leaves_whose_planes_pass_nearest_the_centre(builder, lists):
    rng = np.random.default_rng(11)
    built = builder.build_from_array(mixed_scene(rng, 3 * grazing.GRAZING_CAPACITY))
    lists.collect(built, CENTER, HALF)
    bins = grazing_bins(leaf_corners(built))
    grazing_leaves = np.flatnonzero(bins >= 0)
    assert len(grazing_leaves) > grazing.GRAZING_CAPACITY
    assert lists.read_count() == len(grazing_leaves)
    listed = lists.read()
    assert len(listed) == len(set(listed.tolist())) == grazing.GRAZING_CAPACITY
    assert set(listed.tolist()) <= set(grazing_leaves.tolist())
    # Nearest first: no leaf left out lies in a nearer bin than one listed, and the bins
    # wholly listed are every leaf of theirs.
    left_out = np.setdiff1d(grazing_leaves, listed)
    assert bins[left_out].min() >= bins[listed].max()
    whole = bins[listed] < bins[listed].max()
    assert np.sum(whole) == np.sum(bins[grazing_leaves] < bins[listed].max())


def test_the_list_reads_a_bvh_split_over_storage_blocks(gl, lists):
    # 200 KiB blocks hold 4224 BVH triangles (tests/test_lbvh.py): 10,000 take three, as a
    # 128 MiB block's past 2.8M triangles.
    from hybrid_engine.gpu import dispatch as gpu_dispatch

    rng = np.random.default_rng(5)
    filler = CENTER + rng.uniform(-1.5, 1.5, (10_000, 1, 3)) + 0.01 * rng.standard_normal((10_000, 3, 3))
    scene = np.concatenate([mixed_scene(rng, 30), filler.astype(np.float32)])
    with gpu_dispatch.forced_limits(max_block=200 * 1024):
        builder = LBVHBuilder(gl)
        try:
            built = builder.build_from_array(scene)
            assert built.triangle_split.blocks == 3
            lists.collect(built, CENTER, HALF)
            expected = oracle(leaf_corners(built))
            assert 5 <= len(expected) <= grazing.GRAZING_CAPACITY
            assert set(lists.read().tolist()) == expected
        finally:
            builder.release()
