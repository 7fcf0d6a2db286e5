# SPDX-License-Identifier: GPL-3.0-or-later
"""The add-on's preferences: the OpenGL context Hybrid RT renders with, and *Test GPU*.

An artist whose renders look wrong, or who installs on a new machine, looks here first: the
GL renderer and version, the backend (EGL on Linux, WGL on Windows), the limits that bound
scene sizes, and a button that runs the self-test (``hybrid_rt.test_gpu``).
"""
from __future__ import annotations

import bpy

from ..blender_adapter.gl_host import gl_block
from ..hybrid_engine.gpu import gl_context


def context_lines() -> list[str]:
    """What the preferences show of the GL context, or why there is none."""
    try:
        with gl_block():
            ctx = gl_context.get_context()
            limits = gl_context.limits()
            info = ctx.info
    except gl_context.GLUnavailableError as exc:
        return [f"No OpenGL context: {exc}"]
    return [
        f"Renderer: {info.get('GL_RENDERER', 'unknown')}",
        f"OpenGL: {info.get('GL_VERSION', ctx.version_code)}",
        f"Backend: {gl_context.platform_backend()}",
        f"Storage block limit: {limits.max_ssbo_block_bytes / 2**20:.0f} MiB, "
        f"texture size limit: {limits.max_texture_size} px",
    ]


class HybridRTPreferences(bpy.types.AddonPreferences):
    # The add-on's module: "hybrid_rt" from a checkout, "bl_ext.<repository>.hybrid_rt" installed.
    bl_idname = __package__.rpartition(".")[0]

    def draw(self, context) -> None:
        layout = self.layout
        col = layout.column(align=True)
        for line in context_lines():
            col.label(text=line)
        layout.operator("hybrid_rt.test_gpu", icon="CHECKMARK")


def register() -> None:
    bpy.utils.register_class(HybridRTPreferences)


def unregister() -> None:
    bpy.utils.unregister_class(HybridRTPreferences)
