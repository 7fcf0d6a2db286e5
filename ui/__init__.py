# SPDX-License-Identifier: GPL-3.0-or-later
"""Hybrid RT user interface: the engine's own panels, plus Blender's standard panels that
apply to this engine (enabled through their ``COMPAT_ENGINES``)."""
from __future__ import annotations

from . import panels


def register() -> None:
    panels.register()


def unregister() -> None:
    panels.unregister()
