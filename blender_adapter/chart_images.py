# SPDX-License-Identifier: GPL-3.0-or-later
"""Charts and pictures written as PNG with Blender's own image library and font engine.

The renderer core draws a chart without its text and hands over the text as labels
(``hybrid_engine.reports.chart_raster.ChartPicture``): it has neither an image library nor a
font engine. Inside Blender both exist: OpenImageIO (bundled with Blender, importable after
``bpy.utils.expose_bundled_modules()``) reads and writes the pixels, and blf, Blender's font
engine, draws the labels in Blender's interface font.

blf draws only into an ImBuf, and Python can neither hand pixels to an ImBuf nor read them
back from one, so the pixels make a round trip through a PNG in a temporary folder:
OpenImageIO writes it, ``imbuf.load`` reads it, blf draws, ``imbuf.write`` saves it, and
OpenImageIO reads the result back as an array. The file that stays is written by
OpenImageIO, whose PNG compression level can be chosen (ImBuf's cannot).
"""
from __future__ import annotations

import functools
import os
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Iterable

import blf
import bpy
import imbuf
import numpy as np

if TYPE_CHECKING:
    from ..hybrid_engine.reports.chart_raster import ChartPicture, Label

FONT = 0  # Blender's interface font: always loaded, also in background mode
DEFAULT_COMPRESSION = 6  # zlib level of the PNGs written, 0 (none) to 9 (smallest)
# The round trip's temporary PNG is read back at once: writing it fast matters, not its size.
SCRATCH_COMPRESSION = 1
_ANCHOR_SHIFT = {"left": 0.0, "center": 0.5, "right": 1.0}  # share of the width left of x


class ImageFileError(OSError):
    """OpenImageIO could not read or write an image file (its message says why)."""


@functools.lru_cache(maxsize=1)
def _oiio():
    bpy.utils.expose_bundled_modules()
    import OpenImageIO

    return OpenImageIO


def write_png(path: str | os.PathLike, pixels: np.ndarray, compression: int = DEFAULT_COMPRESSION) -> None:
    """Write (H, W, 3) uint8 RGB ``pixels``, row 0 at the top, as an 8-bit PNG."""
    array = np.ascontiguousarray(pixels)
    if array.dtype != np.uint8 or array.ndim != 3 or array.shape[2] != 3:
        raise ValueError(f"PNG pixels must be (H, W, 3) uint8, got {array.shape} {array.dtype}")
    oiio = _oiio()
    height, width, channels = array.shape
    spec = oiio.ImageSpec(width, height, channels, oiio.UINT8)
    spec.attribute("png:compressionLevel", int(compression))
    output = oiio.ImageOutput.create(os.fspath(path))
    if output is None:
        raise ImageFileError(f"cannot write {os.fspath(path)!r}: {oiio.geterror()}")
    try:
        if not (output.open(os.fspath(path), spec) and output.write_image(array)):
            raise ImageFileError(f"cannot write {os.fspath(path)!r}: {output.geterror()}")
    finally:
        output.close()


def read_png(path: str | os.PathLike) -> np.ndarray:
    """An 8-bit image file's pixels as (H, W, C) uint8, row 0 at the top (as stored)."""
    oiio = _oiio()
    source = oiio.ImageInput.open(os.fspath(path))
    if source is None:
        raise ImageFileError(f"cannot read {os.fspath(path)!r}: {oiio.geterror()}")
    try:
        spec = source.spec()
        pixels = source.read_image(format=oiio.UINT8)
    finally:
        source.close()
    return np.asarray(pixels, np.uint8).reshape(spec.height, spec.width, spec.nchannels)


def text_width(text: str, size: int) -> float:
    """The width in pixels of ``text`` drawn at ``size`` (pixels per em) by ``draw_labels``."""
    blf.size(FONT, size)
    return blf.dimensions(FONT, text)[0]


def _draw(label: "Label", image_height: int) -> None:
    """Draw one label into the bound ImBuf. blf's origin is the bottom-left corner and its
    position the start of the text's baseline; the label's anchor is the middle of its
    capitals in rows counted from the top."""
    blf.size(FONT, label.size)
    blf.color(FONT, *(channel / 255.0 for channel in label.color), 1.0)
    width = blf.dimensions(FONT, label.text)[0]
    capitals = blf.dimensions(FONT, "H")[1]
    left = label.x - _ANCHOR_SHIFT[label.align] * width
    baseline = label.y + capitals / 2.0  # rows from the top
    blf.position(FONT, round(left), round(image_height - baseline), 0)
    blf.draw_buffer(FONT, label.text)


def draw_labels(pixels: np.ndarray, labels: Iterable["Label"]) -> np.ndarray:
    """A copy of (H, W, 3) uint8 ``pixels`` (row 0 at the top) with ``labels`` drawn by blf."""
    labels = list(labels)
    if not labels:
        return np.array(pixels, np.uint8, copy=True)
    with tempfile.TemporaryDirectory(prefix="hybrid_rt_labels_") as folder:
        path = str(Path(folder) / "labels.png")
        write_png(path, pixels, SCRATCH_COMPRESSION)
        buffer = imbuf.load(path)
        try:
            with blf.bind_imbuf(FONT, buffer):
                for label in labels:
                    _draw(label, pixels.shape[0])
            imbuf.write(buffer, filepath=path)
        finally:
            buffer.free()
        return read_png(path)


def write_chart(path: str | os.PathLike, picture: "ChartPicture") -> None:
    """The timing report's chart writer (``timing_report.ChartWriter``): the chart's pixels
    with its labels, as a PNG at ``path``."""
    write_png(path, draw_labels(picture.pixels, picture.labels))
