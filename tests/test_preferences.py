# SPDX-License-Identifier: GPL-3.0-or-later
"""The add-on's preferences (ui/preferences.py): *Kernel Shapes* overrides which shape of each
kernel runs, and a value the engine does not know is refused without being half applied."""
from __future__ import annotations

import pytest


@pytest.fixture
def variants(addon):
    """The add-on's own copy of the module (it is imported as the package ``hybrid_rt``)."""
    return addon.hybrid_engine.gpu.variants


@pytest.fixture
def preferences(addon, variants):
    import bpy

    entry = bpy.context.preferences.addons.get(addon.__name__)
    made = entry is None
    if made:  # enabled through the loader, not addon_utils: give it its preferences entry
        entry = bpy.context.preferences.addons.new()
        entry.module = addon.__name__
    try:
        yield entry.preferences
    finally:
        entry.preferences.kernel_shapes = ""
        if made:
            bpy.context.preferences.addons.remove(entry)
        variants.set_override(None)


def test_kernel_shapes_override_the_renderers_choice_and_auto_restores_it(preferences, variants, gl):
    preferences.kernel_shapes = "trace=gpu, sort=gpu"
    assert variants.choose("trace") == "gpu" and variants.choose("sort") == "gpu"
    assert variants.choose("scan") == "cpu"  # not named: llvmpipe's own choice
    preferences.kernel_shapes = ""
    assert variants.chosen() == {kernel: "cpu" for kernel in variants.KERNELS}


def test_an_unknown_kernel_shape_is_refused_and_the_choice_stays_automatic(preferences, variants, gl, capsys):
    preferences.kernel_shapes = "trace=gpu"
    preferences.kernel_shapes = "trace=fast"
    assert preferences.kernel_shapes == ""
    assert variants.choose("trace") == "cpu"
    assert "Kernel Shapes: unknown kernel family 'fast'" in capsys.readouterr().out


def test_the_preferences_list_each_kernels_shape(addon, variants, gl):
    (line,) = addon.ui.preferences.kernel_lines()
    assert all(f"{kernel} CPU" in line for kernel in variants.KERNELS)


def test_render_device_lists_automatic_and_each_egl_device_and_hands_the_choice_to_the_core(
        addon, preferences, monkeypatch):
    gl_context = addon.hybrid_engine.gpu.gl_context
    devices = addon.hybrid_engine.gpu.egl_devices.enumerate_devices()
    items = [item[:2] for item in addon.ui.preferences.device_items()]
    assert items == [("AUTO", "Automatic")] + [(str(d.index), d.label) for d in devices]
    monkeypatch.delenv(gl_context.DEVICE_ENV, raising=False)
    try:
        preferences.render_device = str(devices[-1].index)
        assert gl_context.device_choice()[0] == str(devices[-1].index)
        monkeypatch.setenv(gl_context.DEVICE_ENV, "0")
        assert addon.ui.preferences.device_lines(preferences)[0] == "HYBRID_RT_DEVICE=0 overrides this setting in this process"
        preferences.render_device = "AUTO"
        monkeypatch.delenv(gl_context.DEVICE_ENV)
        assert gl_context.device_choice() == (None, "automatic")
    finally:
        gl_context.set_device_preference(None)
