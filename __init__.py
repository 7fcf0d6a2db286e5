# SPDX-License-Identifier: GPL-3.0-or-later
"""Hybrid RT: real-time multiply recursive reflections and refractions for Blender.

The repository root is the add-on package. Import order (checked by tests/test_layout.py):
``hybrid_engine`` (core, no bpy) < ``blender_adapter`` (depsgraph extraction, properties,
RenderEngine) < ``operators`` < ``ui`` < this file. Only relative imports are used, so the
package works under whatever name Blender installs it (``bl_ext.<repo>.hybrid_rt``).
"""
from __future__ import annotations

from . import blender_adapter, operators, ui

_MODULES = (blender_adapter, operators, ui)


def register() -> None:
    """Register properties, the render engine, operators and panels, in dependency order.
    On macOS, whose OpenGL stops at 4.1 (no compute shaders), enabling the extension fails
    with a message that says so, and nothing is registered."""
    import sys

    from .hybrid_engine.gpu.gl_context import MACOS_MESSAGE

    if sys.platform == "darwin":
        raise RuntimeError(MACOS_MESSAGE)
    done = []
    try:
        for module in _MODULES:
            module.register()
            done.append(module)
    except Exception:
        for module in reversed(done):  # leave nothing half-registered behind
            module.unregister()
        raise


def unregister() -> None:
    """Remove everything register() added, in reverse order."""
    for module in reversed(_MODULES):
        module.unregister()
