# SPDX-License-Identifier: GPL-3.0-or-later
"""The running mean of one view's samples (hybrid_engine/accumulation.py)."""
from __future__ import annotations

import numpy as np

from hybrid_engine.accumulation import SampleAccumulator, sample_offset


def test_samples_of_one_key_average_and_stop_at_the_target():
    acc = SampleAccumulator()
    images = [np.full((2, 3, 4), float(i), np.float32) for i in range(5)]
    added = 0
    while acc.wants("view", 3):
        acc.add(images[added])
        added += 1
    assert added == 3 and acc.count == 3
    np.testing.assert_allclose(acc.mean, 1.0)  # (0 + 1 + 2) / 3
    assert not acc.wants("view", 3)
    assert acc.wants("view", 4)  # a higher target asks for more of the same view


def test_a_new_key_starts_over_at_the_pixel_centre():
    acc = SampleAccumulator()
    acc.wants("a", 8)
    acc.add(np.ones((1, 1, 4), np.float32))
    assert acc.offset() != (0.0, 0.0)
    assert acc.wants("b", 8) and acc.count == 0 and acc.mean is None
    assert acc.offset() == (0.0, 0.0)


def test_sample_offsets_are_distinct_and_inside_the_pixel():
    points = np.array([sample_offset(i) for i in range(64)])
    assert (np.abs(points) < 0.5).all()
    assert len({tuple(p) for p in points}) == 64
    # Progressive: the first 16 already cover every quarter of the pixel.
    quarters = {(x >= 0, y >= 0) for x, y in points[:16]}
    assert len(quarters) == 4
