# SPDX-License-Identifier: GPL-3.0-or-later
"""The values the last frame rendered with (``hybrid_engine.scene.scale.EffectiveValues``):
the near size, far clip and cube-map face resolution that Automatic settings took.

The render panels show them beside the Automatic switches. A panel's draw must stay cheap
and may not read the scene's geometry, so it shows what the last frame, final or viewport,
derived where the renderer had the bounds at hand, instead of deriving them again.
"""
from __future__ import annotations

from ..hybrid_engine.scene.scale import EffectiveValues

_last: EffectiveValues | None = None


def remember(values: EffectiveValues | None) -> None:
    """Keep a frame's values for the panels (None: the frame had none to show)."""
    global _last
    if values is not None:
        _last = values


def last() -> EffectiveValues | None:
    """The last frame's values, None before the first frame of the session."""
    return _last
