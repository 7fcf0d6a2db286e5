# SPDX-License-Identifier: GPL-3.0-or-later
"""hybrid_engine/scene/changes.py: a frame's delta as triangle ranges."""
from __future__ import annotations

import numpy as np

from hybrid_engine.scene.changes import GeometryDelta, merge_ranges, range_mask


def test_runs_of_a_mask_are_exact_ranges_and_close_runs_merge_only_when_asked():
    mask = np.zeros(100, bool)
    mask[[10, 11, 12, 20, 40]] = True
    assert merge_ranges(mask) == [(10, 3), (20, 1), (40, 1)]
    assert merge_ranges(mask, gap=10) == [(10, 11), (40, 1)]
    assert merge_ranges(np.zeros(5, bool)) == []


def test_a_range_mask_marks_exactly_the_rows_of_its_ranges():
    mask = range_mask(np.array([[2, 3], [10, 1]]), 12)
    assert np.flatnonzero(mask).tolist() == [2, 3, 4, 10]


def test_everything_is_one_range_and_nothing_is_unchanged():
    assert GeometryDelta.everything(7, sequence=3) == GeometryDelta(True, ((0, 7),), 7, 3)
    assert GeometryDelta(full=False).unchanged and not GeometryDelta.everything(1).unchanged
