# SPDX-License-Identifier: GPL-3.0-or-later
"""Read images in tests with OpenImageIO, the library Blender bundles and writes them with.

``bpy.utils.expose_bundled_modules()`` makes Blender's own OpenImageIO importable, so the
tests read EXR (multilayer included) and PNG files as Blender and compositors do, not with a
reader of their own."""
from __future__ import annotations

from pathlib import Path

import numpy as np


def _oiio():
    import bpy

    bpy.utils.expose_bundled_modules()
    import OpenImageIO

    return OpenImageIO


def read_image(path: str | Path) -> np.ndarray:
    """The first image of a file as (H, W, C) float32, row 0 at the top (as stored; colours
    with alpha are kept as stored, not multiplied by it)."""
    oiio = _oiio()
    config = oiio.ImageSpec()
    config.attribute("oiio:UnassociatedAlpha", 1)
    source = oiio.ImageInput.open(str(path), config)
    if source is None:
        raise ValueError(f"OpenImageIO cannot open {path}: {oiio.geterror()}")
    try:
        return np.asarray(source.read_image(format=oiio.FLOAT), np.float32)
    finally:
        source.close()


def read_exr_channels(path: str | Path) -> dict[str, np.ndarray]:
    """Every channel of an EXR file as an (H, W) float32 array, row 0 at the BOTTOM (Blender's
    order). In a multi-part file (Blender's multilayer EXR) a channel is keyed by its part's
    name and its own, joined by a dot unless the channel name already carries the part's."""
    oiio = _oiio()
    source = oiio.ImageInput.open(str(path))
    if source is None:
        raise ValueError(f"OpenImageIO cannot open {path}: {oiio.geterror()}")
    channels: dict[str, np.ndarray] = {}
    try:
        subimage = 0
        while source.seek_subimage(subimage, 0):
            spec = source.spec()
            part = spec.getattribute("name") or ""
            pixels = np.asarray(source.read_image(subimage, 0, 0, spec.nchannels, oiio.FLOAT), np.float32)
            pixels = pixels.reshape(spec.height, spec.width, spec.nchannels)[::-1]
            for index, name in enumerate(spec.channelnames):
                key = name if not part or name.startswith(f"{part}.") else f"{part}.{name}"
                channels[key] = np.ascontiguousarray(pixels[..., index])
            subimage += 1
    finally:
        source.close()
    return channels


def read_png(path: str | Path) -> np.ndarray:
    """An 8-bit PNG's pixels as (H, W, C) uint8, row 0 at the top (as stored)."""
    return np.round(read_image(path) * 255.0).astype(np.uint8)

