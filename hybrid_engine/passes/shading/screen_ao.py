# SPDX-License-Identifier: GPL-3.0-or-later
"""Screen-space ambient occlusion: how much of the sky each primary pixel's surface sees.

The World lights every diffuse surface (sky_light.py), and a surface under a table or in a
corner sees less of it. This pass estimates that share from the primary G-buffer's depths
(``gpu_shaders/shading/screen_ao.comp.glsl``: a few cosine-distributed points above the
surface, projected into the depth buffer) into the alpha of the G-buffer's ``ambient``
target, which the deferred shading smooths over neighbouring pixels of the same surface and
multiplies into the World's light. Its reach is the ``ao_distance`` setting, held with the
rest of the lighting data in FrameResources.

The fallback (*World Light* Screen Space, and RASTER and PROVENANCE, which build no BVH),
not the default: the default traces the diffuse light through the paper's BVH and cube map
(passes/diffuse_light/). This pass costs a few depth reads per pixel and is smooth after the
shading's 3x3 average, but what it cannot see (geometry off screen, behind the first surface
or beyond its reach) does not occlude, which leaves enclosed spaces too bright: light leaks
through walls.
"""
from __future__ import annotations

import math

from ...gpu import shader_loader
from ...gpu.bindings import Image, bind
from ...scene.settings import RenderSettings
from ..frame_context import FrameContext, PassIO
from ..lighting.resources import FrameResources

WORKGROUP = 8


class ScreenSpaceOcclusion:
    """The occlusion pass on the shared context (its program is compiled once); part of the
    frame's ``shade`` step when the World's light is not gathered by rays."""

    name = "shade"

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.program = shader_loader.compute(ctx, "shading/screen_ao.comp.glsl")

    def io(self, settings: RenderSettings) -> PassIO:
        return PassIO(reads=("gbuffer", "lighting"), writes=("ambient",))

    def run(self, frame: FrameContext) -> None:
        targets = frame.read("gbuffer")
        self.occlude(targets, frame.view, frame.read("lighting"), frame.sample)
        frame.write("ambient", targets.ambient)

    def occlude(self, targets, view, resources: FrameResources, sample: int = 0) -> None:
        """Fill ``targets.ambient``'s alpha for the G-buffer of ``view`` (nothing to do when
        the reach is 0: the shading then takes the whole sky)."""
        if not resources.ao_distance > 0.0:
            return
        prog = self.program
        bind(prog, textures={"u_depth": targets.depth, "u_normal_material": targets.normal_material},
             images={"u_visibility": Image(targets.ambient, read=False, write=True)},
             uniforms={**view.uniforms(), "u_view_proj": view.view_proj_bytes(),
                       "u_ao_distance": resources.ao_distance, "u_sample": int(sample),
                       "u_random_unit": resources.random_unit})
        prog.run(math.ceil(view.width / WORKGROUP), math.ceil(view.height / WORKGROUP), 1)
