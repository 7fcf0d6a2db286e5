# SPDX-License-Identifier: GPL-3.0-or-later
"""Blender glue: properties, depsgraph extraction and the RenderEngine.

Thin by design: everything that can be tested without Blender lives in ``hybrid_engine``.
"""
from __future__ import annotations

from . import engine, properties


def register() -> None:
    properties.register()
    engine.register()


def unregister() -> None:
    engine.unregister()
    properties.unregister()
