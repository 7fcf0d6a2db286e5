# SPDX-License-Identifier: GPL-3.0-or-later
"""Run the core's GL work inside Blender without disturbing Blender's own OpenGL.

Every block of GL work from a Blender callback (F12 render, viewport frame, teardown) goes
through ``gl_block()``: our EGL context is made current for the block and Blender's context
is restored afterwards. In an interactive session the context is also handed back after each
block, because F12 renders run on a render thread and the viewport on the main thread, and an
EGL context can be current on one thread only. Background runs keep it current.
"""
from __future__ import annotations

import bpy

from ..hybrid_engine.gpu import gl_context


def gl_block():
    """Context manager for one block of GL work from a Blender callback."""
    return gl_context.activated(release_after=not bpy.app.background)
