# SPDX-License-Identifier: GPL-3.0-or-later
"""Hybrid RT user interface: the engine's own panels, Blender's standard panels that apply to
this engine (enabled through their ``COMPAT_ENGINES``), and the add-on's preferences."""
from __future__ import annotations

from . import panels, preferences


def register() -> None:
    panels.register()
    preferences.register()


def unregister() -> None:
    preferences.unregister()
    panels.unregister()
