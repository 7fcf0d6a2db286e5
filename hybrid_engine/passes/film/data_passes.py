# SPDX-License-Identifier: GPL-3.0-or-later
"""The ``data_passes`` pass: a final render's Depth and Normal passes, and its Denoising
Albedo and Denoising Normal passes, made on the GPU.

frame/film.py says what the passes hold (Cycles' conventions). They are per-pixel functions
of the primary G-buffer, so they are computed where it lies
(``gpu_shaders/film/data_passes.comp.glsl``) and read back as they are, rather than reading
the G-buffer back and converting it pixel by pixel on the host. The pass runs only in
frames whose outputs ask for a data pass (the renderer plans it then).

The denoising passes guide a denoiser (the compositor's Denoise node) and must be
antialiased like the colour they guide, so they are running means over the view's samples
kept on the GPU, as the colour's ``accumulate`` keeps its own: every sample of a final
render adds to them, and only the frame that reads its image reads them back.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import moderngl
import numpy as np

from ...gpu import shader_loader
from ...gpu.bindings import Image, bind
from ...gpu.render_targets import release_all
from ...scene import matrix4
from ...scene.settings import RenderSettings
from ..frame_context import FrameContext, PassIO
from ..scene_upload.scene_buffers import GPUScene
from .accumulate import AccumulationError

WORKGROUP = 8
# Cycles' Depth where nothing was hit (frame/film.py).
BACKGROUND_DEPTH = 1.0e10
# The passes a frame's outputs may ask for (film.FrameOutputs), in the order they are read.
DEPTH_NORMAL = ("depth", "normal")
DENOISING = ("denoising_albedo", "denoising_normal")
# Blender's camera space has z towards the viewer, Cycles' (its Denoising Normal) away from it.
CYCLES_CAMERA_AXES = np.diag([1.0, 1.0, -1.0])


@dataclass(frozen=True)
class DenoisingInputs:
    """What the denoising passes read besides the depth and normal: the G-buffer's albedo and
    surface targets, the scene's materials, and the frame's index among the view's samples
    (0 starts the means over)."""

    albedo: object
    surface: object
    scene: GPUScene
    sample: int
    depth_normal: bool = True  # the frame reads the Depth or Normal too (else they are skipped)


class DataPassesPass:
    """Depth (R32F) and Normal (RGBA32F, xyz) textures of the frame's G-buffer, and, when
    asked, the running means of the Denoising Albedo and Normal (RGBA32F, rgb)."""

    name = "data_passes"

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.program = shader_loader.compute(ctx, "film/data_passes.comp.glsl")
        self._denoising_program = None  # compiled on the first frame that asks for it
        self.size: tuple[int, int] | None = None
        self.denoising_count = 0  # samples in the denoising means
        self._textures: dict[str, object] = {}

    def io(self, settings: RenderSettings) -> PassIO:
        return PassIO(reads=("gbuffer", "scene_buffers"), writes=("data_passes",))

    def run(self, frame: FrameContext) -> None:
        targets = frame.read("gbuffer")
        features = None
        if frame.outputs.denoising:
            features = DenoisingInputs(targets.albedo, targets.surface, frame.read("scene_buffers"), frame.sample,
                                       depth_normal=frame.outputs.depth or frame.outputs.normal)
        frame.write("data_passes", self.compute(targets.depth, targets.normal_material, frame.camera, features))

    def compute(self, depth, normal_material, camera, features: DenoisingInputs | None = None) -> dict[str, object]:
        """{"depth": R32F texture, "normal": RGBA32F texture} of the G-buffer's size, and with
        ``features`` "denoising_albedo" and "denoising_normal", the means of samples
        0..``features.sample`` (sample 0 starts them over; any other must follow the last of
        the same size, else AccumulationError)."""
        size = tuple(int(v) for v in depth.size)
        if features is not None and features.sample != 0 and (
                features.sample != self.denoising_count or size != self.size):
            raise AccumulationError(
                f"denoising sample {features.sample} of a {size[0]}x{size[1]} view does not follow the "
                f"{self.denoising_count} samples so far; start again at sample 0")
        self._ensure(size, denoising=features is not None)
        inverse = matrix4.inverse(camera.projection_matrix())
        program = self.program
        images = {"u_depth_pass": Image(self._textures["depth"], read=False, write=True),
                  "u_normal_pass": Image(self._textures["normal"], read=False, write=True)}
        textures = {"u_depth": depth, "u_normal_material": normal_material}
        uniforms = {"u_inv_projection": np.ascontiguousarray(inverse.T).tobytes(), "u_size": size,
                    "u_background_depth": BACKGROUND_DEPTH}
        parts = []
        if features is not None:
            program = self._denoising()
            parts.append(features.scene.bindings())
            for name in DENOISING:
                images[f"u_{name}"] = Image(self._textures[name], read=True, write=True)
            textures.update(u_albedo=features.albedo, u_surface=features.surface)
            to_camera = CYCLES_CAMERA_AXES @ camera.view_matrix()[:3, :3]
            uniforms.update(u_world_to_camera=np.ascontiguousarray(to_camera.T, np.float32).tobytes(),
                            u_sample=int(features.sample), u_depth_normal=int(features.depth_normal))
        self.ctx.memory_barrier(moderngl.TEXTURE_FETCH_BARRIER_BIT | moderngl.SHADER_IMAGE_ACCESS_BARRIER_BIT)
        bind(program, *parts, textures=textures, images=images, uniforms=uniforms)
        program.run(math.ceil(size[0] / WORKGROUP), math.ceil(size[1] / WORKGROUP), 1)
        self.ctx.memory_barrier(moderngl.TEXTURE_UPDATE_BARRIER_BIT | moderngl.PIXEL_BUFFER_BARRIER_BIT
                                | moderngl.SHADER_IMAGE_ACCESS_BARRIER_BIT)
        if features is not None:
            self.denoising_count = features.sample + 1
        return dict(self._textures)

    def _denoising(self):
        if self._denoising_program is None:
            self._denoising_program = shader_loader.compute(self.ctx, "film/data_passes.comp.glsl",
                                                            defines={"DENOISING": 1})
        return self._denoising_program

    def _ensure(self, size: tuple[int, int], denoising: bool) -> None:
        """Textures of ``size``, made again only when the size changes; the denoising means'
        on the first frame that asks for them."""
        if size != self.size:
            self.release()
            self._textures = {"depth": self.ctx.texture(size, 1, dtype="f4"),
                              "normal": self.ctx.texture(size, 4, dtype="f4")}
            self.size = size
        if denoising and DENOISING[0] not in self._textures:
            for name in DENOISING:
                self._textures[name] = self.ctx.texture(size, 4, dtype="f4")

    def release(self) -> None:
        release_all(self._textures.values())
        self._textures = {}
        self.size = None
        self.denoising_count = 0


def read_data_passes(textures: dict[str, object], names: tuple[str, ...]) -> dict[str, np.ndarray]:
    """The passes ``names`` as float32 arrays, row 0 at the bottom: "depth" (H, W), the
    others (H, W, 3)."""
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
