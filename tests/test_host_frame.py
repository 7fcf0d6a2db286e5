# SPDX-License-Identifier: GPL-3.0-or-later
"""benchmarks/host_frame.py: the main thread's CPU per HYBRID Chess frame, moving and still,
with the time inside draw calls told apart."""
from __future__ import annotations

import moderngl

from benchmarks import host_frame


def test_the_draw_clock_counts_draw_calls_and_puts_moderngl_back():
    originals = {name: getattr(moderngl.VertexArray, name) for name in host_frame.DrawClock.NAMES}
    with host_frame.DrawClock() as clock:
        assert all(getattr(moderngl.VertexArray, name) is not originals[name] for name in originals)
    assert all(getattr(moderngl.VertexArray, name) is originals[name] for name in originals)
    assert clock.seconds == 0.0


def test_moving_and_still_frames_are_measured_with_the_draws_left_out(gl):
    report = host_frame.measure(detail=0.02, frames=2, resolution=(32, 18), kernels="gpu")
    assert report["variants"]["vertices"] == "gpu"
    for kind in ("moving", "still"):
        assert len(report[f"{kind}_ms"]) == 2
        assert 0.0 < report[f"{kind}_python_median_ms"] <= report[f"{kind}_median_ms"]


def test_the_kernel_override_is_lifted_after_the_measurement(gl):
    from hybrid_engine.gpu import variants

    host_frame.measure(detail=0.02, frames=1, resolution=(16, 9), kernels="sort=gpu,trace=cpu")  # not auto anywhere
    assert variants.chosen() == variants.chosen(override="auto")
