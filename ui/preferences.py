# SPDX-License-Identifier: GPL-3.0-or-later
"""The add-on's preferences: the OpenGL context Hybrid RT renders with, and *Test GPU*.

An artist whose renders look wrong, or who installs on a new machine, looks here first: the
GL renderer and version, the backend (EGL on Linux, WGL on Windows), the limits that bound
scene sizes, and a button that runs the self-test (``hybrid_rt.test_gpu``).

*Kernel Shapes* overrides which shape of each kernel runs (``hybrid_engine/gpu/variants.py``:
GPU-shaped or shaped for a CPU driver, chosen from the GL renderer by default), for a driver
the renderer string misjudges or to compare both; the ``HYBRID_RT_KERNELS`` environment
variable does the same for a farm or a benchmark.

*Render Device* lists the machine's EGL devices (``hybrid_engine/gpu/egl_devices.py``); the
context is made on the chosen one (*Automatic*: EGL's first). ``HYBRID_RT_DEVICE`` overrides
it per process, which is how a farm worker with several GPUs gives each Blender its own
(docs/FARM.md). The GL context outlives every render, so a change applies at Blender's next
start once a context exists.
"""
from __future__ import annotations

import os

import bpy

from ..blender_adapter.gl_host import gl_block
from ..hybrid_engine.gpu import egl_devices, gl_context, variants

AUTOMATIC_ITEM = ("AUTO", "Automatic", "EGL's first device (HYBRID_RT_DEVICE overrides the choice per process)")
# Blender keeps no reference to the strings a dynamic enum's callback returns: the list stays here.
_device_items: list[tuple[str, str, str, int]] = []


def device_items(_preferences=None, _context=None) -> list[tuple[str, str, str, int]]:
    """*Render Device*'s entries: Automatic, then each EGL device by index and name."""
    items = [(*AUTOMATIC_ITEM, 0)] + [
        (str(device.index), device.label, f"Render on EGL device {device.label}", device.index + 1)
        for device in egl_devices.enumerate_devices()
    ]
    _device_items[:] = items
    return _device_items


def _render_device_changed(preferences, _context) -> None:
    """Hand *Render Device* to the core (before the context exists it takes effect at once)."""
    choice = preferences.render_device
    gl_context.set_device_preference(None if choice in ("", "AUTO") else choice)


def device_lines(preferences) -> list[str]:
    """What the preferences say of the device: an environment override, and a choice that
    waits for Blender's next start because the context already exists."""
    lines = []
    choice, asked_by = gl_context.device_choice()
    if os.environ.get(gl_context.DEVICE_ENV, "").strip():
        lines.append(f"{asked_by} overrides this setting in this process")
    wanted = preferences.render_device
    current = gl_context.current_device() if gl_context.has_context() else None
    if current is not None and wanted not in ("", "AUTO") and wanted != str(current.index):
        lines.append("Restart Blender to render on the chosen device")
    return lines


def context_lines() -> list[str]:
    """What the preferences show of the GL context, or why there is none."""
    try:
        with gl_block():
            ctx = gl_context.get_context()
            limits = gl_context.limits()
            info = ctx.info
            device = gl_context.current_device()
    except gl_context.GLUnavailableError as exc:
        return [f"No OpenGL context: {exc}"]
    return [
        f"Renderer: {info.get('GL_RENDERER', 'unknown')}"
        + (" (software: slow, no GPU)" if gl_context.is_software_renderer() else ""),
        f"Device: {device.label if device is not None else 'the system default'}",
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
    render_device: bpy.props.EnumProperty(
        name="Render Device",
        description=("The EGL device (GPU) Hybrid RT renders on; HYBRID_RT_DEVICE (an index or part of a "
                     "name) overrides it per process. Takes effect at Blender's next start"),
        items=device_items, update=_render_device_changed)

    def draw(self, context) -> None:
        layout = self.layout
        layout.prop(self, "render_device")
        col = layout.column(align=True)
        for line in device_lines(self) + context_lines():
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
        _render_device_changed(addon.preferences, bpy.context)


def unregister() -> None:
    variants.set_override(None)
    gl_context.set_device_preference(None)
    bpy.utils.unregister_class(HybridRTPreferences)
