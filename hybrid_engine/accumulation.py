# SPDX-License-Identifier: GPL-3.0-or-later
"""Progressive samples of one view: the running mean the viewport and final renders share.

One sample of the paper's frame is a real-time picture, but an aliased and noisy one: each
pixel is sampled at its centre, and the glossy lobes, the ambient occlusion and the soft
shadows draw one set of directions. While nothing changes, more samples of the same view
(each moved by a different fraction of a pixel, the Halton points of
:func:`sample_offset`, and drawing fresh directions, the renderer's ``sample`` index) average to an anti-aliased, converged image, as Cycles' and
EEVEE's viewports do. The viewport adds one sample per redraw until its Viewport Samples
are reached and starts again on any change (the view, the settings, the scene); a final
render adds ``render_samples`` of them at once.
"""
from __future__ import annotations

from collections.abc import Hashable

import numpy as np


def _radical_inverse(index: int, base: int) -> float:
    result, scale = 0.0, 1.0 / base
    while index > 0:
        index, digit = divmod(index, base)
        result += digit * scale
        scale /= base
    return result


def sample_offset(index: int) -> tuple[float, float]:
    """Offset of sample ``index`` from the pixels' centres, in pixels, inside (-0.5, 0.5)^2:
    the centre first, then the Halton (2, 3) points, which spread evenly over the pixel for
    any count (a progressive sequence: the first n of 2n are a good set)."""
    if index == 0:
        return 0.0, 0.0
    return _radical_inverse(index, 2) - 0.5, _radical_inverse(index, 3) - 0.5


class SampleAccumulator:
    """The running mean of the samples rendered for one key (what the samples show)."""

    def __init__(self) -> None:
        self.key: Hashable | None = None
        self.count = 0
        self._sum: np.ndarray | None = None

    def wants(self, key: Hashable, target: int) -> bool:
        """Whether another sample of ``key`` is due (fewer than ``target`` so far); a key
        other than the last starts over."""
        if key != self.key:
            self.restart(key)
        return self.count < int(target)

    def restart(self, key: Hashable | None = None) -> None:
        """Forget the samples (the next one is sample 0, at the pixels' centres)."""
        self.key, self.count, self._sum = key, 0, None

    def offset(self) -> tuple[float, float]:
        """The next sample's offset from the pixels' centres, in pixels."""
        return sample_offset(self.count)

    def add(self, image: np.ndarray) -> np.ndarray:
        """Add the next sample's image; returns the mean so far."""
        if self._sum is None or self._sum.shape != image.shape:
            self._sum, self.count = np.zeros(image.shape, np.float64), 0
        self._sum += image
        self.count += 1
        return self.mean

    @property
    def mean(self) -> np.ndarray | None:
        """The mean of the samples so far (float32), None before the first."""
        if self._sum is None or self.count == 0:
            return None
        return (self._sum / self.count).astype(np.float32)
