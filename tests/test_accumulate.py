# SPDX-License-Identifier: GPL-3.0-or-later
"""The running mean of a view's samples on the GPU (hybrid_engine/passes/film/), and the
frame's one read-back of it (hybrid_engine/frame/readback.py)."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine import RenderSettings
from hybrid_engine.frame.accumulation import sample_offset
from hybrid_engine.frame.antialias import jittered_camera
from hybrid_engine.frame.readback import ImageReadback
from hybrid_engine.passes.film.accumulate import AccumulatePass, AccumulationError
from test_film import cameras as film_cameras, floor_scene

# Sizes that do not divide the 8 x 8 workgroup.
WIDTH, HEIGHT = 37, 21


def _samples(rng, count: int) -> list[np.ndarray]:
    """``count`` HDR samples with a wide range of magnitudes (fireflies beside dark pixels),
    where a plain float32 running sum loses the low bits of small values."""
    return [(rng.lognormal(0.0, 3.0, (HEIGHT, WIDTH, 4)) * rng.choice([1e-3, 1.0, 1e3], (HEIGHT, WIDTH, 1)))
            .astype(np.float32) for _ in range(count)]


def _accumulate(ctx, samples: list[np.ndarray]) -> np.ndarray:
    pass_ = AccumulatePass(ctx)
    color = ctx.texture((WIDTH, HEIGHT), 4, dtype="f4")
    try:
        for index, sample in enumerate(samples):
            color.write(sample.tobytes())
            film = pass_.add(color, index)
        assert film.count == len(samples) and film.size == (WIDTH, HEIGHT)
        out = np.empty((HEIGHT, WIDTH, 4), np.float32)
        film.mean.read_into(out)
        return out
    finally:
        color.release()
        pass_.release()


@pytest.mark.parametrize("count", [1, 2, 16])
def test_the_gpu_mean_equals_the_float64_mean_of_the_samples_to_float32_precision(ctx, rng, count):
    samples = _samples(rng, count)
    reference = np.mean(np.stack(samples).astype(np.float64), axis=0)
    np.testing.assert_allclose(_accumulate(ctx, samples), reference, rtol=1e-6, atol=0.0)


def test_the_compensated_sum_keeps_small_samples_that_a_plain_float32_sum_drops(ctx):
    """One huge sample and many small ones: a float32 running sum rounds every small one away,
    the compensated one keeps them (the test fails with plain summation)."""
    samples = [np.full((HEIGHT, WIDTH, 4), 1.0e4, np.float32)] + [np.full((HEIGHT, WIDTH, 4), 3.0e-4, np.float32)] * 63
    naive = np.float32(0.0)
    for sample in samples:
        naive = np.float32(naive + sample[0, 0, 0])
    reference = (1.0e4 + 63 * 3.0e-4) / 64
    assert abs(naive / 64 - reference) > 1e-6 * reference  # the plain sum is off
    np.testing.assert_allclose(_accumulate(ctx, samples), reference, rtol=1e-6)


def test_sample_zero_starts_the_sum_over_and_a_sample_out_of_step_is_refused(ctx):
    pass_ = AccumulatePass(ctx)
    color = ctx.texture((WIDTH, HEIGHT), 4, dtype="f4")
    try:
        color.write(np.full((HEIGHT, WIDTH, 4), 5.0, np.float32).tobytes())
        pass_.add(color, 0)
        pass_.add(color, 1)
        color.write(np.full((HEIGHT, WIDTH, 4), 2.0, np.float32).tobytes())
        film = pass_.add(color, 0)  # a new view
        out = np.empty((HEIGHT, WIDTH, 4), np.float32)
        film.mean.read_into(out)
        np.testing.assert_array_equal(out, 2.0)
        with pytest.raises(AccumulationError, match="sample 3 .* does not follow the 1 samples"):
            pass_.add(color, 3)
    finally:
        color.release()
        pass_.release()


def test_an_accumulating_frame_reads_the_mean_of_its_samples(renderer):
    """Frames rendered with accumulate=True give the mean of the samples each renders alone."""
    scene, settings = floor_scene(), RenderSettings(mode="RASTER")
    cameras = [jittered_camera(film_cameras()["persp"], *sample_offset(sample)) for sample in range(3)]
    singles, means = [], []
    for sample, camera in enumerate(cameras):
        singles.append(renderer.render(scene, camera, settings, timing=False, sample=sample).image)
    for sample, camera in enumerate(cameras):
        means.append(renderer.render(scene, camera, settings, timing=False, sample=sample, accumulate=True).image)
    assert np.abs(singles[1] - singles[0]).max() > 0  # the samples differ (jittered across the edge)
    for count in (1, 2, 3):
        np.testing.assert_allclose(means[count - 1], np.mean(np.stack(singles[:count]), axis=0), rtol=1e-5, atol=1e-7)


@pytest.mark.parametrize("family", ["cpu", "gpu"])
def test_both_read_backs_bring_the_image_into_one_persistent_array(ctx, rng, family):
    readback = ImageReadback(ctx, family)
    texture = ctx.texture((WIDTH, HEIGHT), 4, dtype="f4")
    try:
        images = []
        for _ in range(3):
            images.append(rng.random((HEIGHT, WIDTH, 4), np.float32))
            texture.write(images[-1].tobytes())
            readback.submit(texture, tag=len(images))
            readback.collect(wait=False)
            if family == "gpu":
                # At most one redraw late: the newest is there, or the one before it (none
                # yet after the first, where the GPU has not finished its copy).
                assert readback.tag in (len(images), len(images) - 1 if len(images) > 1 else None)
        readback.collect(wait=True)
        assert not readback.pending and readback.tag == 3
        np.testing.assert_array_equal(readback.image, images[-1])
        first = readback.image
        texture.write(images[0].tobytes())
        readback.submit(texture, tag=4)
        readback.collect(wait=True)
        assert readback.image is first  # the same array, refilled: nothing allocated per redraw
        np.testing.assert_array_equal(readback.image, images[0])
    finally:
        texture.release()
        readback.release()


def test_the_read_back_follows_the_kernel_variant(ctx, monkeypatch):
    from hybrid_engine.gpu import gl_context, variants

    monkeypatch.setenv(variants.ENVIRONMENT_VARIABLE, "readback=gpu")
    assert ImageReadback(ctx).asynchronous
    monkeypatch.setenv(variants.ENVIRONMENT_VARIABLE, "readback=cpu")
    assert not ImageReadback(ctx).asynchronous
    monkeypatch.setenv(variants.ENVIRONMENT_VARIABLE, "")  # the renderer's own choice
    renderer = gl_context.renderer_name()
    assert ImageReadback(ctx).asynchronous == (variants.choose("readback", renderer) == "gpu")
    assert not ImageReadback(ctx).asynchronous or not gl_context.is_software_renderer()
