# SPDX-License-Identifier: GPL-3.0-or-later
"""What the denoiser keeps from one frame to the next, on the GPU.

The temporal step (gpu_shaders/denoise/reproject.comp.glsl) blends each pixel with what
the same surface held last frame, so it needs last frame's blended estimate, the moments
of its guides (for the variance), how many frames each pixel's history holds, and the
surfaces it showed (world point, normal and material) with the view-projection that drew them.
Each is a pair of textures: one frame reads one while it writes the other, and the pair
swaps at the end of the frame (``advance``), so nothing is copied. The work textures of
the wavelet filter live here too, sized with the rest.

A history is valid only for the size it was made at; a new size, or a frame the denoiser
did not see (``forget``), starts every pixel over.
"""
from __future__ import annotations

import numpy as np

from ...gpu.render_targets import release_all
from ...scene.raster_view import gl_matrix

# name: (components, dtype) of each pair of textures.
_PAIRS = {
    "color": (4, "f4"),  # the temporal blend of the estimate
    "moments": (4, "f4"),  # the guides' means and means of squares
    "length": (2, "f4"),  # how many frames each pixel's history holds (0: background), surface id
    "surface": (4, "f4"),  # world point and packed normal (include/denoise.glsl)
    "work": (4, "f4"),  # the wavelet filter's ping-pong
    "variance": (2, "f4"),  # the guides' variances, ping-pong
    "shown": (4, "f4"),  # the filtered estimate the film's mean showed (DenoisePass.film_share)
}


class DenoiseHistory:
    """The denoiser's textures at one size (module docstring). ``current`` / ``previous``
    name the half of each pair this frame writes / last frame wrote."""

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.size: tuple[int, int] | None = None
        self.valid = False
        # Frames since the history last started over: the diffuse gather draws the numbers of
        # this index (DenoisePass.feedback), not of the view's sample, which the viewport
        # holds at 0 while anything moves.
        self.frames = 0
        self.prev_view_proj: np.ndarray | None = None
        self._pairs: dict[str, list] = {}
        self._current = 0

    def ensure(self, size: tuple[int, int]) -> None:
        """Textures of ``size`` (width, height); new ones hold no history."""
        size = (int(size[0]), int(size[1]))
        if size == self.size:
            return
        self._release_textures()
        for name, (components, dtype) in _PAIRS.items():
            pair = [self.ctx.texture(size, components, dtype=dtype) for _ in range(2)]
            for texture in pair:
                texture.filter = (self.ctx.NEAREST, self.ctx.NEAREST)
            self._pairs[name] = pair
        self.size = size
        self.valid = False

    def current(self, name: str):
        return self._pairs[name][self._current]

    def previous(self, name: str):
        return self._pairs[name][1 - self._current]

    def pair(self, name: str) -> list:
        """Both textures of ``name`` (the wavelet filter's ping-pong)."""
        return self._pairs[name]

    def previous_uniforms(self) -> dict:
        """Last frame's view-projection and whether there is a history, as the temporal
        step's uniforms (the identity before a first frame, which the step then does not read)."""
        view_proj = self.prev_view_proj if self.prev_view_proj is not None else np.eye(4)
        return {"u_prev_view_proj": gl_matrix(view_proj), "u_history_valid": int(self.valid)}

    def advance(self, view_proj: np.ndarray) -> None:
        """This frame's textures become the history of the next, seen through ``view_proj``."""
        self._current = 1 - self._current
        self.frames = self.frames + 1 if self.valid else 1
        self.prev_view_proj = np.array(view_proj, np.float64)
        self.valid = True

    def forget(self) -> None:
        """Start every pixel over at the next frame."""
        self.valid = False

    def read(self, name: str) -> np.ndarray:
        """Last frame's texture ``name`` (after ``advance``) as (H, W, C) float32, row 0 at the
        bottom (tests, diagnostics)."""
        texture = self.previous(name)
        w, h = self.size
        return np.frombuffer(texture.read(), np.float32).reshape(h, w, -1).copy()

    def _release_textures(self) -> None:
        release_all(texture for pair in self._pairs.values() for texture in pair)
        self._pairs = {}
        self.size = None

    def release(self) -> None:
        self._release_textures()
        self.valid = False
