# SPDX-License-Identifier: GPL-3.0-or-later
"""Per-pass timing (hybrid_engine/gpu/timing.py): wall time between finishes, the host's CPU
share of each pass, and GPU timer queries where the renderer is a hardware one."""
from __future__ import annotations

import time

import numpy as np

from hybrid_engine.gpu import gl_context
from hybrid_engine.gpu.timing import PassTimer


def busy(seconds: float) -> None:
    end = time.thread_time() + seconds
    while time.thread_time() < end:
        pass


def test_a_pass_that_computes_on_the_host_shows_as_host_time_and_one_that_sleeps_does_not(ctx):
    timer = PassTimer(ctx)
    with timer.measure("host_bound"):
        busy(0.03)
    with timer.measure("waiting"):
        time.sleep(0.03)
    assert timer.passes["host_bound"] >= 29 and timer.host_passes["host_bound"] >= 29
    assert timer.passes["waiting"] >= 29 and timer.host_passes["waiting"] < 10
    assert set(timer.host_passes) == set(timer.passes) == {"host_bound", "waiting"}


def test_gpu_queries_are_off_on_a_software_renderer_and_off_when_timing_is(ctx):
    assert PassTimer(ctx).gpu_queries == (not gl_context.is_software_renderer())
    off = PassTimer(ctx, enabled=False)
    with off.measure("x"):
        pass
    assert not off.gpu_queries and off.passes == off.host_passes == off.gpu_passes == {}


def test_forced_timer_queries_time_each_pass_of_gpu_work(ctx):
    """The query path runs on any renderer (its figures mean something only on a GPU): each
    measured pass gets a non-negative GPU time."""
    timer = PassTimer(ctx, gpu_queries=True)
    program = ctx.compute_shader("#version 430\nlayout(local_size_x=64) in;\n"
                                 "layout(std430, binding=0) buffer B { float v[]; };\n"
                                 "void main() { v[gl_GlobalInvocationID.x] += 1.0; }")
    buffer = ctx.buffer(np.zeros(4096, np.float32).tobytes())
    buffer.bind_to_storage_buffer(0)
    for name in ("a", "b", "a"):
        with timer.measure(name):
            program.run(64)
    buffer.release()
    assert set(timer.gpu_passes) == {"a", "b"} and all(v >= 0 for v in timer.gpu_passes.values())


def test_a_timed_frame_reports_host_time_per_pass_within_its_wall_time(renderer):
    from hybrid_engine import Camera, Geometry, Lights, MaterialTable, RenderSettings, SceneData, Sky
    from scenes_analytic import quad

    scene = SceneData(Geometry.from_objects([(quad((0, 0, -3), (1, 0, 0), (0, 1, 0)), None, 0)]),
                      MaterialTable.from_rows([dict(base_color=(0.5, 0.5, 0.5))]), Lights.empty(),
                      Sky(color=(0.2, 0.3, 0.5)))
    result = renderer.render(scene, Camera(width=16, height=16), RenderSettings(mode="RASTER"), timing=True)
    assert set(result.host_passes) == set(result.passes)
    for name, ms in result.host_passes.items():
        assert 0 <= ms <= result.passes[name] * 1.05 + 1.0, name
