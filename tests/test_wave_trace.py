# SPDX-License-Identifier: GPL-3.0-or-later
"""The tracer in waves (hybrid_engine/passes/trace/wave_trace.py, gpu_shaders/trace/wave_*.comp.glsl):
the GPU-shaped ``trace`` kernel gives the megakernel's image and exactly its ray and work
counters, and is chosen by the renderer string and the override.

The oracle is the megakernel (trace/hybrid_trace.comp.glsl), itself held to the CPU Whitted
reference by tests/test_tracer.py. Each comparison also checks that the waves did run
(``WaveTracer.overflowed``: what the GPU-side queues held), so that neither side can be the
megakernel twice.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hybrid_engine.frame.renderer import Renderer
from hybrid_engine.gpu import shader_loader, variants
from hybrid_engine.gpu.bindings import bind
from hybrid_engine.passes.trace import wave_trace
from hybrid_engine.passes.trace.tracer import COUNTER_KINDS
from hybrid_engine.scene.settings import RenderSettings
from benchmarks.bench import flip_mean
from scenes_analytic import quad
import test_tracer as scenes

# The acceptance bound: the waves sum a pixel's light in another order than the megakernel.
MAX_FLIP = 0.001
# Neither divides the 8x8 megakernel nor the 64-ray wave workgroups.
ODD_W, ODD_H = 61, 37


@pytest.fixture(scope="module")
def renderer(gl):
    r = Renderer(gl)
    yield r
    r.release()


@pytest.fixture(autouse=True)
def no_override():
    yield
    variants.set_override(None)


def trace_counts(counts: dict) -> dict:
    """The tracer's counters (TraceStats.as_counts): rays per kind and work per depth."""
    return {k: v for k, v in counts.items()
            if k.startswith("rays_") or k.startswith("bvh_nodes") or k.startswith("cube_steps")}


def both(renderer, scene, camera, settings):
    """The frame by the megakernel and by the waves, and what the waves' queues held."""
    variants.set_override("trace=cpu")
    mega = renderer.render(scene, camera, settings)
    variants.set_override("trace=gpu")
    waves = renderer.render(scene, camera, settings)
    held = renderer.tracer._waves.overflowed()
    assert held[0] <= renderer.tracer._waves.capacity, "a queue overflowed: rays took the sky"
    return mega, waves, held


def assert_same(mega, waves):
    flip = flip_mean(mega.image, waves.image)
    assert flip <= MAX_FLIP, flip
    assert trace_counts(waves.counts) == trace_counts(mega.counts)


@pytest.mark.parametrize("mode", ["HYBRID", "FULL_BVH"])
@pytest.mark.parametrize("max_depth", [1, 4, 8])
@pytest.mark.parametrize("name", ["mirror_and_emitters", "glass_ball", "facing_mirrors"])
def test_waves_give_the_megakernels_image_and_counters(renderer, name, max_depth, mode):
    make_scene, make_camera = scenes.SCENES[name]
    settings = scenes.settings(mode, max_depth=max_depth, near_size=6.0, ao_distance=1.0)
    mega, waves, held = both(renderer, make_scene(), make_camera(), settings)
    assert held[0] > 0  # the waves traced rays
    assert mega.counts["rays_traced_bounce_1"] > 0
    if max_depth > 1 and name != "mirror_and_emitters":
        assert mega.counts["rays_traced_bounce_2"] > 0  # the scene bounces past the first wave
    assert_same(mega, waves)


@pytest.mark.parametrize("mode", ["HYBRID", "FULL_BVH"])
def test_occlusion_rays_of_the_first_bounce_are_traced_in_waves(renderer, mode):
    # Mirrors see a floor beside a box: the floor's first-bounce hits near the box send
    # occlusion rays that it stops (AO Distance), darkening them in both variants.
    make_scene, make_camera = scenes.SCENES["mirror_and_emitters"]
    settings = scenes.settings(mode, max_depth=2, near_size=6.0, ao_distance=3.0, world_light="SCREEN")
    mega, waves, held = both(renderer, make_scene(), make_camera(), settings)
    assert held[1] > 0  # occlusion rays were queued
    variants.set_override("trace=cpu")
    open_sky = renderer.render(make_scene(), make_camera(), scenes.settings(mode, max_depth=2, near_size=6.0,
                                                                            ao_distance=0.0, world_light="SCREEN"))
    assert np.abs(open_sky.image - mega.image).max() > 1e-3  # the occlusion matters here
    assert_same(mega, waves)


@pytest.mark.parametrize("mode", ["HYBRID", "FULL_BVH"])
def test_diffuse_gather_rays_of_the_first_bounce_are_traced_in_waves(renderer, mode):
    # World Light Rays: the mirrors' first-bounce hits gather their diffuse light with one
    # ray of unlimited reach (closest hit, shaded) in the occlusion queue; both variants
    # give one image, and it differs from the occlusion rays' within AO Distance.
    make_scene, make_camera = scenes.SCENES["mirror_and_emitters"]
    settings = scenes.settings(mode, max_depth=2, near_size=6.0, ao_distance=3.0, world_light="RAYS")
    mega, waves, held = both(renderer, make_scene(), make_camera(), settings)
    assert held[1] > 0  # gather rays were queued
    variants.set_override("trace=cpu")
    occluded = renderer.render(make_scene(), make_camera(), scenes.settings(mode, max_depth=2, near_size=6.0,
                                                                            ao_distance=3.0, world_light="SCREEN"))
    assert np.abs(occluded.image - mega.image).max() > 1e-3
    assert_same(mega, waves)


@pytest.mark.parametrize("mode", ["HYBRID", "FULL_BVH"])
def test_an_odd_sized_view_traces_every_pixel_in_waves(renderer, mode):
    make_scene, _ = scenes.SCENES["glass_ball"]
    camera = scenes.camera_at((0, -2, 0.2), (0, 3, 0), width=ODD_W, height=ODD_H)
    settings = scenes.settings(mode, max_depth=4, near_size=3.0, ao_distance=1.0)
    mega, waves, _ = both(renderer, make_scene(), camera, settings)
    assert waves.image.shape[:2] == (ODD_H, ODD_W)
    assert_same(mega, waves)


def test_a_view_without_specular_pixels_leaves_the_queue_empty(renderer):
    scene = scenes.make_scene([(quad((0, 0, 0), (4, 0, 0), (0, 4, 0)), None, scenes.DIFFUSE)],
                              lights=[dict(kind="SUN", direction=(0.2, 0.3, -1), color=(2, 2, 2))])
    camera = scenes.camera_at((0, -0.5, 3), (0, 0, 0), width=ODD_W, height=ODD_H)
    mega, waves, held = both(renderer, scene, camera, scenes.settings("HYBRID", max_depth=4, near_size=3.0))
    assert held == (0, 0)
    assert all(v == 0 for v in trace_counts(waves.counts).values())
    assert np.array_equal(mega.image, waves.image)


@pytest.mark.parametrize("mode", ["HYBRID", "FULL_BVH"])
def test_a_view_where_every_pixel_is_specular_traces_a_ray_per_pixel(renderer, mode):
    scene = scenes.make_scene([
        (quad((0, 3, 0), (0, 0, 20), (20, 0, 0)), None, scenes.MIRROR),
        (scenes.uv_sphere((0.5, -2, 0), 0.5, 16, 8)[0], None, scenes.GLASS),
    ], lights=[dict(kind="SUN", direction=(0.2, 0.3, -1), color=(2, 2, 2))])
    camera = scenes.camera_at((0, 0, 0), (0, 1, 0), width=ODD_W, height=ODD_H)
    mega, waves, held = both(renderer, scene, camera, scenes.settings(mode, max_depth=8, near_size=3.0))
    assert mega.counts["rays_traced_bounce_1"] == ODD_W * ODD_H
    assert held[0] >= ODD_W * ODD_H
    assert_same(mega, waves)


def test_the_wave_variant_follows_the_renderer_string_and_the_override():
    hybrid, full = RenderSettings(mode="HYBRID"), RenderSettings(mode="FULL_BVH")
    gpu, cpu = "NVIDIA GeForce RTX 4090/PCIe/SSE2", "llvmpipe (LLVM 15.0.7, 256 bits)"
    assert wave_trace.uses_waves(hybrid, gpu, "auto") and wave_trace.uses_waves(full, gpu, "auto")
    assert not wave_trace.uses_waves(hybrid, cpu, "auto")
    assert wave_trace.uses_waves(hybrid, cpu, "trace=gpu")
    assert not wave_trace.uses_waves(hybrid, gpu, "trace=cpu")
    assert not wave_trace.uses_waves(hybrid, gpu, "sort=cpu,trace=cpu")
    # Per-pixel answers stay on the megakernel.
    assert not wave_trace.uses_waves(RenderSettings(mode="PROVENANCE"), gpu, "auto")
    assert not wave_trace.uses_waves(RenderSettings(mode="BOUNCES"), gpu, "auto")


def test_the_tracer_runs_the_variant_chosen(gl):
    make_scene, make_camera = scenes.SCENES["facing_mirrors"]
    settings = scenes.settings("FULL_BVH", max_depth=2)
    renderer = Renderer(gl)
    try:
        variants.set_override("trace=cpu")
        renderer.render(make_scene(), make_camera(), settings)
        assert renderer.tracer._waves is None  # the megakernel ran; no wave queues were made
        variants.set_override("trace=gpu")
        renderer.render(make_scene(), make_camera(), settings)
        assert renderer.tracer._waves is not None and renderer.tracer._waves.overflowed()[0] > 0
    finally:
        renderer.release()


WEIGHT_PROBE = Path(__file__).resolve().parent / "shaders" / "wave_weight_probe.comp.glsl"


def test_a_queued_weight_keeps_18_bits_below_its_largest_channel_and_every_positive_channel(gl, rng):
    # Weights as paths make them: colours from 1 down to far below any half float, and
    # channels far below their largest (a Fresnel-weighted path through tinted glass), all
    # normal floats (the megakernel's own products flush below them).
    largest = 10.0 ** rng.uniform(-30, 1, 400)
    ratios = np.where(rng.random((400, 3)) < 0.3, 10.0 ** rng.uniform(-7, 0, (400, 3)), rng.random((400, 3)))
    weights = np.concatenate([largest[:, None] * ratios, [[0, 0, 0], [1, 0, 0], [0, 2.0 ** -100, 0], [2.0, 1.0, 0.5]]])
    weights = weights.astype(np.float32)
    prog = shader_loader.compute(gl, WEIGHT_PROBE)
    source = gl.buffer(np.c_[weights, np.zeros(len(weights))].astype(np.float32).tobytes())
    out = gl.buffer(reserve=source.size)
    try:
        bind(prog, storage={"Weights": source, "Unpacked": out, "WaveState": None}, uniforms={"u_count": len(weights)})
        prog.run(-(-len(weights) // 64), 1, 1)
        back = np.frombuffer(out.read(), np.float32).reshape(-1, 4)[:, :3]
    finally:
        source.release()
        out.release()
    # Rounded to half a step of 2^-17 of the largest channel's power of two; a positive
    # channel below one step is kept at one.
    top = weights.max(axis=1, keepdims=True)
    assert (np.abs(back - weights) <= top * 2.0 ** -17).all()
    assert np.median(np.abs(back - weights)[:-4] / top[:-4]) < 2.0 ** -19
    np.testing.assert_array_equal(back > 0, weights > 0)  # the spawned rays depend on it
    np.testing.assert_array_equal(back[-4:], weights[-4:])  # exact where the bits suffice


def overflowing_frame(renderer):
    """The glass ball at depth 4 with occlusion rays, and the most rays and occlusion rays
    any of its waves wants."""
    make_scene, make_camera = scenes.SCENES["glass_ball"]
    scene, camera = make_scene(), make_camera()
    settings = scenes.settings("HYBRID", max_depth=4, near_size=6.0, ao_distance=1.0)
    variants.set_override("trace=cpu")
    mega = renderer.render(scene, camera, settings)
    variants.set_override("trace=gpu")
    renderer.render(scene, camera, settings)
    wanted = renderer.tracer._waves.overflowed()
    assert wanted[0] > 2 * wave_trace.WAVE_LOCAL and wanted[1] > wave_trace.WAVE_LOCAL
    return scene, camera, settings, mega, wanted


def test_the_queues_start_at_one_ray_per_pixel_in_packed_records(renderer):
    make_scene, make_camera = scenes.SCENES["glass_ball"]
    camera = scenes.camera_at((0, -2, 0.2), (0, 3, 0), width=ODD_W, height=ODD_H)
    variants.set_override("trace=gpu")
    fresh = Renderer(renderer.ctx)
    try:
        fresh.render(make_scene(), camera, scenes.settings("HYBRID", max_depth=4, near_size=3.0))
        waves = fresh.tracer._waves
        pixels = ODD_W * ODD_H
        assert (waves.ray_capacity, waves.occlusion_capacity) == (pixels, pixels)
        queues = wave_trace.queue_bytes(pixels, pixels, pixels)
        assert waves.bytes_allocated() - queues <= 2048  # the state and overflow words
        # Two ray queues, the hits, the occlusion queue and a vec4 per pixel, nothing more.
        assert queues <= 176 * pixels
    finally:
        fresh.release()


@pytest.mark.parametrize("short", [1, 2 * wave_trace.WAVE_LOCAL - 1, 2 * wave_trace.WAVE_LOCAL,
                                   2 * wave_trace.WAVE_LOCAL + 1])
def test_a_frame_that_overflows_its_queues_grows_them_and_the_next_frame_is_exact(renderer, short):
    scene, camera, settings, mega, wanted = overflowing_frame(renderer)
    waves = renderer.tracer._waves
    # Queues a little short of what the waves want, ending inside, at the edge and past the
    # edge of a workgroup's children.
    waves.note_overflow()  # forget what earlier frames of other views wanted
    waves.set_capacity(wanted[0] - short, wanted[1] - 1)
    overflows = waves.overflows
    cut = renderer.render(scene, camera, settings)
    assert waves.overflows == overflows  # nothing read in the frame
    assert cut.counts["wave_rays_wanted"] == wanted[0]  # reading the frame's counts notes the overflow
    assert waves.overflows == overflows + 1
    assert not waves.note_overflow()  # noted once, with the frame's statistics
    assert renderer.tracer.queue_overflows() == overflows + 1
    assert waves.overflowed() == wanted  # the GPU counted every ray the waves wanted
    assert np.abs(cut.image - mega.image).max() > 1e-3  # rays past the queues took the sky
    assert waves.ray_capacity == wanted[0] - short  # the frame itself never waited to grow
    grown = renderer.render(scene, camera, settings)
    assert waves.ray_capacity >= wanted[0] and waves.occlusion_capacity >= wanted[1]
    assert waves.overflows == overflows + 1
    assert_same(mega, grown)


def test_queues_exactly_as_long_as_the_waves_want_trace_every_ray(renderer):
    scene, camera, settings, mega, wanted = overflowing_frame(renderer)
    assert wanted[0] % wave_trace.WAVE_LOCAL != 0  # the last workgroup is partly full
    waves = renderer.tracer._waves
    waves.set_capacity(*wanted)
    overflows = waves.overflows
    exact = renderer.render(scene, camera, settings)
    assert (waves.ray_capacity, waves.occlusion_capacity) == wanted
    assert waves.overflows == overflows
    assert_same(mega, exact)


def test_the_waves_fill_the_counter_layout_the_stats_read(renderer):
    make_scene, make_camera = scenes.SCENES["glass_ball"]
    variants.set_override("trace=gpu")
    result = renderer.render(make_scene(), make_camera(), scenes.settings("HYBRID", max_depth=3, near_size=3.0))
    stats = renderer.tracer.read_stats(3)
    assert set(stats.per_depth) == set(COUNTER_KINDS)
    assert stats.per_depth["traced"][0] == result.counts["rays_traced_bounce_1"] > 0
    assert stats.per_depth["bvh_nodes"][0] > 0
