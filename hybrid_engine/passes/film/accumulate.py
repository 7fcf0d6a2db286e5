# SPDX-License-Identifier: GPL-3.0-or-later
"""The ``accumulate`` pass: the running mean of a view's samples, on the GPU.

A viewport adds one sample per redraw and a final render ``render_samples`` of them
(frame/accumulation.py says why and where each sample lies). Keeping the sum on the host
cost a full read-back of every sample and a float64 numpy sum per pixel, work that grows
with the image and dwarfs the frame's own host cost at 1080p. Here the sum stays in GPU
textures: each frame adds its ``color`` into a float32 sum with Kahan's compensation
(``gpu_shaders/film/accumulate.comp.glsl``; the mean matches a float64 sum to
float32 precision) and writes the mean, the frame's ``film`` resource, which the frame's end
reads back once.

The state belongs to one renderer (one consumer: a viewport or a final render). Sample 0 of
a view starts the sum over; sample k must follow sample k - 1 of the same size, and a frame
out of step is refused rather than averaged into the wrong sum.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import moderngl

from ...gpu import shader_loader
from ...gpu.bindings import Image, bind
from ...gpu.render_targets import release_all
from ...scene.settings import RenderSettings
from ..frame_context import FrameContext, PassIO

WORKGROUP = 8


class AccumulationError(RuntimeError):
    """A sample that does not follow the last one (the sum would mix two views)."""


@dataclass(frozen=True)
class FilmImage:
    """The mean of ``count`` samples, an RGBA32F texture of ``size`` (width, height), row 0
    at the bottom; valid until the next frame of the same renderer."""

    mean: object
    count: int
    size: tuple[int, int]


class AccumulatePass:
    """Adds the frame's colour into the running sum and writes the mean (module docstring)."""

    name = "accumulate"

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.program = shader_loader.compute(ctx, "film/accumulate.comp.glsl")
        self.size: tuple[int, int] | None = None
        self.count = 0
        self._textures: dict[str, object] = {}

    def io(self, settings: RenderSettings) -> PassIO:
        return PassIO(reads=("color",), writes=("film",))

    def run(self, frame: FrameContext) -> None:
        frame.write("film", self.add(frame.read("color"), frame.sample))

    def add(self, color, sample: int) -> FilmImage:
        """Add ``color`` (an RGBA32F texture) as sample ``sample`` of the view: 0 starts the
        sum over, any other must be the next one after the last of the same size."""
        size = tuple(int(v) for v in color.size)
        if sample != 0 and (sample != self.count or size != self.size):
            raise AccumulationError(
                f"sample {sample} of a {size[0]}x{size[1]} view does not follow the {self.count} samples of "
                f"the {self._size_text()} view accumulated so far; start again at sample 0")
        self._ensure(size)
        self.count = 1 if sample == 0 else self.count + 1
        # The passes before wrote the colour as an image; the read-back after reads the mean
        # as a texture or into a pixel buffer.
        self.ctx.memory_barrier(moderngl.SHADER_IMAGE_ACCESS_BARRIER_BIT)
        bind(self.program, images={"u_color": Image(color, read=True, write=False),
                                   "u_sum": Image(self._textures["sum"], read=True, write=True),
                                   "u_compensation": Image(self._textures["compensation"], read=True, write=True),
                                   "u_mean": Image(self._textures["mean"], read=False, write=True)},
             uniforms={"u_size": size, "u_restart": int(sample == 0), "u_count": float(self.count)})
        self.program.run(math.ceil(size[0] / WORKGROUP), math.ceil(size[1] / WORKGROUP), 1)
        self.ctx.memory_barrier(moderngl.TEXTURE_UPDATE_BARRIER_BIT | moderngl.PIXEL_BUFFER_BARRIER_BIT
                                | moderngl.TEXTURE_FETCH_BARRIER_BIT)
        return FilmImage(self._textures["mean"], self.count, size)

    def _ensure(self, size: tuple[int, int]) -> None:
        """Textures of ``size``, made again only when the size changes."""
        if size == self.size:
            return
        self.release()
        for name in ("sum", "compensation", "mean"):
            self._textures[name] = self.ctx.texture(size, 4, dtype="f4")
        self.size = size

    def _size_text(self) -> str:
        return "no" if self.size is None else f"{self.size[0]}x{self.size[1]}"

    def release(self) -> None:
        release_all(self._textures.values())
        self._textures = {}
        self.size, self.count = None, 0
