# SPDX-License-Identifier: GPL-3.0-or-later
"""hybrid_engine/scene/changes.py: a frame's delta as triangle ranges."""
from __future__ import annotations

from hybrid_engine.scene.changes import GeometryDelta


def test_everything_is_one_range_and_nothing_is_unchanged():
    assert GeometryDelta.everything(7, sequence=3) == GeometryDelta(True, ((0, 7),), 7, 3)
    assert GeometryDelta.everything(0).ranges == ()
    assert GeometryDelta(full=False).unchanged and not GeometryDelta.everything(1).unchanged
