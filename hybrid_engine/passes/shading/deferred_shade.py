# SPDX-License-Identifier: GPL-3.0-or-later
"""Deferred shading of the primary G-buffer (gpu_shaders/shading/deferred_shade.comp.glsl,
paper §3.5): emission, the World's light and every lamp with its shadow map, plus the
specular lobes no ray follows. RASTER mode's image is this pass's; the traced modes add
their rays' radiance to it (tracer.py)."""
from __future__ import annotations

import math

from ...gpu import shader_loader
from ...gpu.bindings import Image, bind
from ...gpu.render_targets import GBufferTargets
from ...scene.raster_view import RasterView
from ...scene.settings import RenderSettings
from ..film.light_passes import LightPassRequest, LightSampleTargets, light_bindings
from ..frame_context import FrameContext, PassIO
from ..lighting.resources import FrameResources
from ..scene_upload.scene_buffers import GPUScene


class DeferredShadePass:
    """Shades a G-buffer into its ``color`` target (the frame's ``shade`` step)."""

    name = "shade"

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.program = shader_loader.compute(ctx, "shading/deferred_shade.comp.glsl")
        # Whether the frame's plan asks for Cycles' light passes (the renderer sets it): the
        # shading then also writes their layers, the ``light_samples`` resource
        # (passes/film/light_passes.py).
        self.light_passes = False
        self.light_targets = LightSampleTargets(ctx)

    def io(self, settings: RenderSettings) -> PassIO:
        return PassIO(reads=("scene_buffers", "gbuffer", "ambient", "lighting"),
                      writes=("color",) + (("light_samples",) if self.light_passes else ()))

    def run(self, frame: FrameContext) -> None:
        targets = frame.read("gbuffer")
        light = frame.outputs.light if self.light_passes else None
        self.shade(frame.read("scene_buffers"), frame.view, targets, frame.read("lighting"),
                   traced_specular=frame.settings.mode != "RASTER", transparent=frame.outputs.transparent,
                   sample=frame.sample, ambient=frame.read("ambient"), ambient_filtered=frame.denoise,
                   light=light)
        frame.write("color", targets.color)
        if light is not None:
            frame.write("light_samples", self.light_targets.layers)

    def shade(self, gpu: GPUScene, view: RasterView, targets: GBufferTargets, resources: FrameResources, *,
            traced_specular: bool = False, transparent: bool = False, sample: int = 0, ambient=None,
            ambient_filtered: bool = False, light: LightPassRequest | None = None) -> None:
        """Shade ``targets`` into ``targets.color``, lit by ``resources``.
        ``traced_specular`` leaves the lobes the tracer follows out (every traced mode);
        ``transparent`` makes the background (0, 0, 0, 0) instead of the sky (film.py).
        ``sample`` is this sample's index among the samples of one view. The World's light
        is read from ``ambient`` (the frame's ``ambient`` resource: screen_ao.py's or the
        tracer's sky rays' estimate, run first; ``targets.ambient`` when None), smoothed over
        3x3 pixels unless ``ambient_filtered`` (the denoiser, passes/denoise/, filtered it).
        ``light``: also write the light passes' layers of this sample (``light_targets``)."""
        defines = {**gpu.defines, **resources.defines,  # node programs, light linking
                   **({"LIGHT_PASSES": 1} if light is not None else {})}
        prog = (shader_loader.compute(self.ctx, "shading/deferred_shade.comp.glsl", defines)
                if defines else self.program)
        images, uniforms = {}, {}
        if light is not None:
            images, uniforms = light_bindings(self.light_targets.of_size((view.width, view.height)))
            uniforms.update(light.mist_uniforms())
        bind(prog, gpu.bindings(), resources.bindings(),
             textures={"u_depth": targets.depth, "u_normal_material": targets.normal_material,
                       "u_albedo": targets.albedo, "u_emission_scale": targets.emission_scale,
                       "u_ambient": targets.ambient if ambient is None else ambient, "u_surface": targets.surface},
             images={"u_output": Image(targets.color, read=False, write=True), **images},
             uniforms={**view.uniforms(), "u_traced_specular": int(traced_specular),
                       "u_transparent_background": int(transparent), "u_sample": int(sample),
                       "u_ambient_filtered": int(ambient_filtered), **uniforms})
        prog.run(math.ceil(view.width / 8), math.ceil(view.height / 8), 1)
