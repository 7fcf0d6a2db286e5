# SPDX-License-Identifier: GPL-3.0-or-later
"""Both shapes of the GPU radix sort (hybrid_engine/gpu/radix_sort.py) against numpy's stable
argsort, bit for bit: sizes around the 256-key workgroup and 2,048-key tile and chunk
boundaries, keys that stress stability (all equal, few distinct, sorted, reversed), 24-
and 32-bit keys; and the choice of shape."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine.gpu import variants
from hybrid_engine.gpu.prefix_scan import resolve_family
from hybrid_engine.gpu.radix_sort import TILE_KEYS, RadixSort, sort_passes

SIZES = [1, 255, 256, 257, 65_537, 1_000_000]
KINDS = ["random", "equal", "few", "sorted", "reversed"]
# (family, scan_family): the GPU shape as a GPU runs it (multi-workgroup scan) and as
# llvmpipe's automatic choice would pair it (one-workgroup scan).
SHAPES = [("cpu", None), ("gpu", "gpu"), ("gpu", "cpu")]


@pytest.fixture(scope="module")
def sorters(gl):
    made = {shape: RadixSort(gl, *shape) for shape in SHAPES}
    yield made
    for sorter in made.values():
        sorter.release()


def make_keys(rng: np.random.Generator, kind: str, count: int, bits: int) -> np.ndarray:
    top = 1 << bits
    if kind == "equal":
        return np.full(count, (0xDEADBEEF & (top - 1)), np.uint32)
    if kind == "few":  # a handful of values spread over every digit: long runs of ties
        spread = np.array([0, 0x01020304, 0xFFFFFFFF, 0x00FF00FF], np.uint64) & np.uint64(top - 1)
        return rng.choice(spread.astype(np.uint32), count)
    keys = rng.integers(0, top, count, dtype=np.uint64).astype(np.uint32)
    if kind == "sorted":
        keys.sort()
    elif kind == "reversed":
        keys = np.sort(keys)[::-1].copy()
    return keys


def gpu_sort(ctx, sorter: RadixSort, keys: np.ndarray, values: np.ndarray, bits: int):
    """Sort on the GPU; returns the (keys, values) read back."""
    count = len(keys)
    key_buffers = [ctx.buffer(keys.tobytes()), ctx.buffer(reserve=max(count, 1) * 4)]
    value_buffers = [ctx.buffer(values.tobytes()), ctx.buffer(reserve=max(count, 1) * 4)]
    try:
        result = sorter.sort(key_buffers, value_buffers, count, bits)
        out_keys = np.frombuffer(key_buffers[result].read(size=count * 4), np.uint32)
        out_values = np.frombuffer(value_buffers[result].read(size=count * 4), np.uint32)
        return out_keys.copy(), out_values.copy()
    finally:
        for buffer in (*key_buffers, *value_buffers):
            buffer.release()


def assert_sorts_like_numpy(ctx, sorter, keys: np.ndarray, bits: int) -> None:
    """Keys and their indices (the values) come out in numpy's stable order of the low
    ``bits`` bits."""
    values = np.arange(len(keys), dtype=np.uint32)
    out_keys, out_values = gpu_sort(ctx, sorter, keys, values, bits)
    order = np.argsort(keys & np.uint32((1 << bits) - 1 if bits < 32 else 0xFFFFFFFF), kind="stable")
    np.testing.assert_array_equal(out_values, order.astype(np.uint32))
    np.testing.assert_array_equal(out_keys, keys[order])


@pytest.mark.parametrize("bits", [24, 32])
@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("count", SIZES)
@pytest.mark.parametrize("family", ["cpu", "gpu"])
def test_each_shape_sorts_stably_like_numpy(ctx, sorters, rng, family, count, kind, bits):
    sorter = sorters[(family, "gpu" if family == "gpu" else None)]
    assert_sorts_like_numpy(ctx, sorter, make_keys(rng, kind, count, bits), bits)


@pytest.mark.parametrize("count", [TILE_KEYS - 1, TILE_KEYS + 1, 65_537, 1_000_000])
def test_the_gpu_shape_with_the_one_workgroup_histogram_scan_sorts_like_numpy(ctx, sorters, rng, count):
    """The pairing llvmpipe's automatic choice gives when the sort is forced to "gpu"."""
    assert_sorts_like_numpy(ctx, sorters[("gpu", "cpu")], make_keys(rng, "random", count, 30), 30)


@pytest.mark.parametrize("shape", SHAPES)
def test_only_the_low_bits_order_the_keys(ctx, sorters, rng, shape):
    """24 bits asked: keys differing only above bit 23 keep their input order (the ray sort's
    three passes), whole 8-bit digits being the unit."""
    keys = rng.integers(0, 1 << 32, 5000, dtype=np.uint64).astype(np.uint32)
    keys[::3] &= np.uint32(0x00FF)  # equal low bits with different high bytes
    assert_sorts_like_numpy(ctx, sorters[shape], keys, 24)


@pytest.mark.parametrize("shape", SHAPES)
def test_values_travel_with_their_keys(ctx, sorters, rng, shape):
    """Values are arbitrary words, not indices: each leaves with its own key."""
    keys = make_keys(rng, "few", 70_000, 32)
    values = rng.integers(0, 1 << 32, len(keys), dtype=np.uint64).astype(np.uint32)
    out_keys, out_values = gpu_sort(ctx, sorters[shape], keys, values, 32)
    order = np.argsort(keys, kind="stable")
    np.testing.assert_array_equal(out_keys, keys[order])
    np.testing.assert_array_equal(out_values, values[order])


@pytest.mark.parametrize("shape", SHAPES)
def test_no_keys_leave_the_buffers_alone(ctx, sorters, shape):
    buffer = ctx.buffer(np.array([7], np.uint32).tobytes())
    try:
        assert sorters[shape].sort([buffer, buffer], [buffer, buffer], 0, 32) == 0
        assert np.frombuffer(buffer.read(), np.uint32)[0] == 7
    finally:
        buffer.release()


def test_passes_cover_whole_digits_and_refuse_impossible_widths():
    assert [sort_passes(b) for b in (1, 8, 9, 24, 30, 32)] == [1, 1, 2, 3, 4, 4]
    for bits in (0, 33):
        with pytest.raises(ValueError, match="1 to 32"):
            sort_passes(bits)


def test_the_cpu_shape_crosses_its_chunks_with_short_chunks(ctx, rng):
    """Many chunks of 7 keys: the column scan orders equal digits across chunks."""
    sorter = RadixSort(ctx, "cpu", keys_per_chunk=7)
    try:
        assert sorter.sort_plan(1000) == (7, 143)
        assert_sorts_like_numpy(ctx, sorter, make_keys(rng, "few", 1000, 32), 32)
    finally:
        sorter.release()


class FakeContext:
    def __init__(self, renderer: str) -> None:
        self.info = {"GL_RENDERER": renderer}


def test_the_shape_follows_the_renderer_string(monkeypatch):
    monkeypatch.delenv(variants.ENVIRONMENT_VARIABLE, raising=False)
    assert resolve_family("sort", FakeContext("llvmpipe (LLVM 15.0.6, 256 bits)"), None) == "cpu"
    assert resolve_family("sort", FakeContext("NVIDIA H100 80GB HBM3/PCIe/SSE2"), None) == "gpu"


def test_the_shape_follows_the_override_and_the_constructor_wins(ctx, monkeypatch):
    monkeypatch.delenv(variants.ENVIRONMENT_VARIABLE, raising=False)
    assert RadixSort(ctx).family == variants.choose("sort", renderer=ctx.info["GL_RENDERER"])
    variants.set_override("sort=gpu")
    try:
        assert RadixSort(ctx).family == "gpu"
        assert RadixSort(ctx).scan.family == variants.choose("scan", renderer=ctx.info["GL_RENDERER"])
        assert RadixSort(ctx, "cpu").family == "cpu"
    finally:
        variants.set_override(None)
    with pytest.raises(variants.VariantError, match="unknown kernel family"):
        RadixSort(ctx, "fast")
