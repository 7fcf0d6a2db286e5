# SPDX-License-Identifier: GPL-3.0-or-later
"""Reference LBVH build in numpy: the oracle for the GPU passes and the benchmark's baseline.

Same algorithm as ``gpu_shaders/lbvh/`` written independently with vectorised numpy: Morton
codes (bit-identical by construction: only exactly rounded float operations, see
``gpu_shaders/include/morton.glsl``), a stable argsort, Karras 2012 Algorithm 1 over all inner
nodes at once, and a level-by-level bottom-up refit. Because the GPU sort is stable and the
hierarchy is a pure function of the sorted codes, the GPU tree must equal this one node for
node; tests compare them directly.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

FLOAT_MAX = np.float32(np.finfo(np.float32).max)
MORTON_CELLS = np.float32(1024.0)
MORTON_INVALID = np.uint32(0x3FFFFFFF)


def centroid_sums(triangles: np.ndarray) -> np.ndarray:
    """(v0 + v1) + v2 in float32: 3x the centroid, as the shaders compute it."""
    tris = np.asarray(triangles, dtype=np.float32)
    with np.errstate(over="ignore", invalid="ignore"):
        return (tris[:, 0] + tris[:, 1]) + tris[:, 2]


def expand_bits(v: np.ndarray) -> np.ndarray:
    """Insert two zero bits between each of the low 10 bits (see morton.glsl's diagram)."""
    v = v.astype(np.uint32) & np.uint32(0x3FF)
    v = (v * np.uint32(0x00010001)) & np.uint32(0xFF0000FF)
    v = (v * np.uint32(0x00000101)) & np.uint32(0x0F00F00F)
    v = (v * np.uint32(0x00000011)) & np.uint32(0xC30C30C3)
    v = (v * np.uint32(0x00000005)) & np.uint32(0x49249249)
    return v


def morton_axis_scale(extent: np.ndarray) -> np.ndarray:
    """1024 * 2^-e with extent = m * 2^e, m in [0.5, 1); 0 for a non-finite extent."""
    extent = np.asarray(extent, dtype=np.float32)
    finite = extent <= FLOAT_MAX
    _, exponent = np.frexp(np.where(finite, extent, np.float32(0)))
    return np.where(finite, np.ldexp(MORTON_CELLS, -exponent), np.float32(0)).astype(np.float32)


def morton_codes(triangles: np.ndarray) -> np.ndarray:
    """30-bit Morton codes of the centroids in the bounds of the finite centroids."""
    sums = centroid_sums(triangles)
    finite = np.isfinite(sums).all(axis=1)
    codes = np.full(len(sums), MORTON_INVALID, dtype=np.uint32)
    if not finite.any():
        return codes
    valid = sums[finite]
    lo = valid.min(axis=0)
    with np.errstate(over="ignore"):
        extent = valid.max(axis=0) - lo
    scale = morton_axis_scale(extent)
    cells = (valid - lo) * scale
    q = np.clip(cells, np.float32(0), MORTON_CELLS - np.float32(1)).astype(np.uint32)
    codes[finite] = (expand_bits(q[:, 0]) << 2) | (expand_bits(q[:, 1]) << 1) | expand_bits(q[:, 2])
    return codes


def _clz32(x: np.ndarray) -> np.ndarray:
    """Leading zeros of uint32 values (32 for 0)."""
    x = x.astype(np.uint64)
    _, exponent = np.frexp(x.astype(np.float64))  # x = m * 2^e, m in [0.5, 1): bit length e
    return np.where(x == 0, 32, 32 - exponent).astype(np.int64)


def _delta(codes: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Karras' delta: common prefix of codes i and j, index tie-break, -1 outside the range."""
    n = len(codes)
    valid = (j >= 0) & (j < n)
    jj = np.clip(j, 0, n - 1)
    diff = codes[i] ^ codes[jj]
    tie = 32 + _clz32((i ^ jj).astype(np.uint32))
    return np.where(valid, np.where(diff == 0, tie, _clz32(diff)), -1)


def karras_hierarchy(sorted_codes: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Karras 2012 Algorithm 1 for all inner nodes at once.

    Returns (left_child, right_child, parent, leaf_parent): child refs >= 0 are inner nodes,
    < 0 leaves ~ref; parent[0] = -1. For N < 2 the special root of bvh_layout.glsl.
    """
    codes = np.asarray(sorted_codes, dtype=np.uint32)
    n = len(codes)
    if n < 2:
        return (np.array([-1], np.int64), np.array([-1], np.int64), np.array([-1], np.int64),
                np.zeros(n, np.int64))
    i = np.arange(n - 1, dtype=np.int64)
    d = np.where(_delta(codes, i, i + 1) - _delta(codes, i, i - 1) >= 0, 1, -1)
    delta_min = _delta(codes, i, i - d)
    length_max = np.full(n - 1, 2, dtype=np.int64)
    grow = _delta(codes, i, i + length_max * d) > delta_min
    while grow.any():
        length_max = np.where(grow, length_max * 2, length_max)
        grow &= _delta(codes, i, i + length_max * d) > delta_min
    length = np.zeros(n - 1, dtype=np.int64)
    step = length_max // 2
    while (step >= 1).any():
        active = step >= 1
        take = active & (_delta(codes, i, i + (length + step) * d) > delta_min)
        length = np.where(take, length + step, length)
        step = step // 2
    j = i + length * d
    delta_node = _delta(codes, i, j)
    split = np.zeros(n - 1, dtype=np.int64)
    divisor = 2
    active = np.ones(n - 1, dtype=bool)
    while active.any():
        step = (length + divisor - 1) // divisor
        take = active & (_delta(codes, i, i + (split + step) * d) > delta_node)
        split = np.where(take, split + step, split)
        active &= step > 1
        divisor *= 2
    gamma = i + split * d + np.minimum(d, 0)
    first = np.minimum(i, j)
    last = np.maximum(i, j)
    left = np.where(first == gamma, ~gamma, gamma)
    right = np.where(last == gamma + 1, ~(gamma + 1), gamma + 1)
    parent = np.full(n - 1, -1, dtype=np.int64)
    leaf_parent = np.zeros(n, dtype=np.int64)
    for child in (left, right):
        inner = child >= 0
        parent[child[inner]] = i[inner]
        leaf_parent[~child[~inner]] = i[~inner]
    return left, right, parent, leaf_parent


def leaf_boxes(triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-triangle boxes; empty (FLT_MAX, -FLT_MAX) for triangles with a non-finite vertex."""
    tris = np.asarray(triangles, dtype=np.float32).reshape(-1, 3, 3)
    finite = np.isfinite(tris).all(axis=(1, 2))
    lo = np.where(finite[:, None], tris.min(axis=1), FLOAT_MAX)
    hi = np.where(finite[:, None], tris.max(axis=1), -FLOAT_MAX)
    return lo.astype(np.float32), hi.astype(np.float32)


@dataclass
class ReferenceLBVH:
    """The numpy build: sorted codes and leaf order, topology, and each child's box."""

    sorted_codes: np.ndarray  # (N,) uint32
    leaf_primitives: np.ndarray  # (N,) original triangle index of each leaf
    left_child: np.ndarray  # (max(N-1,1),) refs
    right_child: np.ndarray
    parent: np.ndarray
    leaf_parent: np.ndarray  # (N,)
    child_min: np.ndarray  # (max(N-1,1), 2, 3): [:, 0] left child's box, [:, 1] right's
    child_max: np.ndarray


def refit(leaf_lo: np.ndarray, leaf_hi: np.ndarray, left: np.ndarray, right: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray]:
    """Bottom-up boxes, one numpy step per tree level (deepest first)."""
    inner_count = len(left)
    node_lo = np.full((inner_count, 3), FLOAT_MAX, dtype=np.float32)
    node_hi = np.full((inner_count, 3), -FLOAT_MAX, dtype=np.float32)
    if len(leaf_lo) < 2:
        child_min = np.stack([node_lo, node_lo], axis=1)
        child_max = np.stack([node_hi, node_hi], axis=1)
        if len(leaf_lo) == 1:
            child_min[0, 0], child_max[0, 0] = leaf_lo[0], leaf_hi[0]
        return child_min, child_max
    # Levels top-down from the root, then boxes bottom-up.
    levels = []
    frontier = np.array([0], dtype=np.int64)
    while frontier.size:
        levels.append(frontier)
        kids = np.concatenate([left[frontier], right[frontier]])
        frontier = kids[kids >= 0]

    def child_box(ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        leaf = ref < 0
        idx = np.where(leaf, ~ref, ref)
        lo = np.where(leaf[:, None], leaf_lo[np.where(leaf, idx, 0)], node_lo[np.where(leaf, 0, idx)])
        hi = np.where(leaf[:, None], leaf_hi[np.where(leaf, idx, 0)], node_hi[np.where(leaf, 0, idx)])
        return lo, hi

    for level in reversed(levels):
        l_lo, l_hi = child_box(left[level])
        r_lo, r_hi = child_box(right[level])
        node_lo[level] = np.minimum(l_lo, r_lo)
        node_hi[level] = np.maximum(l_hi, r_hi)
    l_lo, l_hi = child_box(left)
    r_lo, r_hi = child_box(right)
    return np.stack([l_lo, r_lo], axis=1), np.stack([l_hi, r_hi], axis=1)


def build(triangles: np.ndarray) -> ReferenceLBVH:
    """The whole reference build over an (N, 3, 3) float32 triangle array."""
    tris = np.asarray(triangles, dtype=np.float32).reshape(-1, 3, 3)
    codes = morton_codes(tris)
    order = np.argsort(codes, kind="stable")
    sorted_codes = codes[order]
    left, right, parent, leaf_parent = karras_hierarchy(sorted_codes)
    lo, hi = leaf_boxes(tris[order])
    child_min, child_max = refit(lo, hi, left, right)
    return ReferenceLBVH(sorted_codes, order.astype(np.int64), left, right, parent, leaf_parent,
                         child_min, child_max)
