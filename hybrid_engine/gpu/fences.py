# SPDX-License-Identifier: GPL-3.0-or-later
"""GL fence syncs, which moderngl does not wrap: "has the GPU got this far?" without waiting.

An asynchronous read-back copies an image into a pixel buffer on the GPU's timeline and maps
it a redraw later; a fence placed after the copy says whether the copy is done, so a redraw
never blocks on it (frame/readback.py). The entry points come from the platform's loader
(``eglGetProcAddress`` under EGL, ``wglGetProcAddress`` under WGL) for the context current on
this thread. Where none can be loaded, ``Fence.signalled`` answers True: the map then waits
for the copy, which is correct, only not asynchronous.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import functools
import sys

GL_SYNC_GPU_COMMANDS_COMPLETE = 0x9117
GL_ALREADY_SIGNALED = 0x911A
GL_CONDITION_SATISFIED = 0x911C
GL_SYNC_FLUSH_COMMANDS_BIT = 0x00000001


@functools.lru_cache(maxsize=1)
def _entry_points():
    """(glFenceSync, glClientWaitSync, glDeleteSync), or None where they cannot be loaded."""
    try:
        if sys.platform.startswith("win"):
            gl = ctypes.WinDLL("opengl32")  # type: ignore[attr-defined]
            loader = gl.wglGetProcAddress
            factory = ctypes.WINFUNCTYPE  # type: ignore[attr-defined]
        else:
            egl = ctypes.CDLL(ctypes.util.find_library("EGL") or "libEGL.so.1")
            loader = egl.eglGetProcAddress
            factory = ctypes.CFUNCTYPE
        loader.restype = ctypes.c_void_p
        loader.argtypes = [ctypes.c_char_p]
        addresses = [loader(name) for name in (b"glFenceSync", b"glClientWaitSync", b"glDeleteSync")]
    except (OSError, AttributeError):
        return None
    if not all(addresses):
        return None
    fence = factory(ctypes.c_void_p, ctypes.c_uint, ctypes.c_uint)(addresses[0])
    wait = factory(ctypes.c_uint, ctypes.c_void_p, ctypes.c_uint, ctypes.c_uint64)(addresses[1])
    delete = factory(None, ctypes.c_void_p)(addresses[2])
    return fence, wait, delete


def available() -> bool:
    """Whether fences can be placed on this platform."""
    return _entry_points() is not None


class Fence:
    """A fence after the GL commands issued so far on the current context."""

    def __init__(self) -> None:
        points = _entry_points()
        self._sync = points[0](GL_SYNC_GPU_COMMANDS_COMPLETE, 0) if points else None

    def signalled(self) -> bool:
        """Whether the GPU has passed the fence (flushing the commands before it, so that
        it gets there without another GL call)."""
        if self._sync is None:
            return True
        status = _entry_points()[1](self._sync, GL_SYNC_FLUSH_COMMANDS_BIT, 0)
        return status in (GL_ALREADY_SIGNALED, GL_CONDITION_SATISFIED)

    def release(self) -> None:
        if self._sync is not None:
            _entry_points()[2](self._sync)
            self._sync = None
