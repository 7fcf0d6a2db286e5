# SPDX-License-Identifier: GPL-3.0-or-later
"""Progressive samples of one view: where each lies and when another is due.

One sample of the paper's frame is a real-time picture, but an aliased and noisy one: each
pixel is sampled at its centre, and the glossy lobes, the ambient occlusion and the soft
shadows draw one set of directions. While nothing changes, more samples of the same view
(each moved by a different fraction of a pixel, the Halton points of
:func:`sample_offset`, and drawing fresh directions, the renderer's ``sample`` index)
average to an anti-aliased, converged image, as Cycles' and EEVEE's viewports do. The viewport adds one sample per redraw until its Viewport Samples
are reached and starts again on any change (the view, the settings, the scene); a final
render adds ``render_samples`` of them at once. The running mean itself is kept on the GPU
by the frame's ``accumulate`` pass (passes/film/).
"""
from __future__ import annotations

import functools
from collections.abc import Hashable

import numpy as np

# Blender's default pixel filter: Blackman-Harris, 1.5 pixels wide (Film > Pixel Filter).
DEFAULT_FILTER_WIDTH = 1.5
_FILTER_TABLE_SIZE = 1024


def _radical_inverse(index: int, base: int) -> float:
    result, scale = 0.0, 1.0 / base
    while index > 0:
        index, digit = divmod(index, base)
        result += digit * scale
        scale /= base
    return result


@functools.lru_cache(maxsize=8)
def _filter_inverse_cdf(width: float) -> tuple[np.ndarray, np.ndarray]:
    """(cdf, x): the cumulative distribution of a Blackman-Harris window ``width`` pixels
    wide, tabulated, to map uniform numbers to offsets distributed like the filter."""
    x = np.linspace(-0.5 * width, 0.5 * width, _FILTER_TABLE_SIZE)
    t = (x / width + 0.5) * 2.0 * np.pi
    weight = np.maximum(0.35875 - 0.48829 * np.cos(t) + 0.14128 * np.cos(2 * t) - 0.01168 * np.cos(3 * t), 0.0)
    cdf = np.cumsum(weight)
    cdf = (cdf - cdf[0]) / (cdf[-1] - cdf[0])
    return cdf, x


def filter_offset(u: float, width: float) -> float:
    """A uniform number in [0, 1) as an offset from the pixel's centre drawn from the pixel
    filter (Blackman-Harris of ``width`` pixels, as Cycles' default): samples are placed by
    the filter's weight, so their plain mean is the filtered pixel (filter importance
    sampling). ``width`` <= 0 keeps every sample at the centre."""
    if width <= 0.0:
        return 0.0
    cdf, x = _filter_inverse_cdf(float(width))
    return float(np.interp(u, cdf, x))


def sample_offset(index: int, filter_width: float = DEFAULT_FILTER_WIDTH) -> tuple[float, float]:
    """Offset of sample ``index`` from the pixels' centres, in pixels: the centre first, then
    the Halton (2, 3) points, which spread evenly for any count (a progressive sequence: the
    first n of 2n are a good set), each axis mapped through the pixel filter."""
    if index == 0:
        return 0.0, 0.0
    return (filter_offset(_radical_inverse(index, 2), filter_width),
            filter_offset(_radical_inverse(index, 3), filter_width))


class SampleSchedule:
    """Which sample of a view is next, for one key (what the samples show), and whether
    another is due. The samples' sum lives on the GPU (passes/film/): the host only
    counts, so a redraw's host work does not grow with the image."""

    def __init__(self, filter_width: float = DEFAULT_FILTER_WIDTH) -> None:
        self.key: Hashable | None = None
        self.count = 0  # samples of ``key`` rendered so far
        self.filter_width = filter_width  # the pixel filter's width (Film > Pixel Filter)

    def wants(self, key: Hashable, target: int) -> bool:
        """Whether another sample of ``key`` is due (fewer than ``target`` so far); a key
        other than the last starts over."""
        if key != self.key:
            self.restart(key)
        return self.count < int(target)

    def restart(self, key: Hashable | None = None) -> None:
        """Forget the samples (the next one is sample 0, at the pixels' centres)."""
        self.key, self.count = key, 0

    def offset(self) -> tuple[float, float]:
        """The next sample's offset from the pixels' centres, in pixels."""
        return sample_offset(self.count, self.filter_width)

    def advance(self) -> int:
        """Count the sample just rendered; returns the samples so far."""
        self.count += 1
        return self.count
