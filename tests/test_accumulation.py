# SPDX-License-Identifier: GPL-3.0-or-later
"""Where a view's samples lie and when another is due (hybrid_engine/frame/accumulation.py)."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine.frame.accumulation import SampleSchedule, sample_offset


def test_samples_of_one_key_are_counted_up_to_the_target():
    schedule = SampleSchedule()
    rendered = 0
    while schedule.wants("view", 3):
        schedule.advance()
        rendered += 1
    assert rendered == 3 and schedule.count == 3
    assert not schedule.wants("view", 3)
    assert schedule.wants("view", 4)  # a higher target asks for more of the same view


def test_a_new_key_starts_over_at_the_pixel_centre():
    schedule = SampleSchedule()
    schedule.wants("a", 8)
    schedule.advance()
    assert schedule.offset() != (0.0, 0.0)
    assert schedule.wants("b", 8) and schedule.count == 0
    assert schedule.offset() == (0.0, 0.0)


def test_sample_offsets_are_distinct_and_inside_the_pixel():
    points = np.array([sample_offset(i) for i in range(64)])
    assert (np.abs(points) < 0.5).all()
    assert len({tuple(p) for p in points}) == 64
    # Progressive: the first 16 already cover every quarter of the pixel.
    quarters = {(x >= 0, y >= 0) for x, y in points[:16]}
    assert len(quarters) == 4


@pytest.mark.parametrize("width", [0.5, 1.5, 3.0])
def test_sample_offsets_follow_the_pixel_filter_of_its_width(width):
    """Samples are spread by the Blackman-Harris filter (Film > Pixel Filter): inside its
    width, centred, with the filter's own spread (second moment, integrated independently)."""
    from hybrid_engine.frame.accumulation import sample_offset

    offsets = np.array([sample_offset(i, width) for i in range(1, 1025)])
    assert np.abs(offsets).max() <= width / 2 + 1e-9
    np.testing.assert_allclose(offsets.mean(axis=0), 0.0, atol=0.01 * width)
    x = np.linspace(-width / 2, width / 2, 20001)
    t = 2 * np.pi * (x / width + 0.5)
    weight = 0.35875 - 0.48829 * np.cos(t) + 0.14128 * np.cos(2 * t) - 0.01168 * np.cos(3 * t)
    spread = np.sqrt((weight * x ** 2).sum() / weight.sum())
    np.testing.assert_allclose(offsets.std(axis=0), spread, rtol=0.03)
    assert sample_offset(0, width) == (0.0, 0.0)
