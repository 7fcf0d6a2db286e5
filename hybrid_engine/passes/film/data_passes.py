# SPDX-License-Identifier: GPL-3.0-or-later
"""The ``data_passes`` pass: a final render's Depth and Normal passes, made on the GPU.

frame/film.py says what the passes hold (Cycles' conventions). They are per-pixel functions
of the primary G-buffer, so they are computed where it lies
(``gpu_shaders/film/data_passes.comp.glsl``) and read back as they are, rather than reading
the G-buffer back and converting it pixel by pixel on the host. The pass runs only in
frames whose outputs ask for a data pass (the renderer plans it then).
"""
from __future__ import annotations

import math

import moderngl
import numpy as np

from ...gpu import shader_loader
from ...gpu.bindings import Image, bind
from ...gpu.render_targets import release_all
from ...scene import matrix4
from ...scene.settings import RenderSettings
from ..frame_context import FrameContext, PassIO

WORKGROUP = 8
# Cycles' Depth where nothing was hit (frame/film.py).
BACKGROUND_DEPTH = 1.0e10


class DataPassesPass:
    """Depth (R32F) and Normal (RGBA32F, xyz) textures of the frame's G-buffer."""

    name = "data_passes"

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.program = shader_loader.compute(ctx, "film/data_passes.comp.glsl")
        self.size: tuple[int, int] | None = None
        self._textures: dict[str, object] = {}

    def io(self, settings: RenderSettings) -> PassIO:
        return PassIO(reads=("gbuffer",), writes=("data_passes",))

    def run(self, frame: FrameContext) -> None:
        targets = frame.read("gbuffer")
        frame.write("data_passes", self.compute(targets.depth, targets.normal_material, frame.camera))

    def compute(self, depth, normal_material, camera) -> dict[str, object]:
        """{"depth": R32F texture, "normal": RGBA32F texture} of the G-buffer's size."""
        size = tuple(int(v) for v in depth.size)
        self._ensure(size)
        inverse = matrix4.inverse(camera.projection_matrix())
        self.ctx.memory_barrier(moderngl.TEXTURE_FETCH_BARRIER_BIT)
        bind(self.program, textures={"u_depth": depth, "u_normal_material": normal_material},
             images={"u_depth_pass": Image(self._textures["depth"], read=False, write=True),
                     "u_normal_pass": Image(self._textures["normal"], read=False, write=True)},
             uniforms={"u_inv_projection": np.ascontiguousarray(inverse.T).tobytes(), "u_size": size,
                       "u_background_depth": BACKGROUND_DEPTH})
        self.program.run(math.ceil(size[0] / WORKGROUP), math.ceil(size[1] / WORKGROUP), 1)
        self.ctx.memory_barrier(moderngl.TEXTURE_UPDATE_BARRIER_BIT | moderngl.PIXEL_BUFFER_BARRIER_BIT)
        return dict(self._textures)

    def _ensure(self, size: tuple[int, int]) -> None:
        if size == self.size:
            return
        self.release()
        self._textures = {"depth": self.ctx.texture(size, 1, dtype="f4"),
                          "normal": self.ctx.texture(size, 4, dtype="f4")}
        self.size = size

    def release(self) -> None:
        release_all(self._textures.values())
        self._textures = {}
        self.size = None


def read_data_passes(textures: dict[str, object], names: tuple[str, ...]) -> dict[str, np.ndarray]:
    """The passes ``names`` as float32 arrays, row 0 at the bottom: "depth" (H, W), "normal"
    (H, W, 3)."""
    out = {}
    for name in names:
        texture = textures[name]
        width, height = (int(v) for v in texture.size)
        if name == "depth":
            out[name] = np.empty((height, width), np.float32)
            texture.read_into(out[name])
        else:
            rgba = np.empty((height, width, 4), np.float32)
            texture.read_into(rgba)
            out[name] = np.ascontiguousarray(rgba[..., :3])
    return out
