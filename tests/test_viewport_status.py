# SPDX-License-Identifier: GPL-3.0-or-later
"""hybrid_engine.frame.viewport_status: the viewport's stats line, frame clock and message latch."""
from __future__ import annotations

import pytest

from hybrid_engine.frame.viewport_status import FrameClock, MessageLatch, stats_line


def test_stats_line_shows_frame_time_fps_and_triangle_counts():
    line = stats_line("HYBRID", 12.34, 58.2, {"triangles_total": 123456, "triangles_bvh": 789}, (640, 360))
    for part in ("HYBRID", "640x360", "12.3 ms", "58.2 fps", "BVH 789 / 123,456 tris"):
        assert part in line
    assert "BVH - / 10 tris" in stats_line("RASTER", 1.0, None, {"triangles_total": 10}, (1, 1))


def test_frame_clock_reports_smoothed_frames_per_second():
    times = iter([0.0, 0.1, 0.2, 0.3])
    clock = FrameClock(clock=lambda: next(times))
    assert clock.tick() is None
    assert clock.tick() == pytest.approx(10.0)
    assert clock.tick() == pytest.approx(10.0)


def test_message_latch_says_each_message_once_until_cleared():
    latch = MessageLatch()
    assert latch.first_time("no GL") and not latch.first_time("no GL") and latch.first_time("other")
    latch.clear()
    assert latch.first_time("no GL")


def test_the_stats_line_refreshes_at_most_every_interval():
    from hybrid_engine.frame.viewport_status import StatsRefresh

    now = [10.0]
    refresh = StatsRefresh(0.5, clock=lambda: now[0])
    taken = []
    for t in (10.0, 10.2, 10.49, 10.5, 10.6, 11.2):
        now[0] = t
        taken.append(refresh.due())
    assert taken == [True, False, False, True, False, True]
    refresh.reset()
    assert refresh.due()  # a reset takes the counts on the next redraw
