# SPDX-License-Identifier: GPL-3.0-or-later
"""Hybrid RT renderer core: numpy + moderngl, no Blender.

Implements Ganestam & Doggett, "Real-Time Multiply Recursive Reflections and Refractions
using Hybrid Rendering" (2014): rasterized primary visibility and G-buffer cube map, a
per-frame GPU LBVH of the geometry near the camera, and recursive tracing through both.

Importing this package is cheap and never touches OpenGL or bpy; the GL context is created
on first use. Public names are loaded lazily so that ``import hybrid_engine`` works on a
machine without moderngl for the pure-numpy parts.
"""
from __future__ import annotations

import importlib

from .scene.camera import Camera, CameraError, look_at
from .scene.geometry import Geometry
from .scene.data import Lights, MaterialTable, SceneData, Sky
from .scene.arrays import SceneDataError
from .scene.settings import MODES, RenderSettings, SettingsError

__version__ = "0.1.0"

# name -> submodule that defines it (imported on first access)
_LAZY = {
    "trace_closest": "passes.lbvh.lbvh",
    "Renderer": "frame.renderer",
    "FrameResult": "frame.renderer",
    "get_context": "gpu.gl_context",
    "GLUnavailableError": "gpu.gl_context",
    "ShaderError": "gpu.shader_loader",
}

__all__ = [
    "Camera", "CameraError", "look_at", "Geometry", "Lights", "MaterialTable", "SceneData",
    "SceneDataError", "Sky", "MODES", "RenderSettings", "SettingsError",
]  # lazy names stay out of __all__ so that a star import never starts OpenGL


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'hybrid_engine' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value
