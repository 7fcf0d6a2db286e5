# SPDX-License-Identifier: GPL-3.0-or-later
"""Viewport arrays: one draw that rasterizes into several rectangles of a target.

A draw whose vertex stage writes ``gl_ViewportIndex`` (GL_ARB_shader_viewport_layer_array)
sends each primitive through the viewport of that index, so the six faces of a cube map,
each in its own tile of an atlas, can be drawn by one multi-draw whose draw index
(``gl_DrawIDARB``, GL_ARB_shader_draw_parameters) names the face. Each primitive is
transformed, clipped and rasterized exactly as with ``glViewport`` set to its tile, so the
tiles are bit for bit what one draw per face writes.

moderngl 5.13 sets only ``glViewport`` (which sets every viewport of the array to one
rectangle, GL 4.5 §13.6.1); ``glViewportArrayv`` (core since GL 4.1) is fetched here from the
platform's loader. Setting the array last and restoring one viewport with moderngl's own
setter afterwards keeps moderngl's idea of the viewport true. Where the loader, the
function or the extensions are missing, :func:`viewport_array` returns None and callers
draw one face at a time (what the "cpu" variant of the ``faces`` kernel does anyway).
"""
from __future__ import annotations

import ctypes
import sys

import numpy as np

# What the vertex stage needs (both Mesa's llvmpipe and current GPU drivers expose them).
REQUIRED_EXTENSIONS = ("GL_ARB_shader_viewport_layer_array", "GL_ARB_shader_draw_parameters")

_GLVIEWPORTARRAYV = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.c_int, ctypes.POINTER(ctypes.c_float))
_cache: dict[int, "ViewportArray | None"] = {}


def _proc_address(name: bytes) -> int | None:
    """The address of GL function ``name`` from the platform's loader, or None."""
    try:
        if sys.platform.startswith("linux"):
            lib = ctypes.CDLL("libEGL.so.1")
            get = lib.eglGetProcAddress
        elif sys.platform == "win32":
            lib = ctypes.WinDLL("opengl32.dll")  # type: ignore[attr-defined]
            get = lib.wglGetProcAddress
        else:
            return None
    except (OSError, AttributeError):
        return None
    get.restype = ctypes.c_void_p
    get.argtypes = [ctypes.c_char_p]
    address = get(name)
    return int(address) if address else None


class ViewportArray:
    """``glViewportArrayv`` of one context, and how many viewports it has."""

    def __init__(self, function, count: int) -> None:
        self._function = function
        self.count = count

    def set(self, rects: list[tuple[int, int, int, int]]) -> None:
        """Viewports 0 .. len(rects) - 1 to the (x, y, width, height) rectangles."""
        if not 1 <= len(rects) <= self.count:
            raise ValueError(f"between 1 and {self.count} viewports, got {len(rects)}")
        values = np.ascontiguousarray(np.asarray(rects, np.float32).reshape(-1))
        self._function(0, len(rects), values.ctypes.data_as(ctypes.POINTER(ctypes.c_float)))


def viewport_array(ctx) -> ViewportArray | None:
    """The context's viewport array, or None where one draw cannot pick its viewport per
    primitive (module doc). Looked up once per context."""
    key = id(ctx)
    if key not in _cache:
        array = None
        extensions = ctx.extensions
        count = int(ctx.info.get("GL_MAX_VIEWPORTS", 0) or 0)
        if all(name in extensions for name in REQUIRED_EXTENSIONS) and count >= 6:
            address = _proc_address(b"glViewportArrayv")
            if address:
                array = ViewportArray(_GLVIEWPORTARRAYV(address), count)
        _cache[key] = array
    return _cache[key]
