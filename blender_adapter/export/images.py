# SPDX-License-Identifier: GPL-3.0-or-later
"""Image pixels for textures and the environment, read once per image content.

Reading ``Image.pixels`` is slow, in proportion to the image's size: pixels are kept by what
identifies their content, so playback frames and viewport redraws do not read them again.
Byte images are converted to the scene's working space by OpenColorIO (colour.py).
"""
from __future__ import annotations

from collections import OrderedDict

import numpy as np

from .. import colour
from . import tell

# Pixels of images read so far, keyed by what identifies their content (``_image_key``): a
# playback frame or a viewport redraw reuses them instead of reading ``Image.pixels`` again
# (slow, in proportion to the image's size). Least recently used images are dropped beyond
# this.
IMAGE_CACHE_BYTES = 1 << 30
_image_cache: OrderedDict[tuple, np.ndarray] = OrderedDict()
# The environment's RGB pixels, kept as one array per image content (``environment_pixels``).
_environment_cache: dict[tuple, np.ndarray] = {}

# Byte images in this space, and ``is_data`` (Non-Color) ones, are read as they are: Blender
# 5's name for "whatever the scene works in".
_WORKING_SPACE_ALIAS = "Working Space"


def forget_image_pixels() -> None:
    """Drop the cached image pixels (for callers that know an image was painted: in-memory
    edits of an already modified image do not change its cache key)."""
    _image_cache.clear()
    _environment_cache.clear()


def _image_key(image) -> tuple:
    """What identifies an image's pixels: the datablock, its source, size, colour space and
    modified state; a generated image also by its generator settings."""
    key = (image.session_uid, image.name_full, image.source, image.filepath_raw, tuple(image.size),
           int(image.channels), bool(image.is_float), image.colorspace_settings.name,
           bool(image.colorspace_settings.is_data), bool(image.is_dirty), image.packed_file is not None)
    if image.source == "GENERATED":
        key += (image.generated_type, tuple(image.generated_color), int(image.generated_width),
                int(image.generated_height), bool(image.use_generated_float))
    return key


def _byte_image_to_working_space(image, rgb: np.ndarray) -> np.ndarray:
    """A byte image's colours (in its own colour space, as Blender hands them back) in the
    scene's working space (colour.py); an unknown space is read as it is, and said so."""
    settings = image.colorspace_settings
    if settings.is_data or settings.name == _WORKING_SPACE_ALIAS:
        return rgb
    try:
        return colour.to_working_space(rgb, settings.name)
    except colour.ColourSpaceError as exc:
        tell("image %r: %s; its values are used as they are", image.name_full, exc)
        return rgb


def _missing_pixels() -> np.ndarray:
    """One opaque magenta texel: what Blender's engines render for an image they cannot read,
    so that a missing texture is seen in the picture, not only in the console."""
    pixels = np.array([[[1.0, 0.0, 1.0, 1.0]]], np.float32)
    pixels.flags.writeable = False
    return pixels


MISSING_PIXELS = _missing_pixels()


def image_pixels(image) -> np.ndarray:
    """An image as (H, W, 4) float32 linear RGBA, row 0 at the bottom (read-only, shared by
    every caller); ``MISSING_PIXELS`` (magenta, as Blender renders it) when it has no pixels
    (missing file, empty image) or is of a kind the engine does not read, with a message
    naming it. Read once per image content (``_image_key``) with one ``foreach_get``."""
    if image.source not in ("FILE", "GENERATED"):
        tell("image %r: %s images are not supported; it "
                   "renders magenta", image.name_full, image.source)
        return MISSING_PIXELS
    key = _image_key(image)
    cached = _image_cache.get(key)
    if cached is not None:
        _image_cache.move_to_end(key)
        return cached
    width, height = (int(v) for v in image.size)
    channels = int(image.channels)
    if width < 1 or height < 1 or channels < 1:
        tell("image %r has no pixels (missing file %r?); it "
                   "renders magenta, as in Blender", image.name_full, image.filepath)
        return MISSING_PIXELS
    flat = np.empty(width * height * channels, np.float32)
    image.pixels.foreach_get(flat)
    pixels = flat.reshape(height, width, channels)
    out = np.ones((height, width, 4), np.float32)
    out[..., :3] = pixels[..., :3] if channels >= 3 else pixels[..., :1]
    if channels in (2, 4):
        out[..., 3] = pixels[..., -1]
    if not image.is_float:
        out[..., :3] = _byte_image_to_working_space(image, out[..., :3])
    out.flags.writeable = False  # shared by the cache and every scene that uses it
    _image_cache[key] = out
    total = sum(a.nbytes for a in _image_cache.values())
    while total > IMAGE_CACHE_BYTES and len(_image_cache) > 1:
        _, dropped = _image_cache.popitem(last=False)
        total -= dropped.nbytes
    return out


def environment_pixels(image) -> np.ndarray:
    """(H, W, 3) linear float32 pixels of an environment image (row 0 = bottom); magenta
    when it cannot be read, as Blender renders it.
    Read by ``image_pixels`` (one read per image content, the textures' colour-space rule)
    and kept as the same array while the image stays the same, so that the GPU side (sky
    irradiance, mipmapped environment: sky_light.py) is not rebuilt by a render that only
    read the World again."""
    key = _image_key(image)
    cached = _environment_cache.get(key)
    if cached is not None:
        return cached
    pixels = image_pixels(image)
    rgb = np.ascontiguousarray(pixels[..., :3])
    rgb.flags.writeable = False
    _environment_cache.clear()  # one World at a time is rendered
    _environment_cache[key] = rgb
    return rgb
