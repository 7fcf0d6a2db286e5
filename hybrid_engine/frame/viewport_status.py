# SPDX-License-Identifier: GPL-3.0-or-later
"""What the viewport tells the artist about its frames: the smoothed frame rate, the one-line
statistics in the header, and the latch that says an error once, not on every redraw."""
from __future__ import annotations

import time

# ---------------------------------------------------------------------------------------
# Statistics and messages
# ---------------------------------------------------------------------------------------
class FrameClock:
    """Frame time and frames per second of the viewport, smoothed (exponential moving
    average) so the stats line is readable during playback."""

    SMOOTHING = 0.2  # weight of the newest interval

    def __init__(self, clock=time.perf_counter) -> None:
        self._clock = clock
        self._last: float | None = None
        self.interval_s: float | None = None

    def tick(self) -> float | None:
        """Mark a presented frame; returns the smoothed frames per second (None at first)."""
        now = self._clock()
        if self._last is not None:
            dt = max(now - self._last, 1e-9)
            self.interval_s = dt if self.interval_s is None else (
                (1 - self.SMOOTHING) * self.interval_s + self.SMOOTHING * dt)
        self._last = now
        return None if self.interval_s is None else 1.0 / self.interval_s


class StatsRefresh:
    """When the viewport's statistics line takes new counts. Counts come from the GPU (the
    frame's statistics ring) and reading them is a read-back, so a redraw reads them only
    when the line is due to change: at most every ``interval_s``, as a header refreshed for a
    person to read needs no more; in between the line keeps the last counts read."""

    def __init__(self, interval_s: float = 0.5, clock=time.perf_counter) -> None:
        self.interval_s = float(interval_s)
        self._clock = clock
        self._last: float | None = None

    def due(self) -> bool:
        """Whether this redraw should read the counts (and, if so, count it as read)."""
        now = self._clock()
        if self._last is not None and now - self._last < self.interval_s:
            return False
        self._last = now
        return True

    def reset(self) -> None:
        """Read the counts on the next redraw (a new scene, an error)."""
        self._last = None


def stats_line(mode: str, frame_ms: float, fps: float | None, counts: dict, size: tuple[int, int],
               samples: str = "") -> str:
    """The viewport's one-line statistics: mode, render size, the accumulated samples
    ("sample 3/16"), frame time, FPS and the BVH (near-cube) and total triangle counts."""
    total = int(counts.get("triangles_total", 0))
    bvh = counts.get("triangles_bvh", counts.get("triangles_near", None))
    bvh_text = f"{int(bvh):,}" if bvh is not None else "-"
    fps_text = f"{fps:.1f} fps" if fps is not None else "- fps"
    sample_text = f"{samples} | " if samples else ""
    return (f"Hybrid RT | {mode} | {size[0]}x{size[1]} | {sample_text}{frame_ms:.1f} ms | {fps_text} | "
            f"BVH {bvh_text} / {total:,} tris")


class MessageLatch:
    """Remembers messages already shown, so an error that repeats on every redraw reaches the
    console once; ``clear()`` forgets (after a frame succeeds) so a new failure is shown again."""

    def __init__(self) -> None:
        self._seen: set[str] = set()

    def first_time(self, message: str) -> bool:
        if message in self._seen:
            return False
        self._seen.add(message)
        return True

    def clear(self) -> None:
        self._seen.clear()
