# SPDX-License-Identifier: GPL-3.0-or-later
"""The near cube sized to a frame budget: beyond the paper, whose limitations (§5) call the
size "chosen arbitrarily" and, in some scenes, vital to performance.

A frame's time depends on the near cube's half-size through terms that pull both ways: the
BVH side (culling, the LBVH build, traversal of the rays that start inside) grows with the
triangles inside the cube, the cube-map side shrinks as its near planes move out. Rather
than model them, the controller measures: it watches the frames rendered at one size, and
when their median leaves the budget's tolerance band it steps the size in log space by the
amount the last two sizes' medians say it takes (a secant on log frame time over log size),
bounded per step and by the artist's limits. It takes a larger cube to cost more, as it does
wherever the BVH side dominates; a secant that says otherwise is taken for noise. Three
things keep it from flickering:

- the hysteresis band: inside ``budget * (1 ± tolerance)`` nothing changes;
- a decision needs ``window`` frames at the current size (one frame when the budget is
  missed by more than the acceptance band, to react to a rising load at once);
- the median of those frames, not the last one, is compared.

The band, the window and the urgent ratio were chosen by replaying frame times recorded at
several fixed sizes along camera paths, with and without added noise
(``scripts/budget_replay.py``), for the most frames within the acceptance band (±15 % of the
budget). The median of two frames rarely leaves a band of ±10 % by noise alone, and the band
is narrow enough for the size to follow a changing load closely; a wider band or a longer
window leaves frames off budget for longer before the size moves, and acting at once on a
frame past the acceptance band, rather than later, keeps a rising load from running over
for a whole window.
"""
from __future__ import annotations

import math
import statistics
from dataclasses import dataclass, field, replace

from ..scene.scale import auto_near_size, near_limits

# Bounds of the measured elasticity d ln(frame) / d ln(size): a secant that says the frame
# barely depends on the size would ask for huge steps.
MIN_ELASTICITY = 0.2
MAX_ELASTICITY = 3.0
DEFAULT_ELASTICITY = 1.0
# A frame this far over budget is acted on without waiting for a full window: the edge of
# the band a frame is judged by (±15 %), so a rising load is met one frame sooner.
URGENT_RATIO = 1.15
# Frame-time changes below this (in log ratio, about 5 %) between two sizes are taken for
# noise, and the default elasticity holds.
NOISE_LOG_RATIO = 0.05


class BudgetError(ValueError):
    """Budget settings that cannot be met by any size (bad limits or budget)."""


@dataclass
class NearCubeBudget:
    """Chooses the near cube's half-size for the next frame from the last frames' times."""

    budget_ms: float
    min_size: float
    max_size: float
    size: float  # the size the next frame renders with
    # Inside this band nothing changes. It is wider than a still frame's time wanders from
    # frame to frame, so the median of two frames rarely leaves it by noise alone.
    tolerance: float = 0.10
    window: int = 2
    max_step: float = 1.25  # largest factor between two successive sizes
    urgent_ratio: float = URGENT_RATIO
    _recent: list[float] = field(default_factory=list)  # frame times at the current size
    _previous: tuple[float, float] | None = None  # (size, median frame ms) before the last change
    changes: int = 0  # how many times the size changed (a still scene's should stop growing)

    def __post_init__(self) -> None:
        if not (math.isfinite(self.budget_ms) and self.budget_ms > 0):
            raise BudgetError(f"the frame budget must be a positive number of milliseconds, got {self.budget_ms}")
        if not (0 < self.min_size <= self.max_size and math.isfinite(self.max_size)):
            raise BudgetError(f"the near cube's limits must satisfy 0 < minimum <= maximum, "
                              f"got {self.min_size} and {self.max_size}")
        if not (0 < self.tolerance < 1 and self.window >= 1 and self.max_step > 1 and self.urgent_ratio > 1):
            raise BudgetError("tolerance must lie in (0, 1), window be >= 1, max_step and urgent_ratio > 1")
        self.size = min(max(float(self.size), self.min_size), self.max_size)

    @classmethod
    def for_fps(cls, fps: float, min_size: float, max_size: float, size: float, **kw) -> "NearCubeBudget":
        """A budget given as frames per second."""
        if not (math.isfinite(fps) and fps > 0):
            raise BudgetError(f"the target frame rate must be positive, got {fps}")
        return cls(1000.0 / fps, min_size, max_size, size, **kw)

    def within(self, frame_ms: float) -> bool:
        """Whether a frame time lies inside the tolerance band around the budget."""
        return abs(frame_ms - self.budget_ms) <= self.tolerance * self.budget_ms

    def observe(self, frame_ms: float, size_used: float | None = None) -> float:
        """Record a frame rendered at ``size_used`` (default: the current size) that took
        ``frame_ms``; returns the size for the next frame."""
        if not (math.isfinite(frame_ms) and frame_ms >= 0):
            return self.size  # a failed or unmeasured frame tells nothing
        if size_used is not None and not math.isclose(size_used, self.size, rel_tol=1e-9):
            return self.size  # a frame of another size (settings changed under us): ignore
        self._recent.append(float(frame_ms))
        urgent = frame_ms > self.urgent_ratio * self.budget_ms
        if len(self._recent) < self.window and not urgent:
            return self.size
        median = statistics.median(self._recent[-self.window:])
        if self.within(median):
            self._recent = self._recent[-self.window:]
            return self.size
        wanted = self._next_size(median)
        if math.isclose(wanted, self.size, rel_tol=1e-6):
            self._recent = self._recent[-self.window:]  # at a limit: nothing more to do
            return self.size
        self._previous = (self.size, median)
        self.size = wanted
        self._recent = []
        self.changes += 1
        return self.size

    def _elasticity(self, median: float) -> float:
        """How strongly the frame time follows the size, from the last two sizes' medians;
        the default where they tell nothing (a first change, noise, or a frame that got no
        faster with a smaller cube)."""
        if self._previous is None:
            return DEFAULT_ELASTICITY
        size, frame = self._previous
        d_size = math.log(self.size / size)
        if abs(d_size) < 1e-9 or frame <= 0 or median <= 0:
            return DEFAULT_ELASTICITY
        e = math.log(median / frame) / d_size
        if e <= 0 or abs(math.log(median / frame)) < NOISE_LOG_RATIO:
            return DEFAULT_ELASTICITY
        return min(max(e, MIN_ELASTICITY), MAX_ELASTICITY)

    def _next_size(self, median: float) -> float:
        if median <= 0:
            return self.max_size
        step = math.log(self.budget_ms / median) / self._elasticity(median)
        limit = math.log(self.max_step)
        step = min(max(step, -limit), limit)
        return min(max(self.size * math.exp(step), self.min_size), self.max_size)


class NearCubeSizer:
    """A RenderSettings' near-cube mode applied frame after frame: *Fixed* passes the settings
    through; *Frame Budget* keeps a :class:`NearCubeBudget` across frames (made anew when the
    budget or the limits change, from the size reached so far) and hands each frame the
    size it chose. Its owner (a viewport session, a timing report) reports each frame's time."""

    def __init__(self) -> None:
        self.controller: NearCubeBudget | None = None
        self._key: tuple | None = None

    def settings_for_frame(self, settings, scene=None):
        """``settings`` with the near size this frame renders at; ``scene`` (its SceneData)
        gives Automatic limits their size (scene/scale.py)."""
        if settings.near_cube_mode != "BUDGET":
            self.controller, self._key = None, None
            return settings
        near_min, near_max = near_limits(settings, scene)
        key = (settings.frame_budget_ms, near_min, near_max)
        if self.controller is None or key != self._key:
            if self.controller is not None:
                start = self.controller.size
            else:
                start = settings.near_size if settings.near_size > 0.0 else auto_near_size(scene)
            self.controller = NearCubeBudget(settings.frame_budget_ms, near_min, near_max, start)
            self._key = key
        return replace(settings, near_size=self.controller.size, near_min=near_min, near_max=near_max)

    def observe(self, frame_ms: float, settings_used) -> None:
        """The time of a frame rendered with ``settings_used`` (from settings_for_frame)."""
        if self.controller is not None and settings_used.near_cube_mode == "BUDGET":
            self.controller.observe(frame_ms, settings_used.near_size)

    @property
    def size(self) -> float | None:
        """The size the next frame would take, None in Fixed mode."""
        return None if self.controller is None else self.controller.size
