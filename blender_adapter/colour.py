# SPDX-License-Identifier: GPL-3.0-or-later
"""Image colour spaces converted to the scene's working space by OpenColorIO, with the
config Blender ships and uses itself.

Blender hands back a byte image's pixels in the image's own colour space (value / 255) and a
float image's in the working space; every other colour the engine reads (base colours,
lamps, the World) is in the working space already. So byte images are converted from their
``colorspace_settings`` to ``bpy.data.colorspace.working_space`` (Blender 5; the config's
``scene_linear`` role before), by the same OpenColorIO and the same config Blender's own
engines use, so an sRGB, Linear Rec.709 or ACEScg texture renders as in Cycles. Non-Color
(``is_data``) images are read as they are. Processors are made once per pair of spaces;
the images themselves are converted once per content (export/images.py caches them).
"""
from __future__ import annotations

import functools
import os

import bpy
import numpy as np


class ColourSpaceError(ValueError):
    """An image names a colour space Blender's OpenColorIO config does not know."""


@functools.lru_cache(maxsize=1)
def _config():
    bpy.utils.expose_bundled_modules()
    import PyOpenColorIO as OCIO

    path = os.environ.get("OCIO") or os.path.join(
        bpy.utils.resource_path("LOCAL"), "datafiles", "colormanagement", "config.ocio")
    return OCIO, OCIO.Config.CreateFromFile(path)


def working_space() -> str:
    """The colour space the scene's colours live in."""
    settings = getattr(bpy.data, "colorspace", None)
    name = getattr(settings, "working_space", "") if settings is not None else ""
    return name or _config()[1].getRoleColorSpace("scene_linear")


@functools.lru_cache(maxsize=64)
def _processor(source: str, target: str):
    OCIO, config = _config()
    if config.getColorSpace(source) is None:
        raise ColourSpaceError(f"colour space {source!r} is not in Blender's OpenColorIO config")
    return config.getProcessor(source, target).getDefaultCPUProcessor()


def to_working_space(rgb: np.ndarray, space: str, is_data: bool = False) -> np.ndarray:
    """(..., 3) float32 colours of an image in ``space`` converted to the working space (a new
    array; the input itself for data images or when the spaces agree)."""
    target = working_space()
    if is_data or space == target:
        return rgb
    out = np.ascontiguousarray(rgb, np.float32).copy()
    _processor(space, target).applyRGB(out.reshape(-1))
    return out
