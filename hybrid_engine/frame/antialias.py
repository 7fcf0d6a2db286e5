# SPDX-License-Identifier: GPL-3.0-or-later
"""Anti-aliased final renders: several samples of each pixel, averaged.

The paper's frame takes one primary sample per pixel (its G-buffer is rasterized at the
image's resolution), which is what a real-time viewport wants; a final render of the same
frame shows stair-stepped edges and, worse on this method's mirrors, reflections that
crawl between frames. A final render therefore renders the frame ``render_samples`` times,
each time with the projection moved by a different fraction of a pixel, and averages the
images: a box filter over the pixel, so an edge pixel gets the fraction of it that each
side covers, in colour and (with transparent film) in alpha, premultiplied as Blender
expects.

The samples see the scene from the same point, so the cube map and the near-cube BVH of
the first are kept for the others (``Renderer.render(reuse_world=True)``); each further
sample costs a primary raster, the shading and the trace. The Depth and Normal passes are
taken from the first sample, which lies at the pixels' centres (data passes are not
averaged: the mean of two depths is a depth nothing lies at). The Denoising Albedo and
Normal are the exception, averaged over all samples as Cycles does: a denoiser compares them
with the colour, and an edge pixel's colour is a mix of both sides.
"""
from __future__ import annotations

import numpy as np

from ..scene.camera import Camera
from ..scene.data import SceneData
from ..scene.settings import RenderSettings
from .accumulation import DEFAULT_FILTER_WIDTH, SampleSchedule, sample_offset
from .camera_effects import CameraEffects
from .film import FrameOutputs
from ..passes.trace.wave_trace import wave_count
from .views import cropped_camera
from .renderer import CancelCallback, FrameResult, ProgressCallback, Renderer


def sample_offsets(count: int, filter_width: float = DEFAULT_FILTER_WIDTH) -> np.ndarray:
    """(count, 2) offsets of the first ``count`` samples (``sample_offset``)."""
    if count < 1:
        raise ValueError(f"a frame needs at least one sample, got {count}")
    return np.asarray([sample_offset(i, filter_width) for i in range(count)], np.float64)


def jittered_camera(camera: Camera, dx: float, dy: float) -> Camera:
    """``camera`` with its image moved by (dx, dy) pixels: pixel (i, j) of the new image is
    the point (i + dx, j + dy) of the old one, i.e. the projection translated in NDC."""
    if dx == 0.0 and dy == 0.0:
        return camera
    w, h = camera.width, camera.height
    return cropped_camera(camera, (dx, dy, w + dx, h + dy), w, h)


def render_antialiased(renderer: Renderer, scene: SceneData, camera: Camera, settings: RenderSettings,
                       samples: int, *, outputs: FrameOutputs | None = None, timing: bool = False,
                       cancel: CancelCallback | None = None,
                       progress: ProgressCallback | None = None,
                       filter_width: float = DEFAULT_FILTER_WIDTH, denoise: bool = False,
                       effects: CameraEffects | None = None) -> FrameResult:
    """The frame averaged over ``samples`` sub-pixel positions (``sample_offsets``).

    The result's ``passes`` sum each pass over the samples (the kept cube map and BVH are
    timed once), ``total_ms`` is the whole render, ``counts`` are the first sample's with
    ``samples`` added, and ``data_passes`` are the first sample's (the denoising passes: the
mean of all, read with the last sample's image). Each sample draws its own
    directions in the glossy lobes and the ambient occlusion (``Renderer.render``'s
    ``sample``), so the average converges there too. Raises RenderCancelled between samples
    as between passes. Never an image whose wave queues overflowed: the samples are rendered
    again with the grown queues.

    ``denoise``: each sample's ambient estimate is filtered (passes/denoise/) over the image
    and over the samples so far; the filter's history starts with the first sample, so a
    render does not depend on what the renderer drew before.

    ``effects``: depth of field and motion blur (camera_effects.py): each sample is also
    seen from its own aperture point and at its own time in the shutter.
    """
    if samples < 1:
        raise ValueError(f"a frame needs at least one sample, got {samples}")
    # The wave tracer's queues hold what earlier frames wanted; a sample whose waves wanted
    # more gave the rays past them the sky. Its film already holds that sample, so the
    # render starts over once the queues have grown (they grow from every overflow noted),
    # and at most once per wave: each attempt fits at least the first wave that overflowed.
    for _ in range(wave_count(settings.max_depth) + 1):
        overflows = _queue_overflows(renderer)
        result = _render_samples(renderer, scene, camera, settings, samples, outputs, timing, cancel, progress,
                                 filter_width, denoise, effects)
        if _queue_overflows(renderer) == overflows:
            break
    return result


def _queue_overflows(renderer: Renderer) -> int:
    """Frames so far whose wave queues overflowed (tracer.HybridTracer.queue_overflows)."""
    return 0 if renderer.tracer is None else renderer.tracer.queue_overflows()


def _render_samples(renderer: Renderer, scene: SceneData, camera: Camera, settings: RenderSettings,
                    samples: int, outputs: FrameOutputs | None, timing: bool, cancel: CancelCallback | None,
                    progress: ProgressCallback | None, filter_width: float, denoise: bool,
                    effects: CameraEffects | None = None) -> FrameResult:
    outputs = outputs or FrameOutputs()
    if denoise and renderer.denoiser is not None:
        renderer.denoiser.forget()
    # Only the first sample reads the Depth and Normal back; every sample adds to the
    # denoising means, which the last reads with the image.
    # Cryptomatte, the light passes and Vector count every sample too, and the last reads them.
    later_outputs = FrameOutputs(transparent=outputs.transparent, denoising=outputs.denoising,
                                 cryptomatte=outputs.cryptomatte, light=outputs.light, vector=outputs.vector)
    first: FrameResult | None = None
    passes: dict[str, float] = {}
    total_ms = 0.0
    schedule = SampleSchedule(filter_width)
    image = None
    data: dict[str, np.ndarray] = {}
    while schedule.wants("frame", samples):
        index = schedule.count
        dx, dy = schedule.offset()
        last = index == samples - 1
        if effects is not None and effects.active:
            sample_scene = effects.scene(scene, index)
            sample_camera = effects.camera(camera, index, lambda c: jittered_camera(c, float(dx), float(dy)))
        else:
            sample_scene, sample_camera = scene, jittered_camera(camera, float(dx), float(dy))
        # The mean is kept on the GPU (accumulate=True) and read back after the last sample.
        result = renderer.render(
            sample_scene, sample_camera, settings, timing=timing,
            cancel=cancel, progress=_sample_progress(progress, index, samples),
            outputs=outputs if index == 0 else later_outputs, reuse_world=index > 0, sample=index,
            accumulate=True, read_image=last, denoise=denoise)
        first = first or result
        data.update(result.data_passes)
        image = result.image if last else None
        schedule.advance()
        for name, ms in result.passes.items():
            passes[name] = passes.get(name, 0.0) + ms
        total_ms += result.total_ms
    counts = {**first.counts, "samples": int(samples)}
    return FrameResult(image=image, passes=passes, counts=counts, timing_source=first.timing_source,
                       total_ms=total_ms, mode=first.mode, data_passes=data,
                       near_size=first.near_size, effective=first.effective, diagnostic=first.diagnostic, legend=first.legend)


def _sample_progress(progress: ProgressCallback | None, index: int, samples: int) -> ProgressCallback | None:
    """Progress of one sample as a share of the whole render."""
    if progress is None:
        return None

    def report(step: str, fraction: float) -> None:
        progress(f"sample {index + 1}/{samples}: {step}", (index + fraction) / samples)

    return report

