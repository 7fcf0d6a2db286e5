# SPDX-License-Identifier: GPL-3.0-or-later
"""What a final render delivers besides the shaded colour: Blender's film and passes.

An artist composites a render: over a plate (*Film > Transparent*), with depth of field or
fog from the *Depth* pass, relit or masked from the *Normal* pass, and re-renders a small
part of a frame (*Render Region*, Ctrl+B in camera view). Blender's own engines give all
four, so a renderer that ignores them breaks a compositing setup the moment it is chosen.
The conventions below are Cycles', so a compositing node tree made for Cycles reads ours
the same way (tests/test_engine.py compares both engines in one process):

* transparent film: the background (no primary hit) is (0, 0, 0, 0), premultiplied; rays
  reflected or refracted into the sky still see it, as in Cycles;
* Depth: the distance from the camera *along its view axis* (planar, not along the ray),
  in scene units, and ``BACKGROUND_DEPTH`` where nothing was hit;
* Normal: the world-space shading normal turned towards the camera (a surface seen from its
  back side reports the back side's normal), 0 where nothing was hit;
* Denoising Albedo and Denoising Normal (Cycles' *Denoising Data* passes, which the
  compositor's Denoise node reads beside the noisy image): the albedo of the surface's
  diffuse-like closures, or a specular-dominant surface's tint, and the shading normal on
  the viewer's side in Cycles' camera space (x right, y up, z into the view), both 0 on the
  background and both the mean over the render's samples, as the colour is
  (gpu_shaders/film/data_passes.comp.glsl gives the rules);
* render region: Blender's render pipeline asks for the pixels ``views.border_pixels`` gives
  (its ``disprect``: fractions times the resolution, truncated), and places them in the
  full frame itself unless the render is cropped to the region.

The data passes are made on the GPU from the primary G-buffer by the frame's
``data_passes`` pass (passes/film/data_passes.py), and only in frames that ask for them.
"""
from __future__ import annotations

from dataclasses import dataclass

from ..passes.film.data_passes import BACKGROUND_DEPTH as DATA_PASS_BACKGROUND_DEPTH
from ..passes.film.data_passes import DENOISING, DEPTH_NORMAL
from ..passes.film.light_passes import LightPassRequest
from ..passes.film.vector import VectorRequest
from ..scene.cryptomatte import CryptomatteRequest

# Cycles' Depth of a pixel that hit nothing (kernel film: "no hit" leaves the 1e10 it
# starts the pass with); compositing setups test for it.
BACKGROUND_DEPTH = DATA_PASS_BACKGROUND_DEPTH


class FilmError(ValueError):
    """A render region that covers no pixel."""


@dataclass(frozen=True)
class FrameOutputs:
    """What a frame is asked to deliver besides its colour.

    ``transparent``: background pixels get alpha 0 (Blender's ``render.film_transparent``).
    ``depth`` / ``normal``: fill ``FrameResult.data_passes["depth"]`` ((H, W) float32) and
    ``["normal"]`` ((H, W, 3) float32), as the view layer's Z and Normal passes.
    ``denoising``: fill ``["denoising_albedo"]`` and ``["denoising_normal"]`` ((H, W, 3)
    float32), the means over the view's samples: every sample of the view must ask for them,
    and the frame that reads its image reads them.
    ``cryptomatte``: fill ``data_passes`` under Blender's names (``CryptoObject00``, ...:
    (H, W, 4) float32) with the kinds and levels it asks for, counted over every sample of
    the view (passes/film/cryptomatte.py) and read by the frame that reads its image.
    ``light``: fill ``data_passes`` under Cycles' names with the light passes and Mist it
    asks for ((H, W, channels) float32), over every sample of the view
    (passes/film/light_passes.py), read by the frame that reads its image.
    ``vector``: fill ``data_passes["Vector"]`` ((H, W, 4) float32) with Cycles' Vector pass
    of the motion it holds, over every sample of the view (passes/film/vector.py), read by
    the frame that reads its image.
    """

    transparent: bool = False
    depth: bool = False
    normal: bool = False
    denoising: bool = False
    cryptomatte: CryptomatteRequest | None = None
    light: LightPassRequest | None = None
    vector: VectorRequest | None = None

    @property
    def wants_data(self) -> bool:
        """Whether the frame runs the ``data_passes`` pass."""
        return self.depth or self.normal or self.denoising

    def data_names(self, reads_image: bool) -> tuple[str, ...]:
        """The data passes a frame reads back: those asked for, the denoising means only in a
        frame that reads its image (the last of a final render's samples)."""
        names = tuple(name for name in DEPTH_NORMAL if getattr(self, name))
        return names + (DENOISING if self.denoising and reads_image else ())
