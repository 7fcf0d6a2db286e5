# SPDX-License-Identifier: GPL-3.0-or-later
"""Image textures on the GPU: all of a scene's images in one 2D texture array.

Materials refer to their base-colour and emission images by index
(``MaterialTable.base_color_texture`` / ``emission_texture``, see scene/data.py); every pass
that shades a surface -- the primary G-buffer (paper §3.1), the six cube-map faces, which
reuse the same G-buffer pass (§3.2), and the tracer's BVH hits (§3.4) -- samples them through
``gpu_shaders/include/textures.glsl`` from ONE ``sampler2DArray``, bound once per pass, with
the material's texture index as the layer.

Why an array rather than an atlas: the array gives, per layer and in hardware, repeat
wrapping of UVs outside [0, 1], a full mipmap chain that never bleeds into a neighbouring
image, and trilinear plus anisotropic filtering; an atlas needs all three done by hand
(wrapped UVs folded into the image's rectangle, the mip level picked and clamped so that
filtering stays inside it, gutters), and still bleeds at coarse levels. The cost of the
array is that its layers share one size: every image is resampled to the largest width and
the largest height among the scene's images (UVs are normalised, so a stretched layer still
maps [0, 1] onto the whole image). Smaller images are upsampled with the bilinear filter the
GPU would apply anyway, so they look nearly as before, but take the memory of the largest
one.
Two documented fallbacks keep the array inside the driver's limits: the layer size is
clamped to ``GL_MAX_TEXTURE_SIZE``, and when layers x size (with mipmaps) exceed
``TEXTURE_ARRAY_BUDGET_BYTES`` all layers are halved together (a warning is logged).
More images than ``GL_MAX_ARRAY_TEXTURE_LAYERS`` is a ``TextureLimitError``.

Texels are stored as RGBA16F (8 bytes): linear colour needs more than 8 bits in the darks,
and emission images may exceed 1. Non-finite texels become 0 and negative ones 0, larger
than the half-float range is clamped to 65504 (documented fallback, applied once when the
array is packed, not every frame).

The upload happens only when the list of images changes (other array objects with other
contents); a frame with the same images uploads nothing.

Level of detail: the G-buffer fragment shader has screen-space UV derivatives, so it samples
with them (trilinear, plus anisotropic filtering on hardware GL; llvmpipe's anisotropic
filter averages far beyond the footprint, so it is left off on software renderers).
Compute shaders have none; the tracer picks the level from a ray cone
(``pixel_footprint``): the footprint of a pixel at the hit is its width at the camera plus
its angular spread times the distance from the camera to the ray's origin plus the hit
distance (a lower bound of the path length, exact for the first bounce off a flat mirror;
curved mirrors widen the cone and are sampled too sharp), measured in texels of the hit
triangle (``uv_per_world``, the scale in the triangle's UV row that
``gpu_shaders/scene_upload/instance_transform.comp.glsl`` writes). The footprint is not
stretched by the grazing angle, so grazing hits are sampled sharper rather than blurrier
than the G-buffer samples them.
"""
from __future__ import annotations

import logging
import math
from collections.abc import Sequence

import numpy as np

from ...gpu import gl_context
from ...scene import matrix4

log = logging.getLogger(__name__)

# At most this much GPU memory (all layers with their mipmaps) for the texture array.
TEXTURE_ARRAY_BUDGET_BYTES = 1 << 30
BYTES_PER_TEXEL = 8  # RGBA16F
MIP_CHAIN_FACTOR = 4.0 / 3.0  # a full mipmap chain adds a third
HALF_MAX = 65504.0  # largest finite float16
MAX_ANISOTROPY = 16.0


class TextureLimitError(ValueError):
    """The scene has more images than the driver's texture array can hold."""


def srgb_to_linear(values: np.ndarray) -> np.ndarray:
    """The sRGB transfer function inverted (IEC 61966-2-1), element-wise, float32."""
    v = np.asarray(values, np.float32)
    return np.where(v <= 0.04045, v / 12.92, ((np.maximum(v, 0.04045) + 0.055) / 1.055) ** 2.4).astype(np.float32)


def layer_size(shapes: Sequence[tuple[int, ...]], max_size: int, max_layers: int,
               budget_bytes: int = TEXTURE_ARRAY_BUDGET_BYTES) -> tuple[int, int]:
    """(width, height) of the array's layers for images of the given (H, W, ...) shapes.

    The largest width and height, clamped to ``max_size`` and then halved together until
    all layers with their mipmaps fit in ``budget_bytes`` (documented fallbacks; halving
    keeps the resampling of power-of-two images an exact average of texel blocks).
    """
    layers = len(shapes)
    if layers == 0:
        return (1, 1)
    if layers > max_layers:
        raise TextureLimitError(
            f"the scene uses {layers} images but the GPU's texture arrays hold at most "
            f"{max_layers} (GL_MAX_ARRAY_TEXTURE_LAYERS)"
        )
    width = min(max(int(s[1]) for s in shapes), max_size)
    height = min(max(int(s[0]) for s in shapes), max_size)
    per_texel = layers * BYTES_PER_TEXEL * MIP_CHAIN_FACTOR
    while width * height * per_texel > budget_bytes and (width > 1 or height > 1):
        width, height = max((width + 1) // 2, 1), max((height + 1) // 2, 1)
    return width, height


def _resample_axis(image: np.ndarray, size: int, axis: int) -> np.ndarray:
    """Resample one axis to ``size`` texels with a tent filter and repeat wrapping.

    The output texel centres are sampled at the same normalised coordinate as in the
    source. Upsampling uses the tent of one source texel (exactly the GPU's bilinear
    filter); downsampling widens it to the scale factor, averaging every source texel the
    output texel covers.
    """
    n = image.shape[axis]
    if n == size:
        return image
    ratio = n / size
    radius = max(1.0, ratio)
    x = (np.arange(size) + 0.5) * ratio - 0.5  # output centres in source texel coordinates
    first = np.floor(x - radius).astype(np.int64) + 1
    taps = int(math.ceil(2 * radius)) + 1
    out = None
    total = np.zeros(size, np.float64)
    for k in range(taps):
        j = first + k
        w = np.maximum(0.0, 1.0 - np.abs(j - x) / radius)
        total += w
        shape = [1] * image.ndim
        shape[axis] = size
        term = np.take(image, np.mod(j, n), axis=axis) * w.reshape(shape).astype(np.float32)
        out = term if out is None else out + term
    shape = [1] * image.ndim
    shape[axis] = size
    return out / total.reshape(shape).astype(np.float32)


def resample(texture: np.ndarray, width: int, height: int) -> np.ndarray:
    """(H, W, C) image resampled to (height, width, C), wrapping (see _resample_axis)."""
    out = _resample_axis(np.asarray(texture, np.float32), int(width), axis=1)
    return _resample_axis(out, int(height), axis=0)


def pack_layers(textures: Sequence[np.ndarray], width: int, height: int) -> np.ndarray:
    """All textures as one (L, height, width, 4) float16 array, ready for upload.

    Documented fallback for bad texels: NaN becomes 0, +inf and values beyond the half-float
    range become 65504, negative values (and -inf) become 0.
    """
    out = np.empty((len(textures), height, width, 4), np.float16)
    for layer, texture in enumerate(textures):
        image = resample(texture, width, height)
        with np.errstate(invalid="ignore"):
            image = np.clip(np.nan_to_num(image, nan=0.0, posinf=HALF_MAX, neginf=0.0), 0.0, HALF_MAX)
        out[layer] = image
    return out


def pixel_footprint(view_proj: np.ndarray, height: int, orthographic: bool) -> tuple[float, float]:
    """(width at the camera, angular spread) of one pixel, for the tracer's ray cones.

    A pixel's footprint at distance d from the camera is ``width + spread * d``: a
    perspective camera's pixel has width 0 and spreads by its vertical angle; an
    orthographic one has a constant world width and no spread.
    """
    inv = matrix4.inverse(view_proj)
    step = 2.0 / max(int(height), 1)

    def unproject(y: float, z: float) -> np.ndarray:
        p = inv @ np.array([0.0, y, z, 1.0])
        return p[:3] / p[3]

    if orthographic:
        return float(np.linalg.norm(unproject(step, -1.0) - unproject(0.0, -1.0))), 0.0
    a = unproject(0.0, 1.0) - unproject(0.0, -1.0)
    b = unproject(step, 1.0) - unproject(step, -1.0)
    a /= np.linalg.norm(a)
    b /= np.linalg.norm(b)
    return 0.0, float(2.0 * math.asin(min(1.0, np.linalg.norm(a - b) / 2.0)))


def _same_images(a: Sequence[np.ndarray], b: Sequence[np.ndarray]) -> bool:
    if len(a) != len(b):
        return False
    return all(x is y or (x.shape == y.shape and np.array_equal(x, y, equal_nan=True)) for x, y in zip(a, b))


class GPUTextures:
    """The scene's images as one RGBA16F texture array with mipmaps, re-uploaded only when
    the list of images changes. ``array`` is always a valid texture to bind: a 1x1 white
    layer while the scene has no images."""

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        white = np.ones((1, 1, 1, 4), np.float16)
        self._dummy = ctx.texture_array((1, 1, 1), 4, white.tobytes(), dtype="f2")
        self._texture = None
        self._sources: list[np.ndarray] = []
        self.uploads = 0  # GPU uploads made (tests prove that unchanged frames make none)
        self.layer_size = (1, 1)
        self.downscaled = False  # a documented fallback shrank the layers below the images

    @property
    def array(self):
        """The texture array to bind (never None)."""
        return self._texture if self._texture is not None else self._dummy

    @property
    def layers(self) -> int:
        return len(self._sources)

    def upload(self, textures: Sequence[np.ndarray]) -> bool:
        """Make the GPU array hold ``textures``; returns True when it uploaded."""
        textures = list(textures)
        if _same_images(textures, self._sources):
            self._sources = textures  # hold the current objects (their ids stay unique)
            return False
        old, self._texture = self._texture, None
        if old is not None:
            old.release()
        self._sources = textures
        self.uploads += 1
        if not textures:
            self.layer_size, self.downscaled = (1, 1), False
            return True
        limits = gl_context.limits()
        width, height = layer_size([t.shape for t in textures], limits.max_texture_size,
                                   limits.max_array_texture_layers)
        self.downscaled = any(t.shape[1] > width or t.shape[0] > height for t in textures)
        if self.downscaled:
            log.warning("%d image texture(s) resampled to %dx%d to fit the GPU's limits or the "
                        "%d MiB texture budget", len(textures), width, height,
                        TEXTURE_ARRAY_BUDGET_BYTES >> 20)
        data = pack_layers(textures, width, height)
        tex = self.ctx.texture_array((width, height, len(textures)), 4, memoryview(data).cast("B"), dtype="f2")
        tex.repeat_x = tex.repeat_y = True
        tex.build_mipmaps()
        tex.filter = (self.ctx.LINEAR_MIPMAP_LINEAR, self.ctx.LINEAR)
        # llvmpipe's anisotropic filter is wrong (it averages far beyond the footprint, in
        # fragment and compute shaders alike), so software renderers filter trilinearly.
        if not gl_context.is_software_renderer():
            tex.anisotropy = min(MAX_ANISOTROPY, float(self.ctx.max_anisotropy))
        self._texture = tex
        self.layer_size = (width, height)
        if gl_context.debug_checks_enabled():
            gl_context.check_error("texture array upload")
        return True

    def release(self) -> None:
        for tex in (self._texture, self._dummy):
            if tex is not None:
                tex.release()
        self._texture = self._dummy = None
        self._sources = []
