# SPDX-License-Identifier: GPL-3.0-or-later
"""The frame statistics ring (hybrid_engine/gpu/statistics.py): counts copied on the GPU and
read only when a caller asks, never when a held frame's slot comes round again."""
from __future__ import annotations

import numpy as np

from hybrid_engine.gpu.statistics import FrameStatistics, StatisticsRing


def _frame(ctx, value: int) -> tuple[FrameStatistics, object]:
    counter = ctx.buffer(np.array([value, 2 * value], np.uint32).tobytes())
    statistics = FrameStatistics()
    statistics.deposit(counter, 2, lambda words: {"first": int(words[0]), "second": int(words[1])})
    return statistics, counter


def test_held_frames_keep_their_counts_without_a_read_when_their_slots_are_reused(ctx, monkeypatch):
    import moderngl

    reads = []
    original = moderngl.Buffer.read
    monkeypatch.setattr(moderngl.Buffer, "read", lambda self, *a, **k: (reads.append(self), original(self, *a, **k))[1])
    ring = StatisticsRing(ctx, slots=2)
    counters, held = [], []
    try:
        for value in range(1, 6):  # five frames through two slots, every result held
            statistics, counter = _frame(ctx, value)
            counters.append(counter)
            held.append(ring.collect(statistics))
        assert reads == [], "a held frame's counts were read when its slot was reused"
        assert ring.kept == 3
        assert [pending.resolve() for pending in held] == [{"first": v, "second": 2 * v} for v in range(1, 6)]
        assert len(reads) == 5
        ring.collect(_frame(ctx, 9)[0])  # the read frames' buffers go back
        assert ring.kept == 0
    finally:
        ring.release()
        for counter in counters:
            counter.release()


def test_a_dropped_frame_s_kept_buffer_is_released_and_never_read(ctx, monkeypatch):
    import moderngl

    reads = []
    original = moderngl.Buffer.read
    monkeypatch.setattr(moderngl.Buffer, "read", lambda self, *a, **k: (reads.append(self), original(self, *a, **k))[1])
    ring = StatisticsRing(ctx, slots=1)
    statistics, counter = _frame(ctx, 3)
    try:
        held = ring.collect(statistics)
        ring.collect(_frame(ctx, 4)[0])
        assert ring.kept == 1
        del held
        ring.collect(_frame(ctx, 5)[0])
        assert ring.kept == 0 and reads == []
    finally:
        ring.release()
        counter.release()
