# SPDX-License-Identifier: GPL-3.0-or-later
"""The GPU self-test (hybrid_engine/reports/self_test.py) and its button in the add-on's preferences:
it passes on this machine, and a shader broken on purpose makes it fail, naming the shader."""
from __future__ import annotations

from hybrid_engine.gpu import shader_loader
from hybrid_engine.reports import self_test


def test_the_self_test_passes_here(gl):
    result = self_test.run_self_test()
    assert result.ok, result.summary()
    assert [name for name, _, _ in result.steps][-1] == "LBVH trace against the CPU"
    assert "passed" in result.summary()


def test_a_broken_shader_fails_the_self_test_clearly(gl, monkeypatch):
    original = shader_loader.assemble

    def broken(name, defines=None):
        source = original(name, defines)
        if name == "shading/deferred_shade.comp.glsl":
            source = type(source)(**{**source.__dict__, "text": source.text.replace("void main()", "void main( {")})
        return source

    shader_loader.clear_cache()
    monkeypatch.setattr(shader_loader, "assemble", broken)
    try:
        result = self_test.run_self_test()
    finally:
        monkeypatch.undo()
        shader_loader.clear_cache()
    assert not result.ok
    assert "failed" in result.summary() and "deferred_shade" in result.summary()


def test_the_preferences_show_the_context_and_the_test_button(addon):
    import bpy

    prefs = addon.ui.preferences
    lines = prefs.context_lines()
    assert lines[0].startswith("Renderer: ") and any(line.startswith("Backend: egl") for line in lines)
    assert prefs.HybridRTPreferences.bl_idname == addon.__name__
    assert bpy.ops.hybrid_rt.test_gpu() == {"FINISHED"}
