# SPDX-License-Identifier: GPL-3.0-or-later
"""hybrid_engine.gpu.gl_context: one context per process, clear errors when GL 4.3/EGL is missing."""
from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from conftest import REPO_ROOT


def run_isolated(code: str, **env: str) -> subprocess.CompletedProcess:
    """Run ``code`` in a fresh interpreter (a new process gets its own GL context)."""
    import os

    return subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)], cwd=REPO_ROOT, capture_output=True, text=True,
        env={**os.environ, **env}, timeout=120,
    )


def test_every_caller_gets_the_same_context(gl):
    from hybrid_engine.gpu import gl_context

    assert gl_context.get_context() is gl
    assert gl.version_code >= gl_context.REQUIRED_GL_VERSION


def test_limits_report_the_drivers_storage_block_and_dispatch_limits(gl):
    from hybrid_engine.gpu import gl_context

    limits = gl_context.limits()
    assert limits.max_ssbo_block_bytes >= 1 << 24  # GL 4.3 guarantees at least 16 MiB
    assert min(limits.max_compute_workgroup_count) >= 65535


def test_unknown_backend_fails_with_a_message_naming_it_and_the_fix():
    result = run_isolated(
        """
        from hybrid_engine.gpu import gl_context
        try:
            gl_context.get_context()
        except gl_context.GLUnavailableError as exc:
            print("ERROR:", exc)
        """,
        HYBRID_RT_GL_BACKEND="nonexistent-backend",
    )
    assert "ERROR:" in result.stdout, result.stderr
    assert "nonexistent-backend" in result.stdout
    assert "EGL" in result.stdout


def test_a_driver_below_opengl_4_3_is_refused_with_the_version_it_offers(monkeypatch):
    from hybrid_engine.gpu import gl_context
    import moderngl

    class OldContext:
        version_code = 330
        info = {"GL_VERSION": "3.3 (Compatibility Profile) Mesa"}
        released = False

        def release(self):
            OldContext.released = True

    monkeypatch.setattr(moderngl, "create_context", lambda **kwargs: OldContext())
    with pytest.raises(gl_context.GLUnavailableError, match=r"OpenGL 4\.3.*3\.3"):
        gl_context._create_context()
    assert OldContext.released, "the refused context must be released"


def test_driver_refusing_the_required_version_names_opengl_4_3(monkeypatch):
    from hybrid_engine.gpu import gl_context
    import moderngl

    def refuse(**kwargs):
        raise Exception("requested OpenGL version 430, got version 410")

    monkeypatch.setattr(moderngl, "create_context", refuse)
    with pytest.raises(gl_context.GLUnavailableError, match=r"needs OpenGL 4\.3"):
        gl_context._create_context()


def test_activated_renders_in_our_context_and_restores_a_host_context():
    """Inside Blender's viewport callbacks Blender's context is current: our frame must run in
    our own context and hand Blender's back afterwards (a second EGL context stands in for
    Blender's here)."""
    result = run_isolated(
        """
        import ctypes, moderngl, numpy as np
        from hybrid_engine import Camera, Geometry, MaterialTable, Lights, SceneData, Sky, RenderSettings
        from hybrid_engine.gpu import gl_context
        from hybrid_engine.frame.renderer import Renderer
        egl = ctypes.CDLL("libEGL.so.1"); egl.eglGetCurrentContext.restype = ctypes.c_void_p
        ours = gl_context.get_context(); ours_handle = egl.eglGetCurrentContext()
        renderer = Renderer()
        host = moderngl.create_context(standalone=True, backend="egl")  # now current, like Blender's
        host_handle = egl.eglGetCurrentContext()
        assert host_handle != ours_handle
        scene = SceneData(Geometry.empty(), MaterialTable.default(), Lights.empty(), Sky(color=(0.25, 0.5, 1.0)))
        with gl_context.activated():
            inside = egl.eglGetCurrentContext()
            image = renderer.render(scene, Camera(width=8, height=4), RenderSettings(mode="RASTER")).image
        after = egl.eglGetCurrentContext()
        print("INSIDE_OURS", inside == ours_handle)
        print("HOST_RESTORED", after == host_handle)
        print("IMAGE_OK", bool(np.allclose(image[..., :3], [0.25, 0.5, 1.0])))
        """
    )
    assert "INSIDE_OURS True" in result.stdout, result.stdout + result.stderr
    assert "HOST_RESTORED True" in result.stdout
    assert "IMAGE_OK True" in result.stdout


def test_activated_leaves_our_context_current_when_no_host_context_exists():
    result = run_isolated(
        """
        import numpy as np
        from hybrid_engine.gpu import gl_context
        ctx = gl_context.get_context()
        with gl_context.activated():
            pass
        buf = ctx.buffer(np.arange(4, dtype="f4").tobytes())
        print("READ", np.frombuffer(buf.read(), "f4").tolist())
        """
    )
    assert "READ [0.0, 1.0, 2.0, 3.0]" in result.stdout, result.stdout + result.stderr


def test_activated_can_hand_the_context_back_for_use_on_another_thread():
    """Interactive Blender renders F12 on a render thread and the viewport on the main thread:
    with release_after the context is free for the next thread that activates it."""
    result = run_isolated(
        """
        import ctypes, threading, numpy as np
        from hybrid_engine.gpu import gl_context
        egl = ctypes.CDLL("libEGL.so.1"); egl.eglGetCurrentContext.restype = ctypes.c_void_p
        ctx = gl_context.get_context()
        with gl_context.activated(release_after=True):
            pass
        print("RELEASED", egl.eglGetCurrentContext() is None)
        out = {}
        def worker():
            with gl_context.activated(release_after=True) as c:
                buf = c.buffer(np.arange(3, dtype="f4").tobytes())
                out["read"] = np.frombuffer(buf.read(), "f4").tolist()
                buf.release()
        t = threading.Thread(target=worker); t.start(); t.join()
        print("THREAD", out.get("read"))
        with gl_context.activated():
            buf = ctx.buffer(np.ones(2, dtype="f4").tobytes())
            print("MAIN", np.frombuffer(buf.read(), "f4").tolist())
        """
    )
    assert "RELEASED True" in result.stdout, result.stdout + result.stderr
    assert "THREAD [0.0, 1.0, 2.0]" in result.stdout, result.stdout + result.stderr
    assert "MAIN [1.0, 1.0]" in result.stdout, result.stdout + result.stderr


def test_a_thread_takes_the_context_over_from_the_main_thread_and_leaves_its_gl_state_behind():
    """A preview on Blender's job thread while the main thread keeps the context between its
    blocks: the job thread waits until the main thread hands the context over, its block runs
    alone (no block of the main thread overlaps it), and the main thread finds its bound
    framebuffer, program, viewport and capabilities as it left them."""
    result = run_isolated(
        """
        import threading, time, numpy as np
        from hybrid_engine.gpu import gl_context
        ctx = gl_context.get_context()
        gl = gl_context._gl_functions()
        main_fbo = ctx.simple_framebuffer((8, 8))
        program = ctx.program(vertex_shader="#version 430\\nvoid main() { gl_Position = vec4(0.0); }",
                              fragment_shader="#version 430\\nout vec4 c; void main() { c = vec4(1.0); }")
        def state():
            return (gl.integers(0x8CA6)[0], gl.integers(0x8B8D)[0], tuple(gl.integers(0x0BA2, 4)),
                    bool(gl.is_enabled(0x0BE2)), bool(gl.is_enabled(0x0B44)), ctx.fbo is main_fbo)
        with gl_context.activated():
            main_fbo.use(); ctx.viewport = (1, 2, 3, 4); ctx.enable(ctx.BLEND); ctx.disable(ctx.CULL_FACE)
            gl.use_program(program.glo)
            before = state()
        spans, out = [], {}
        def worker():
            with gl_context.activated() as c:
                start = time.perf_counter()
                other = c.simple_framebuffer((16, 16)); other.use(); c.viewport = (0, 0, 16, 16)
                c.disable(c.BLEND); c.enable(c.CULL_FACE); gl.use_program(0)
                other.clear(0.5, 0.25, 0.0, 1.0)
                out["pixel"] = np.frombuffer(other.read(components=4), np.uint8)[:4].tolist()
                time.sleep(0.2)
                spans.append(("worker", start, time.perf_counter()))
        thread = threading.Thread(target=worker); thread.start()
        time.sleep(0.2)
        print("WORKER_WAITED", "pixel" not in out)
        for _ in range(20):  # the main thread's own blocks, as viewport frames
            with gl_context.activated():
                start = time.perf_counter(); after = state(); time.sleep(0.02)
                spans.append(("main", start, time.perf_counter()))
                if after != before:
                    print("MAIN_STATE_CHANGED", before, after)
        thread.join()
        worker_span = [s for s in spans if s[0] == "worker"][0]
        overlaps = [s for s in spans if s[0] == "main" and s[1] < worker_span[2] and worker_span[1] < s[2]]
        print("PIXEL", out.get("pixel"))
        print("OVERLAPS", len(overlaps))
        with gl_context.activated():
            print("STATE_KEPT", state() == before)
        """
    )
    assert "WORKER_WAITED True" in result.stdout, result.stdout + result.stderr
    assert "PIXEL [128, 64, 0, 255]" in result.stdout, result.stdout + result.stderr
    assert "OVERLAPS 0" in result.stdout
    assert "MAIN_STATE_CHANGED" not in result.stdout, result.stdout
    assert "STATE_KEPT True" in result.stdout, result.stdout


def test_the_addon_and_the_core_imported_under_two_names_share_one_context(gl):
    """Blender imports the add-on as bl_ext.*.hybrid_rt while scripts import hybrid_engine:
    still one context per process."""
    from conftest import load_addon

    addon = load_addon()
    assert addon.hybrid_engine.gpu.gl_context is not __import__("hybrid_engine.gpu.gl_context").gpu.gl_context
    assert addon.hybrid_engine.gpu.gl_context.get_context() is gl


@pytest.mark.parametrize("platform,backend", [("linux", "egl"), ("win32", "wgl")])
def test_each_platform_gets_its_own_backend_and_the_override_wins(monkeypatch, platform, backend):
    from hybrid_engine.gpu import gl_context

    monkeypatch.delenv("HYBRID_RT_GL_BACKEND", raising=False)
    assert gl_context.platform_backend(platform) == backend
    monkeypatch.setenv("HYBRID_RT_GL_BACKEND", "x11")
    assert gl_context.platform_backend(platform) == "x11"


def test_macos_is_refused_with_a_message_that_says_why(monkeypatch):
    from hybrid_engine.gpu import gl_context

    monkeypatch.delenv("HYBRID_RT_GL_BACKEND", raising=False)
    with pytest.raises(gl_context.GLUnavailableError, match="OpenGL 4.1"):
        gl_context.platform_backend("darwin")


def test_the_native_context_switch_is_linux_only():
    """Off Linux the EGL/GLX ctypes path is never loaded: glcontext's own save and restore
    of the host's context (WGL on Windows) is used instead."""
    from hybrid_engine.gpu import gl_context

    elsewhere = gl_context._NativeGL(linux=False)
    assert elsewhere.egl is None and elsewhere.glx is None
    assert gl_context._NativeGL(linux=True).egl is not None  # this Linux machine has libEGL


def test_enabling_the_extension_on_macos_fails_with_the_reason_and_registers_nothing(monkeypatch):
    import bpy

    from addon_loader import load_addon

    addon = load_addon()
    monkeypatch.setattr(sys, "platform", "darwin")
    with pytest.raises(RuntimeError, match="macOS provides OpenGL 4.1"):
        addon.register()
    assert not hasattr(bpy.types.Scene, "hybrid_rt")


def test_off_linux_a_gl_block_enters_and_leaves_through_glcontext(monkeypatch, gl):
    from hybrid_engine.gpu import gl_context

    calls = []
    monkeypatch.setattr(gl_context, "_native", gl_context._NativeGL(linux=False))
    monkeypatch.setattr(sys, "platform", "win32")
    monkeypatch.setattr(type(gl), "__enter__", lambda self: calls.append("enter") or self)
    monkeypatch.setattr(type(gl), "__exit__", lambda self, *exc: calls.append("exit"))
    with gl_context.activated(release_after=True) as ctx:
        assert ctx is gl
    assert calls == ["enter", "exit"]


# ---------------------------------------------------------------------------------------------
# The render device: Preferences choose it, HYBRID_RT_DEVICE overrides them per process.

def two_devices():
    from hybrid_engine.gpu.egl_devices import EGLDevice

    return [EGLDevice(0, "NVIDIA RTX A6000 (/dev/dri/card1, nvidia, PCI 0000:01:00.0)", "/dev/dri/card1"),
            EGLDevice(1, "NVIDIA RTX A6000 (/dev/dri/card2, nvidia, PCI 0000:41:00.0)", "/dev/dri/card2")]


@pytest.fixture
def device_state(monkeypatch):
    """No override from the environment and no preference, restored afterwards."""
    from hybrid_engine.gpu import gl_context

    monkeypatch.delenv(gl_context.DEVICE_ENV, raising=False)
    saved = gl_context._state.device_preference
    gl_context.set_device_preference(None)
    yield gl_context
    gl_context.set_device_preference(saved)


def test_a_device_is_chosen_by_index_or_by_a_part_of_its_name(device_state):
    devices = two_devices()
    assert device_state.choose_device("1", devices) is devices[1]
    assert device_state.choose_device("card2", devices) is devices[1]
    assert device_state.choose_device("pci 0000:01", devices) is devices[0]
    assert device_state.choose_device(None, devices) is None
    assert device_state.choose_device("auto", devices) is None


def test_a_bad_device_choice_fails_with_a_message_listing_the_devices(device_state):
    devices = two_devices()
    for choice in ("2", "radeon", "RTX"):  # out of range, no match, ambiguous
        with pytest.raises(device_state.GLUnavailableError) as caught:
            device_state.choose_device(choice, devices, "HYBRID_RT_DEVICE=" + choice)
        message = str(caught.value)
        assert devices[0].label in message and devices[1].label in message, message
        assert f"HYBRID_RT_DEVICE={choice}" in message


def test_the_environment_overrides_the_preference(device_state, monkeypatch):
    device_state.set_device_preference("1")
    assert device_state.device_choice()[0] == "1"
    monkeypatch.setenv(device_state.DEVICE_ENV, "card1")
    choice, asked_by = device_state.device_choice()
    assert choice == "card1" and asked_by == "HYBRID_RT_DEVICE=card1"
    device_state.set_device_preference("auto")
    monkeypatch.delenv(device_state.DEVICE_ENV)
    assert device_state.device_choice() == (None, "automatic")


def test_the_chosen_device_becomes_glcontexts_device_index(device_state, monkeypatch):
    from hybrid_engine.gpu import egl_devices

    monkeypatch.setattr(egl_devices, "enumerate_devices", two_devices)
    monkeypatch.setenv(device_state.DEVICE_ENV, "card2")
    assert device_state._device_kwargs("egl") == {"device_index": 1}
    monkeypatch.delenv(device_state.DEVICE_ENV)
    assert device_state._device_kwargs("egl") == {}  # automatic: glcontext's own default


def test_a_device_choice_off_egl_is_refused(device_state, monkeypatch):
    monkeypatch.setenv(device_state.DEVICE_ENV, "1")
    with pytest.raises(device_state.GLUnavailableError, match="through EGL"):
        device_state._device_kwargs("wgl")


def test_a_context_is_made_on_the_device_chosen_by_index_or_name_and_says_it_is_software():
    code = """
        from hybrid_engine.gpu import gl_context, egl_devices
        ctx = gl_context.get_context()
        device = gl_context.current_device()
        print("DEVICE", device.index, device.software)
        print("DESCRIPTION", gl_context.device_description())
        print("LIVE", ctx.version_code >= 430)
        """
    software = [d for d in __import__("hybrid_engine.gpu.egl_devices").gpu.egl_devices.enumerate_devices()
                if d.software][0]
    for choice in (str(software.index), "SOFTWARE RENDERER"):
        result = run_isolated(code, HYBRID_RT_DEVICE=choice)
        assert f"DEVICE {software.index} True" in result.stdout, result.stdout + result.stderr
        assert "LIVE True" in result.stdout
        assert f"EGL device {software.label}" in result.stdout
        assert "llvmpipe" in result.stdout and "a software renderer: slow" in result.stdout


def test_the_device_index_reaches_glcontext():
    """A second device listed where EGL has one: glcontext is asked for index 1 and refuses, which
    proves the choice is not dropped on the way (the context would come up on device 0)."""
    result = run_isolated(
        """
        from hybrid_engine.gpu import gl_context, egl_devices
        from hybrid_engine.gpu.egl_devices import EGLDevice
        real = egl_devices.enumerate_devices()
        egl_devices.enumerate_devices = lambda: real + [EGLDevice(len(real), "Second GPU (/dev/dri/card9)")]
        try:
            gl_context.get_context()
            print("CREATED")
        except gl_context.GLUnavailableError as exc:
            print("ERROR:", exc)
        """,
        HYBRID_RT_DEVICE="Second GPU",
    )
    assert "ERROR:" in result.stdout, result.stdout + result.stderr
    assert "requested device index 1" in result.stdout and "Second GPU" in result.stdout


def test_a_bad_device_in_the_environment_fails_the_context_listing_the_devices():
    result = run_isolated(
        """
        from hybrid_engine.gpu import gl_context
        try:
            gl_context.get_context()
        except gl_context.GLUnavailableError as exc:
            print("ERROR:", exc)
        """,
        HYBRID_RT_DEVICE="7",
    )
    assert "ERROR: There is no EGL device 7 (HYBRID_RT_DEVICE=7)" in result.stdout, result.stdout + result.stderr
    assert "0: Mesa software renderer" in result.stdout


def test_a_final_render_reports_the_device_once_per_process():
    result = run_isolated(
        """
        from addon_loader import load_addon
        import bpy
        bpy.ops.wm.read_factory_settings(use_empty=False)
        load_addon().register()
        scene = bpy.context.scene
        scene.render.engine = "HYBRID_RT"
        scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 32, 24, 100
        scene.hybrid_rt.render_samples = 1
        bpy.ops.render.render()
        bpy.ops.render.render()
        """,
        PYTHONPATH=str(REPO_ROOT / "scripts"),
    )
    lines = [line for line in result.stdout.splitlines() if "Hybrid RT: rendering on EGL device" in line]
    assert len(lines) == 1, result.stdout + result.stderr
    assert lines[0].startswith("Info: ") and "a software renderer: slow" in lines[0]
