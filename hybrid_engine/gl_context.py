# SPDX-License-Identifier: GPL-3.0-or-later
"""The one OpenGL context of the process.

Every renderer (RASTER, the LBVH builder, the hybrid tracer) shares a single standalone
moderngl context. Creating a context costs tens of milliseconds and compiled programs
belong to their context, so making one per frame or per renderer would defeat the shader
cache and leak driver objects. Blender re-creates viewport engines on every frame change,
hence the context lives at module level and outlives any engine instance.

OpenGL 4.3 is the floor because the LBVH and the tracer need compute shaders and shader
storage buffers (both core in 4.3).
"""
from __future__ import annotations

import os
import threading
from dataclasses import dataclass

REQUIRED_GL_VERSION = 430


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


_lock = threading.Lock()
_context = None
_limits: GLLimits | None = None


def _create_context():
    try:
        import moderngl
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise GLUnavailableError(
            "Hybrid RT needs the Python package 'moderngl' (pip install moderngl); "
            f"importing it failed: {exc}"
        ) from exc

    backend = os.environ.get("HYBRID_RT_GL_BACKEND", "egl")
    kwargs = {"standalone": True, "require": REQUIRED_GL_VERSION}
    if backend:
        kwargs["backend"] = backend
    try:
        ctx = moderngl.create_context(**kwargs)
    except Exception as exc:
        text = str(exc)
        if "require" in text.lower() or "version" in text.lower():
            raise GLUnavailableError(
                "Hybrid RT needs OpenGL 4.3 (compute shaders and storage buffers); "
                f"the {backend or 'default'} context reports: {text}"
            ) from exc
        raise GLUnavailableError(
            f"Could not create a standalone OpenGL context with the '{backend}' backend: {text}. "
            "On Linux install the Mesa EGL libraries (apt-get install libegl1 libegl-mesa0 "
            "libgl1-mesa-dri libgbm1) or a GPU driver that provides EGL; set "
            "HYBRID_RT_GL_BACKEND to another glcontext backend to override."
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
    global _context, _limits
    with _lock:
        if _context is None:
            _context = _create_context()
            _limits = None
        return _context


def limits() -> GLLimits:
    """Driver limits of the shared context (queried once)."""
    global _limits
    ctx = get_context()
    if _limits is None:
        info = ctx.info
        _limits = GLLimits(
            max_ssbo_block_bytes=int(info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE", 1 << 27)),
            max_compute_workgroup_count=tuple(
                int(info.get(f"GL_MAX_COMPUTE_WORK_GROUP_COUNT")[i]) for i in range(3)
            ) if isinstance(info.get("GL_MAX_COMPUTE_WORK_GROUP_COUNT"), tuple) else (65535,) * 3,
            max_compute_workgroup_size=tuple(info.get("GL_MAX_COMPUTE_WORK_GROUP_SIZE", (1024, 1024, 64))),
            max_compute_invocations=int(info.get("GL_MAX_COMPUTE_WORK_GROUP_INVOCATIONS", 1024)),
            max_texture_size=int(info.get("GL_MAX_TEXTURE_SIZE", 8192)),
            max_3d_texture_size=int(info.get("GL_MAX_3D_TEXTURE_SIZE", 2048)),
            max_array_texture_layers=int(info.get("GL_MAX_ARRAY_TEXTURE_LAYERS", 2048)),
        )
    return _limits


def renderer_name() -> str:
    """The GL renderer string, for reports (e.g. 'llvmpipe (LLVM 15.0.6, 256 bits)')."""
    return str(get_context().info.get("GL_RENDERER", "unknown"))


def is_software_renderer() -> bool:
    """True on llvmpipe/softpipe, whose timer queries return meaningless values."""
    name = renderer_name().lower()
    return any(word in name for word in ("llvmpipe", "softpipe", "swrast", "lavapipe"))


def check_error(where: str) -> None:
    """Raise if the GL error flag is set; called after passes in debug and test runs."""
    ctx = get_context()
    err = ctx.error
    if err != "GL_NO_ERROR":
        raise RuntimeError(f"OpenGL error after {where}: {err}")


def debug_checks_enabled() -> bool:
    """GL error checks after each pass cost a sync; tests and HYBRID_RT_DEBUG=1 turn them on."""
    return os.environ.get("HYBRID_RT_DEBUG", "") not in ("", "0")


_parking_fbo = None


def park_framebuffer() -> None:
    """Bind a private 1x1 framebuffer.

    Mesa raises GL_INVALID_OPERATION on later calls when the bound framebuffer is deleted,
    so code that releases a framebuffer parks the binding here first.
    """
    global _parking_fbo
    ctx = get_context()
    if _parking_fbo is None:
        _parking_fbo = ctx.simple_framebuffer((1, 1))
    _parking_fbo.use()


def release_context() -> None:
    """Release the shared context (explicit teardown, never left to a GC on another thread)."""
    global _context, _limits, _parking_fbo
    from . import shader_loader

    with _lock:
        if _context is not None:
            shader_loader.clear_cache()
            if _parking_fbo is not None:
                _parking_fbo.release()
                _parking_fbo = None
            _context.release()
            _context = None
            _limits = None
