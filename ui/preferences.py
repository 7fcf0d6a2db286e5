# SPDX-License-Identifier: GPL-3.0-or-later
"""The add-on's preferences: the OpenGL context Hybrid RT renders with, and *Test GPU*.

An artist whose renders look wrong, or who installs on a new machine, looks here first: the
GL renderer and version, the backend (EGL on Linux, WGL on Windows), the limits that bound
scene sizes, and a button that runs the self-test (``hybrid_rt.test_gpu``).

*Kernel Shapes* overrides which shape of each kernel runs (``hybrid_engine/gpu/variants.py``:
GPU-shaped or shaped for a CPU driver, chosen from the GL renderer by default), for a driver
the renderer string misjudges or to compare both; the ``HYBRID_RT_KERNELS`` environment
variable does the same for a farm or a benchmark.
"""
from __future__ import annotations

import bpy

from ..blender_adapter.gl_host import gl_block
from ..hybrid_engine.gpu import gl_context, variants


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


def _kernel_shapes_changed(preferences, _context) -> None:
    """Apply *Kernel Shapes*; a value the engine does not understand is said and undone (to
    automatic), never half applied."""
    try:
        variants.set_override(preferences.kernel_shapes or None)
    except variants.VariantError as exc:
        print(f"Hybrid RT: Kernel Shapes: {exc}; back to automatic")
        variants.set_override(None)
        if preferences.kernel_shapes:
            preferences.kernel_shapes = ""


def kernel_lines() -> list[str]:
    """Which shape each kernel runs, as the preferences show it."""
    try:
        with gl_block():
            chosen = variants.chosen()
    except (gl_context.GLUnavailableError, variants.VariantError) as exc:
        return [f"Kernel shapes unknown: {exc}"]
    return ["Kernels: " + ", ".join(f"{kernel} {family.upper()}" for kernel, family in chosen.items())]


class HybridRTPreferences(bpy.types.AddonPreferences):
    # The add-on's module: "hybrid_rt" from a checkout, "bl_ext.<repository>.hybrid_rt" installed.
    bl_idname = __package__.rpartition(".")[0]

    kernel_shapes: bpy.props.StringProperty(
        name="Kernel Shapes",
        description=("Override the shape of the GPU kernels: empty or 'auto' follows the GL renderer "
                     "(GPU-shaped on a GPU, CPU-shaped on a software driver); 'gpu' or 'cpu' for all, "
                     "or per kernel, e.g. 'trace=gpu, sort=cpu'. Renders started after the change use it"),
        default="", update=_kernel_shapes_changed)

    def draw(self, context) -> None:
        layout = self.layout
        col = layout.column(align=True)
        for line in context_lines():
            col.label(text=line)
        layout.prop(self, "kernel_shapes")
        col = layout.column(align=True)
        for line in kernel_lines():
            col.label(text=line)
        layout.operator("hybrid_rt.test_gpu", icon="CHECKMARK")


def register() -> None:
    bpy.utils.register_class(HybridRTPreferences)
    addon = bpy.context.preferences.addons.get(HybridRTPreferences.bl_idname)
    if addon is not None and addon.preferences is not None:  # a saved override applies at start-up
        _kernel_shapes_changed(addon.preferences, bpy.context)


def unregister() -> None:
    variants.set_override(None)
    bpy.utils.unregister_class(HybridRTPreferences)
