# SPDX-License-Identifier: GPL-3.0-or-later
"""The one OpenGL context of the process.

Every renderer (RASTER, the LBVH builder, the hybrid tracer) shares a single standalone
moderngl context. Creating a context is slow and compiled programs belong to their
context, so making one per frame or per renderer would defeat the shader cache and leak
driver objects. Blender re-creates viewport engines on every frame change, hence the
context lives at module level and outlives any engine instance.

OpenGL 4.3 is the floor because the LBVH and the tracer need compute shaders and shader
storage buffers (both core in 4.3).

The context is made on one EGL device (``egl_devices.py``): the add-on's preferences choose
it, and ``HYBRID_RT_DEVICE`` (an index or part of a device's name) overrides them, so that
each process of a multi-GPU farm worker renders on its own GPU. Which device and GL renderer
rendered is logged once, plainly so when the renderer is a software one (slow).
"""
from __future__ import annotations

import ctypes
import logging
import os
import sys
import threading
import types
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Callable, Iterator

from . import egl_devices
from .egl_devices import EGLDevice

REQUIRED_GL_VERSION = 430
DEVICE_ENV = "HYBRID_RT_DEVICE"
AUTOMATIC = "auto"
SOFTWARE_RENDERERS = ("llvmpipe", "softpipe", "swrast", "lavapipe")

log = logging.getLogger(__name__)


class GLUnavailableError(RuntimeError):
    """No usable OpenGL >= 4.3 context could be created; the message says what is missing."""


@dataclass(frozen=True)
class GLLimits:
    """Driver limits that the passes must respect rather than hit."""

    max_ssbo_block_bytes: int
    max_compute_workgroup_count: tuple[int, int, int]
    max_compute_workgroup_size: tuple[int, int, int]
    max_compute_invocations: int
    max_texture_size: int
    max_3d_texture_size: int
    max_array_texture_layers: int
    max_compute_storage_blocks: int = 16  # GL's floor is 8; llvmpipe and NVIDIA give 16


# The package can be imported under two names in one process (Blender's ``bl_ext.*.hybrid_rt``
# add-on and the top-level ``hybrid_engine`` of scripts and tests). The context must still be
# one per process, so its state lives in a process-wide module object, not in this module.
_STATE_KEY = "_hybrid_rt_gl_process_state"
_state = sys.modules.setdefault(_STATE_KEY, types.ModuleType(_STATE_KEY))
if not hasattr(_state, "lock"):
    _state.lock = threading.Lock()
    _state.context = None
    _state.handle = None  # our EGLContext, to tell it from a host's context
    _state.limits = None
    _state.parking_fbo = None
if not hasattr(_state, "device_preference"):
    _state.device_preference = None  # the add-on preferences' Render Device
    _state.device = None  # the EGLDevice the context was made on (None: unknown or not EGL)
    _state.device_reported = False
if not hasattr(_state, "gl_lock"):
    # One thread at a time runs GL (``activated``): the lock is held for a whole block, and
    # ``holder`` is the thread our context is current on between blocks (None: no thread),
    # which must hand it over before another thread can make it current (EGL refuses a
    # context current on another thread).
    _state.gl_lock = threading.RLock()
    _state.handed_over = threading.Condition(_state.gl_lock)
    _state.holder = None
    _state.waiting = 0
    _state.local = threading.local()  # per thread: how deep in nested blocks it is
if not hasattr(_state, "release_hooks"):
    # Callbacks run before the context is released: what caches GL objects of the context
    # (the shader loader's programs) registers here, so that this module imports none of it.
    _state.release_hooks = []


# glcontext's backend for a standalone context on each platform: EGL on Linux (no window
# system needed, headless renders included), WGL on Windows. macOS stops at OpenGL 4.1,
# which has no compute shaders.
PLATFORM_BACKENDS = {"linux": "egl", "win32": "wgl"}
MACOS_MESSAGE = ("Hybrid RT needs OpenGL 4.3 (compute shaders and storage buffers); macOS "
                 "provides OpenGL 4.1 at most, so Hybrid RT cannot run on this Mac")


def platform_backend(platform: str | None = None) -> str:
    """The glcontext backend for ``platform`` (default ``sys.platform``); HYBRID_RT_GL_BACKEND
    overrides it. Raises GLUnavailableError on a platform without OpenGL 4.3."""
    override = os.environ.get("HYBRID_RT_GL_BACKEND")
    if override:
        return override
    platform = sys.platform if platform is None else platform
    if platform == "darwin":
        raise GLUnavailableError(MACOS_MESSAGE)
    for prefix, backend in PLATFORM_BACKENDS.items():
        if platform.startswith(prefix):
            return backend
    raise GLUnavailableError(f"Hybrid RT has no OpenGL backend for the platform {platform!r}; "
                             "set HYBRID_RT_GL_BACKEND to a glcontext backend to try one")


def set_device_preference(choice: str | None) -> None:
    """The Preferences' *Render Device* (an index, part of a name, or None/"auto" for EGL's
    first device). It applies when the context is created: Blender's next start once one
    exists, since every renderer's GL objects belong to the current one."""
    _state.device_preference = choice or None


def device_choice() -> tuple[str | None, str]:
    """The device asked for and who asked: ``HYBRID_RT_DEVICE`` beats the preference, so a
    farm can start one process per GPU whatever the workers' saved preferences say."""
    env = os.environ.get(DEVICE_ENV, "").strip()
    if env:
        return env, f"{DEVICE_ENV}={env}"
    preference = _state.device_preference
    if preference and preference.strip().lower() != AUTOMATIC:
        return preference.strip(), f"the Render Device preference {preference!r}"
    return None, "automatic"


def device_list_text(devices: list[EGLDevice]) -> str:
    """The devices as one line for messages: what a person can put in HYBRID_RT_DEVICE."""
    if not devices:
        return "EGL lists no devices here (no EGL_EXT_device_enumeration)"
    return "the EGL devices are " + "; ".join(device.label for device in devices)


def choose_device(choice: str | None, devices: list[EGLDevice], asked_by: str = "") -> EGLDevice | None:
    """The device ``choice`` names: a number is an index, any other text must match exactly one
    device's name (case-insensitive, e.g. ``renderD129`` or ``RTX``). None is automatic (EGL's
    first device, as glcontext picks it). Raises GLUnavailableError listing the devices."""
    if choice is None or choice.strip().lower() in ("", AUTOMATIC):
        return None
    text = choice.strip()
    who = f" ({asked_by})" if asked_by else ""
    if text.isdigit():
        index = int(text)
        if index < len(devices):
            return devices[index]
        raise GLUnavailableError(f"There is no EGL device {index}{who}; {device_list_text(devices)}")
    matches = [device for device in devices if text.lower() in device.name.lower()]
    if len(matches) == 1:
        return matches[0]
    if not matches:
        raise GLUnavailableError(f"No EGL device is named like {text!r}{who}; "
                                 f"{device_list_text(devices)}")
    raise GLUnavailableError(f"{len(matches)} EGL devices are named like {text!r}{who}: give "
                             f"an index or a longer part of the name; {device_list_text(devices)}")


def _device_kwargs(backend: str) -> dict:
    """glcontext's ``device_index`` for the chosen device; records the device for the log."""
    choice, asked_by = device_choice()
    if backend != "egl":
        _state.device = None
        if choice is not None:
            raise GLUnavailableError(f"Hybrid RT chooses render devices through EGL; the '{backend}' backend "
                                     f"renders on the system's default device ({asked_by})")
        return {}
    devices = egl_devices.enumerate_devices()
    device = choose_device(choice, devices, asked_by)
    if device is None:  # automatic: glcontext's own default, GLCONTEXT_DEVICE_INDEX or 0
        index = os.environ.get("GLCONTEXT_DEVICE_INDEX", "0")
        _state.device = devices[int(index)] if index.isdigit() and int(index) < len(devices) else None
        return {}
    _state.device = device
    return {"device_index": device.index}


def _create_context():
    try:
        import moderngl
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise GLUnavailableError(
            "Hybrid RT needs the Python package 'moderngl' (pip install moderngl); "
            f"importing it failed: {exc}"
        ) from exc

    backend = platform_backend()
    kwargs = {"standalone": True, "require": REQUIRED_GL_VERSION, "backend": backend, **_device_kwargs(backend)}
    on_device = f" on EGL device {_state.device.label}" if "device_index" in kwargs else ""
    try:
        ctx = moderngl.create_context(**kwargs)
    except Exception as exc:
        text = str(exc)
        if "require" in text.lower() or "version" in text.lower():
            raise GLUnavailableError(
                "Hybrid RT needs OpenGL 4.3 (compute shaders and storage buffers); "
                f"the {backend or 'default'} context{on_device} reports: {text}"
            ) from exc
        raise GLUnavailableError(
            f"Could not create a standalone OpenGL context with the '{backend}' backend{on_device}: {text}. "
            + ("On Linux install the Mesa EGL libraries (apt-get install libegl1 libegl-mesa0 "
               "libgl1-mesa-dri libgbm1) or a GPU driver that provides EGL; "
               if sys.platform.startswith("linux") else "Update the graphics driver; ")
            + "set HYBRID_RT_GL_BACKEND to another glcontext backend to override."
        ) from exc
    if ctx.version_code < REQUIRED_GL_VERSION:
        version = ctx.info.get("GL_VERSION", ctx.version_code)
        ctx.release()
        raise GLUnavailableError(
            f"Hybrid RT needs OpenGL 4.3 for compute shaders; the driver offers {version}."
        )
    return ctx


def get_context():
    """Return the process-wide moderngl context, creating it on first use.

    Raises GLUnavailableError with a specific message when EGL, moderngl or GL 4.3 is missing.
    """
    with _state.lock:
        if _state.context is None:
            _state.context = _create_context()
            _state.limits = None
            _state.handle = _native.egl_current()[3] if _native.egl else None
            _state.holder = threading.get_ident()  # creating it made it current here
            _state.device_reported = False
            # Once per context, for a configured log; the console line is the final render's
            # report (device_report_once), so a background render does not print it twice.
            log.info("Hybrid RT: %s", _describe(_state.context)[1])
        return _state.context


def has_context() -> bool:
    """Whether the process's context exists (asking creates nothing)."""
    return _state.context is not None


def limits() -> GLLimits:
    """Driver limits of the shared context (queried once)."""
    ctx = get_context()
    if _state.limits is None:
        info = ctx.info
        _state.limits = GLLimits(
            max_ssbo_block_bytes=int(info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE", 1 << 27)),
            max_compute_workgroup_count=tuple(
                int(info.get("GL_MAX_COMPUTE_WORK_GROUP_COUNT")[i]) for i in range(3)
            ) if isinstance(info.get("GL_MAX_COMPUTE_WORK_GROUP_COUNT"), tuple) else (65535,) * 3,
            max_compute_workgroup_size=tuple(info.get("GL_MAX_COMPUTE_WORK_GROUP_SIZE", (1024, 1024, 64))),
            max_compute_invocations=int(info.get("GL_MAX_COMPUTE_WORK_GROUP_INVOCATIONS", 1024)),
            max_texture_size=int(info.get("GL_MAX_TEXTURE_SIZE", 8192)),
            max_3d_texture_size=int(info.get("GL_MAX_3D_TEXTURE_SIZE", 2048)),
            max_array_texture_layers=int(info.get("GL_MAX_ARRAY_TEXTURE_LAYERS", 2048)),
            max_compute_storage_blocks=int(info.get("GL_MAX_COMPUTE_SHADER_STORAGE_BLOCKS", 16)),
        )
    return _state.limits


def renderer_name() -> str:
    """The GL renderer string, for reports (e.g. 'llvmpipe (LLVM 15.0.6, 256 bits)')."""
    return str(get_context().info.get("GL_RENDERER", "unknown"))


def is_software_renderer() -> bool:
    """True on llvmpipe/softpipe, whose timer queries return meaningless values."""
    name = renderer_name().lower()
    return any(word in name for word in SOFTWARE_RENDERERS)


def current_device() -> EGLDevice | None:
    """The EGL device the context was made on (None off EGL or where EGL lists none)."""
    get_context()
    return _state.device


def _describe(ctx) -> tuple[bool, str]:
    renderer = str(ctx.info.get("GL_RENDERER", "unknown"))
    software = any(word in renderer.lower() for word in SOFTWARE_RENDERERS)
    device = _state.device
    where = (f"EGL device {device.label}" if device is not None
             else f"the {platform_backend()} backend's default device")
    text = f"rendering on {where} with the OpenGL renderer {renderer}"
    if software:
        text += " - a software renderer: slow, no GPU is used"
    return software, text


def device_description() -> str:
    """Which device and GL renderer render, in one sentence for logs and reports; a software
    renderer is named as such, since it is what makes a worker without a GPU driver slow."""
    return _describe(get_context())[1]


def device_report_once() -> str | None:
    """``device_description()`` the first time it is asked for after the context was made,
    None afterwards: a final render reports the device once per process, not every frame."""
    get_context()
    if _state.device_reported:
        return None
    _state.device_reported = True
    return device_description()


def check_error(where: str) -> None:
    """Raise if the GL error flag is set; called after passes in debug and test runs."""
    ctx = get_context()
    err = ctx.error
    if err != "GL_NO_ERROR":
        raise RuntimeError(f"OpenGL error after {where}: {err}")


def debug_checks_enabled() -> bool:
    """GL error checks after each pass cost a sync; tests and HYBRID_RT_DEBUG=1 turn them on."""
    return os.environ.get("HYBRID_RT_DEBUG", "") not in ("", "0")


class _NativeGL:
    """Just enough of EGL and GLX (through ctypes) to save and restore a host's current
    context on Linux. Missing libraries simply disable that half; elsewhere (Windows) both
    halves stay off and glcontext saves and restores the host's context itself."""

    def __init__(self, linux: bool = True) -> None:
        self.egl = self.glx = None
        if not linux:
            return
        self.egl = self._load("libEGL.so.1", ("eglGetCurrentDisplay", "eglGetCurrentSurface",
                                              "eglGetCurrentContext", "eglMakeCurrent"))
        self.glx = self._load("libGL.so.1", ("glXGetCurrentDisplay", "glXGetCurrentDrawable",
                                             "glXGetCurrentReadDrawable", "glXGetCurrentContext",
                                             "glXMakeContextCurrent"))
        if self.egl:
            for name in ("eglGetCurrentDisplay", "eglGetCurrentSurface", "eglGetCurrentContext"):
                getattr(self.egl, name).restype = ctypes.c_void_p
            self.egl.eglGetCurrentSurface.argtypes = [ctypes.c_int]
            self.egl.eglMakeCurrent.argtypes = [ctypes.c_void_p] * 4
        if self.glx:
            for name in ("glXGetCurrentDisplay", "glXGetCurrentContext"):
                getattr(self.glx, name).restype = ctypes.c_void_p
            for name in ("glXGetCurrentDrawable", "glXGetCurrentReadDrawable"):
                getattr(self.glx, name).restype = ctypes.c_ulong
            self.glx.glXMakeContextCurrent.argtypes = [ctypes.c_void_p, ctypes.c_ulong, ctypes.c_ulong, ctypes.c_void_p]

    @staticmethod
    def _load(name: str, symbols: tuple[str, ...]):
        try:
            lib = ctypes.CDLL(name)
            for symbol in symbols:
                getattr(lib, symbol)
            return lib
        except (OSError, AttributeError):
            return None

    def egl_current(self) -> tuple:
        e = self.egl
        EGL_DRAW, EGL_READ = 0x3059, 0x305A
        return (e.eglGetCurrentDisplay(), e.eglGetCurrentSurface(EGL_DRAW),
                e.eglGetCurrentSurface(EGL_READ), e.eglGetCurrentContext())

    def glx_current(self) -> tuple:
        g = self.glx
        return (g.glXGetCurrentDisplay(), g.glXGetCurrentDrawable(),
                g.glXGetCurrentReadDrawable(), g.glXGetCurrentContext())


_native = _NativeGL(linux=sys.platform.startswith("linux"))


# How long a thread waits for another to hand the context over before its block fails: a
# thread that keeps the context current between blocks (a background session's main thread)
# hands it over at its next block, or at ``hand_back()``.
HANDOVER_TIMEOUT_S = 120.0


@contextmanager
def activated(release_after: bool = False) -> Iterator[object]:
    """Make the shared context current for a block of GL work inside a host application.

    One thread at a time: a process-wide lock is held for the whole block, so a preview on
    Blender's job thread, an F12 render on its render thread and the viewport on the main
    thread never run GL at the same time. The context is taken over by the thread that
    enters (``eglMakeCurrent`` on that thread) and handed back on exit, and a block that hands
    it back leaves the GL state it found (``_GLState``: bound framebuffers, program, viewport,
    capabilities), so no thread inherits another's bindings.

    Inside Blender's viewport callbacks Blender's own context is current; our context is made
    current for the block and Blender's (EGL or GLX) is restored afterwards, so Blender's own
    drawing is untouched. Where nothing else was current our context stays current on the
    main thread, unless ``release_after`` (interactive Blender, where every thread may render)
    or another thread is waiting for it; a thread other than the main one always hands it back
    (it may end, or idle in a pool, holding it). Nested blocks on one thread share the outer one.
    """
    with _state.gl_lock:
        local = _state.local
        depth = getattr(local, "depth", 0)
        local.depth = depth + 1
        try:
            if depth:
                yield get_context()
                return
            if not (_native.egl or _native.glx) and not sys.platform.startswith("linux"):
                # Windows: glcontext's WGL context saves the host's current context when it is
                # made current and restores it on exit.
                ctx = get_context()
                with ctx:
                    yield ctx
                return
            with _outer_block(release_after) as ctx:
                yield ctx
        finally:
            local.depth = depth


@contextmanager
def _outer_block(release_after: bool) -> Iterator[object]:
    """The outermost block of a thread, on Linux (the lock is held)."""
    # Record the host's context first: creating ours on first use makes ours current.
    saved_egl = _native.egl_current() if _native.egl else None
    saved_glx = _native.glx_current() if _native.glx else None
    ctx = get_context()
    me = threading.get_ident()
    _wait_for_handover(me)
    foreign_egl = saved_egl is not None and saved_egl[3] not in (None, _state.handle)
    foreign_glx = saved_glx is not None and saved_glx[3] is not None
    already_ours = saved_egl is not None and saved_egl[3] == _state.handle
    if not (foreign_egl or foreign_glx or already_ours) and saved_egl is None:
        yield ctx  # no EGL library to ask: trust that ours is current
        return
    if not already_ours:
        ctx.__enter__()  # glcontext makes ours current
    _state.holder = me
    state = _GLState.save(ctx)
    try:
        yield ctx
    finally:
        keep = (not (foreign_egl or foreign_glx or release_after or _state.waiting)
                and threading.current_thread() is threading.main_thread())
        if state is not None and not keep:  # a thread that keeps the context keeps its state
            state.restore(ctx)
        if foreign_egl:
            _native.egl.eglMakeCurrent(*saved_egl)
        elif foreign_glx:
            _native.glx.glXMakeContextCurrent(*saved_glx)
        elif not keep and _native.egl:
            _release_current()
        if not keep:
            _state.holder = None
            _state.handed_over.notify_all()


def _release_current() -> None:
    """Make no context current on this thread (ours becomes free for another thread)."""
    display = _native.egl_current()[0]
    _native.egl.eglMakeCurrent(display, None, None, None)


def _wait_for_handover(me: int) -> None:
    """Wait (the lock released meanwhile) until no other thread holds the context current."""
    if _state.holder in (None, me):
        return
    _state.waiting += 1
    try:
        if not _state.handed_over.wait_for(lambda: _state.holder in (None, me), HANDOVER_TIMEOUT_S):
            raise GLUnavailableError(
                f"Hybrid RT's OpenGL context is held by another thread, which did not hand it "
                f"over within {HANDOVER_TIMEOUT_S:.0f} s (a script's main thread hands it over "
                "at its next render or at hybrid_engine.gpu.gl_context.hand_back())")
    finally:
        _state.waiting -= 1


def hand_back() -> bool:
    """Hand the context over if this thread holds it current between blocks (a background
    session's main thread keeps it so): a thread waiting to render (a preview job) can take
    it. The next block on this thread takes it back. True if it was held here."""
    with _state.gl_lock:
        if _state.holder != threading.get_ident() or getattr(_state.local, "depth", 0):
            return False
        if _native.egl:
            _release_current()
        _state.holder = None
        _state.handed_over.notify_all()
        return True


class _GLFunctions:
    """The few GL entry points ``_GLState`` needs, through ``eglGetProcAddress`` (moderngl
    exposes no getters for bindings and capabilities)."""

    def __init__(self, egl) -> None:
        get = egl.eglGetProcAddress
        get.restype, get.argtypes = ctypes.c_void_p, [ctypes.c_char_p]
        uint, ubyte, integer = ctypes.c_uint, ctypes.c_ubyte, ctypes.c_int

        def function(name: str, restype, *argtypes):
            address = get(name.encode())
            if not address:
                raise OSError(f"no {name}")
            return ctypes.CFUNCTYPE(restype, *argtypes)(address)

        self.get_integerv = function("glGetIntegerv", None, uint, ctypes.POINTER(integer))
        self.is_enabled = function("glIsEnabled", ubyte, uint)
        self.enable = function("glEnable", None, uint)
        self.disable = function("glDisable", None, uint)
        self.bind_framebuffer = function("glBindFramebuffer", None, uint, uint)
        self.is_framebuffer = function("glIsFramebuffer", ubyte, uint)
        self.use_program = function("glUseProgram", None, uint)
        self.is_program = function("glIsProgram", ubyte, uint)
        self.viewport = function("glViewport", None, integer, integer, integer, integer)

    def integers(self, name: int, count: int = 1) -> list[int]:
        values = (ctypes.c_int * count)()
        self.get_integerv(name, values)
        return list(values)


class _GLState:
    """The context's state a block may change and another thread's work may rely on: draw and
    read framebuffers (and moderngl's record of the bound one), program, viewport and the
    capabilities the passes switch. Saved when a block starts, restored when it ends; a
    framebuffer or program the block deleted is not bound again (the parking framebuffer
    and no program stand in)."""

    DRAW_FRAMEBUFFER, READ_FRAMEBUFFER = 0x8CA9, 0x8CA8
    DRAW_FRAMEBUFFER_BINDING, READ_FRAMEBUFFER_BINDING = 0x8CA6, 0x8CAA
    CURRENT_PROGRAM, VIEWPORT = 0x8B8D, 0x0BA2
    # DEPTH_TEST, CULL_FACE, BLEND, SCISSOR_TEST, RASTERIZER_DISCARD, PROGRAM_POINT_SIZE
    CAPABILITIES = (0x0B71, 0x0B44, 0x0BE2, 0x0C11, 0x8C89, 0x8642)

    def __init__(self, gl: _GLFunctions, fbo, mglo_fbo) -> None:
        self.gl = gl
        self.fbo, self.mglo_fbo = fbo, mglo_fbo
        self.draw = gl.integers(self.DRAW_FRAMEBUFFER_BINDING)[0]
        self.read = gl.integers(self.READ_FRAMEBUFFER_BINDING)[0]
        self.program = gl.integers(self.CURRENT_PROGRAM)[0]
        self.viewport = gl.integers(self.VIEWPORT, 4)
        self.enabled = {cap: bool(gl.is_enabled(cap)) for cap in self.CAPABILITIES}

    @classmethod
    def save(cls, ctx) -> "_GLState | None":
        gl = _gl_functions()
        if gl is None:
            return None
        return cls(gl, getattr(ctx, "fbo", None), getattr(ctx.mglo, "fbo", None))

    def restore(self, ctx) -> None:
        gl = self.gl
        for target, name in ((self.DRAW_FRAMEBUFFER, self.draw), (self.READ_FRAMEBUFFER, self.read)):
            if name == 0 or gl.is_framebuffer(name):
                gl.bind_framebuffer(target, name)
            else:
                park_framebuffer()
        gl.use_program(self.program if self.program == 0 or gl.is_program(self.program) else 0)
        gl.viewport(*self.viewport)
        for cap, on in self.enabled.items():
            (gl.enable if on else gl.disable)(cap)
        if self.fbo is not None and not _released(self.fbo):
            ctx.fbo = self.fbo
            ctx.mglo.fbo = self.mglo_fbo


def _released(gl_object) -> bool:
    return type(getattr(gl_object, "mglo", None)).__name__ == "InvalidObject"


def _gl_functions() -> _GLFunctions | None:
    """The GL entry points (looked up once per process; None without EGL)."""
    if not hasattr(_state, "gl_functions"):
        try:
            _state.gl_functions = _GLFunctions(_native.egl) if _native.egl else None
        except (OSError, AttributeError):
            _state.gl_functions = None
    return _state.gl_functions


def park_framebuffer() -> None:
    """Bind a private 1x1 framebuffer.

    Mesa raises GL_INVALID_OPERATION on later calls when the bound framebuffer is deleted,
    so code that releases a framebuffer parks the binding here first.
    """
    ctx = get_context()
    if _state.parking_fbo is None:
        _state.parking_fbo = ctx.simple_framebuffer((1, 1))
    _state.parking_fbo.use()


def on_release(hook: Callable[[], None]) -> None:
    """Run ``hook`` before the shared context is released (once per hook, however often a
    module registers it: the package may be imported under two names)."""
    if hook not in _state.release_hooks:
        _state.release_hooks.append(hook)


def release_context() -> None:
    """Release the shared context (explicit teardown, never left to a GC on another thread)."""
    with _state.lock:
        if _state.context is not None:
            for hook in list(_state.release_hooks):
                hook()
            if _state.parking_fbo is not None:
                _state.parking_fbo.release()
                _state.parking_fbo = None
            _state.context.release()
            _state.context = None
            _state.handle = None
            _state.limits = None
            _state.device = None
            _state.holder = None
