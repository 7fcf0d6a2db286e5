# SPDX-License-Identifier: GPL-3.0-or-later
"""Both shapes of the GPU prefix sum (hybrid_engine/gpu/prefix_scan.py) against numpy's
cumsum, bit for bit (uint32 arithmetic, wrapping included): sizes around the 256-lane
workgroup and the 2,048-value block, one and two levels of block sums; and the choice of
shape."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine.gpu import variants
from hybrid_engine.gpu.bindings import Storage
from hybrid_engine.gpu.prefix_scan import BLOCK_ITEMS, PrefixScan, resolve_family

SIZES = [0, 1, 255, 256, 257, BLOCK_ITEMS, BLOCK_ITEMS + 1, 4096, 65_537, 1_000_000]
# Two levels of block sums under the "gpu" shape (more blocks than one block can scan).
TWO_LEVELS = BLOCK_ITEMS * BLOCK_ITEMS + 1
KINDS = ["counts", "zeros", "wrapping"]
# A word past the total that no scan may touch.
SENTINEL = 0xA5A5A5A5


@pytest.fixture(scope="module")
def scans(gl):
    made = {family: PrefixScan(gl, family) for family in variants.FAMILIES}
    yield made
    for scan in made.values():
        scan.release()


def make_counts(rng: np.random.Generator, kind: str, count: int) -> np.ndarray:
    if kind == "zeros":
        return np.zeros(count, np.uint32)
    if kind == "wrapping":  # the sum passes 2^32: both sides wrap the same way
        return rng.integers(0, 1 << 32, count, dtype=np.uint64).astype(np.uint32)
    return rng.integers(0, 2049, count).astype(np.uint32)  # kept triangles per chunk


def assert_scans_like_numpy(ctx, scan: PrefixScan, counts: np.ndarray, offset_words: int = 0) -> None:
    """Exclusive sums in place, the total at [count], and the words around left alone;
    the data sits ``offset_words`` into its buffer (a Storage range, as the culls bind it)."""
    count = len(counts)
    before = np.full(offset_words, SENTINEL, np.uint32)
    buffer = ctx.buffer(np.concatenate([before, counts, [0xFFFFFFFF, SENTINEL]]).astype(np.uint32).tobytes())
    try:
        scan.run(Storage(buffer, (count + 1) * 4, offset_words * 4), count)
        out = np.frombuffer(buffer.read(), np.uint32)
    finally:
        buffer.release()
    expected = np.concatenate([[0], np.cumsum(counts, dtype=np.uint32)]).astype(np.uint32)
    np.testing.assert_array_equal(out[offset_words:offset_words + count + 1], expected)
    assert np.all(out[:offset_words] == SENTINEL) and out[-1] == SENTINEL


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("count", SIZES)
@pytest.mark.parametrize("family", variants.FAMILIES)
def test_each_shape_scans_like_numpy(ctx, scans, rng, family, count, kind):
    assert_scans_like_numpy(ctx, scans[family], make_counts(rng, kind, count))


@pytest.mark.parametrize("family", variants.FAMILIES)
def test_each_shape_scans_past_one_level_of_block_sums(ctx, scans, rng, family):
    assert_scans_like_numpy(ctx, scans[family], make_counts(rng, "counts", TWO_LEVELS))


@pytest.mark.parametrize("family", variants.FAMILIES)
def test_each_shape_scans_a_range_that_starts_inside_its_buffer(ctx, scans, rng, family):
    assert_scans_like_numpy(ctx, scans[family], make_counts(rng, "counts", 5000), offset_words=64)


@pytest.mark.parametrize("family", variants.FAMILIES)
def test_repeated_scans_of_shrinking_sizes_reuse_the_shape(ctx, scans, rng, family):
    """A scan object serves every size in turn (the culls' counts change per frame)."""
    for count in (70_000, 3, 9000, 0, 2049):
        assert_scans_like_numpy(ctx, scans[family], make_counts(rng, "counts", count))


class FakeContext:
    def __init__(self, renderer: str) -> None:
        self.info = {"GL_RENDERER": renderer}


def test_the_shape_follows_the_renderer_string(monkeypatch):
    monkeypatch.delenv(variants.ENVIRONMENT_VARIABLE, raising=False)
    assert resolve_family("scan", FakeContext("llvmpipe (LLVM 15.0.6, 256 bits)"), None) == "cpu"
    assert resolve_family("scan", FakeContext("AMD Radeon RX 7900 XTX (radeonsi, navi31)"), None) == "gpu"


def test_the_shape_follows_the_override_and_the_constructor_wins(ctx, monkeypatch):
    monkeypatch.delenv(variants.ENVIRONMENT_VARIABLE, raising=False)
    assert PrefixScan(ctx).family == variants.choose("scan", renderer=ctx.info["GL_RENDERER"])
    variants.set_override("scan=gpu")
    try:
        assert PrefixScan(ctx).family == "gpu"
        assert PrefixScan(ctx, "cpu").family == "cpu"
    finally:
        variants.set_override(None)
    monkeypatch.setenv(variants.ENVIRONMENT_VARIABLE, "scan=gpu")
    assert PrefixScan(ctx).family == "gpu"
    with pytest.raises(variants.VariantError, match="unknown kernel family"):
        PrefixScan(ctx, "warp")
