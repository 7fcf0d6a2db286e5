# SPDX-License-Identifier: GPL-3.0-or-later
"""Cycles' light passes (Diffuse, Glossy and Transmission Color / Direct / Indirect,
Emission, Environment, AO) and Mist, made by the shaders that shade.

A compositing node tree made for Cycles recombines Combined from the light passes as
Cycles documents, ``(Direct + Indirect) x Color`` per lobe plus Emission and Environment, and
a studio relights or grades each lobe on its own; a renderer that writes other names or
other conventions breaks those trees. The passes here keep Cycles' names, channels and
conventions (``PASSES``), so the same tree reads either engine.

How it is made, without a second shading of the frame: with the host define
``LIGHT_PASSES`` the deferred shading (``shading/deferred_shade.comp.glsl``) writes, beside
the colour, each lobe's colour and the light it brought (``include/light_passes.glsl``),
and the hybrid tracer (``trace/hybrid_trace.comp.glsl``) adds what arrives through the
primary hit's reflection (the paper's recursive mirror rays, §3.4) to Glossy Indirect and
through its refraction to Transmission Indirect: the lobe is decided at the primary hit,
as Cycles decides it. The layers are tiles of one RGBA32F image per view, two across and
five down, so a 4K view still fits the largest image a GPU makes (``LightSampleTargets``); this pass (the frame's ``light_passes`` step, after
``accumulate``) adds each sample into running sums and writes the passes as delivered
(light divided by colour, Cycles' film convention, and the means) over the sample's layers,
which the frame that reads its image reads back in one go. A frame whose view layer asks
for none compiles none of it and runs exactly as before: the image is the same bit for bit
(tests/test_light_passes.py).

What differs from Cycles (README, passes): the World's light on the diffuse layer is all
Diffuse Indirect (the gather does not tell the sky from the surfaces that hide it, where
Cycles counts the sky as Direct); no lamp is seen straight through a refraction
(Transmission Direct is 0); AO is the sky's visibility the frame's World light estimated.
The GPU-shaped wave tracer has no lobe per ray, so a frame with light passes traces with
the megakernel.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import moderngl
import numpy as np

from ...gpu import shader_loader
from ...gpu.bindings import Image, bind
from ...scene.settings import RenderSettings
from ..frame_context import FrameContext, PassIO
from .accumulate import AccumulationError

WORKGROUP = 8
LAYERS = 10  # include/light_passes.glsl LP_LAYERS
COLUMNS = 2  # ... LP_COLUMNS: the layers are tiles of one image, two across and five down
ROWS = math.ceil(LAYERS / COLUMNS)

# Each pass: Cycles' name, its channels and channel ids, the kind register_pass takes, the
# resolved layer it is read from (film/light_passes.comp.glsl OUT_*; None: all zero) and
# the components of that layer. Keys are the ViewLayer properties that ask for them.
PASSES: dict[str, tuple[str, int, str, str, int | None, slice]] = {
    "use_pass_diffuse_direct": ("Diffuse Direct", 3, "RGB", "COLOR", 0, slice(0, 3)),
    "use_pass_diffuse_indirect": ("Diffuse Indirect", 3, "RGB", "COLOR", 1, slice(0, 3)),
    "use_pass_diffuse_color": ("Diffuse Color", 3, "RGB", "COLOR", 2, slice(0, 3)),
    "use_pass_glossy_direct": ("Glossy Direct", 3, "RGB", "COLOR", 3, slice(0, 3)),
    "use_pass_glossy_indirect": ("Glossy Indirect", 3, "RGB", "COLOR", 4, slice(0, 3)),
    "use_pass_glossy_color": ("Glossy Color", 3, "RGB", "COLOR", 5, slice(0, 3)),
    "use_pass_transmission_direct": ("Transmission Direct", 3, "RGB", "COLOR", None, slice(0, 3)),
    "use_pass_transmission_indirect": ("Transmission Indirect", 3, "RGB", "COLOR", 6, slice(0, 3)),
    "use_pass_transmission_color": ("Transmission Color", 3, "RGB", "COLOR", 7, slice(0, 3)),
    "use_pass_emit": ("Emission", 3, "RGB", "COLOR", 8, slice(0, 3)),
    "use_pass_environment": ("Environment", 3, "RGB", "COLOR", 9, slice(0, 3)),
    "use_pass_ambient_occlusion": ("Ambient Occlusion", 3, "RGB", "COLOR", 2, slice(3, 4)),
    "use_pass_mist": ("Mist", 1, "Z", "VALUE", 5, slice(3, 4)),
}
# Blender's World mist falloffs and the exponent Cycles gives each (scene/film.cpp).
MIST_FALLOFF = {"QUADRATIC": 2.0, "LINEAR": 1.0, "INVERSE_QUADRATIC": 0.5}


@dataclass(frozen=True)
class LightPassRequest:
    """The light passes a frame delivers (``PASSES`` keys) and the World's mist settings
    (Start, Depth, Falloff) the Mist pass follows."""

    flags: tuple[str, ...]
    mist_start: float = 5.0
    mist_depth: float = 25.0
    mist_falloff: str = "QUADRATIC"

    def __post_init__(self) -> None:
        unknown = set(self.flags) - set(PASSES)
        if unknown:
            raise ValueError(f"no such light pass: {sorted(unknown)}")
        if self.mist_falloff not in MIST_FALLOFF:
            raise ValueError(f"mist falloff {self.mist_falloff!r} is none of {sorted(MIST_FALLOFF)}")

    @property
    def names(self) -> tuple[str, ...]:
        """Cycles' names of the passes asked for."""
        return tuple(PASSES[flag][0] for flag in self.flags)

    def mist_uniforms(self) -> dict[str, float]:
        """deferred_shade.comp.glsl's u_mist_*: Cycles' start, 1 / depth and exponent."""
        depth = float(self.mist_depth)
        return {"u_mist_start": float(self.mist_start), "u_mist_inv_depth": 1.0 / depth if depth > 0.0 else 1e30,
                "u_mist_falloff": MIST_FALLOFF[self.mist_falloff]}


def tiled(ctx, size: tuple[int, int]):
    """An RGBA32F image holding ``LAYERS`` tiles of ``size`` (include/light_passes.glsl)."""
    return ctx.texture((size[0] * COLUMNS, size[1] * ROWS), 4, dtype="f4")


def view_size(layers) -> tuple[int, int]:
    """The view size of a tiled image."""
    return int(layers.width) // COLUMNS, int(layers.height) // ROWS


def light_bindings(layers) -> tuple[dict, dict]:
    """The images and uniforms a shader that includes light_passes.glsl binds."""
    return ({"u_light_samples": Image(layers, read=True, write=True)}, {"u_light_view": view_size(layers)})


class LightSampleTargets:
    """The per-sample layers the shading and the tracer write (one tiled RGBA32F image),
    made again only when the view's size changes."""

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.layers = None
        self.size: tuple[int, int] | None = None

    def of_size(self, size: tuple[int, int]):
        if size != self.size:
            self.release()
            self.layers = tiled(self.ctx, size)
            self.size = size
        return self.layers

    def release(self) -> None:
        if self.layers is not None:
            self.layers.release()
        self.layers, self.size = None, None


class LightPassesPass:
    """Adds a sample's light layers into the view's sums and writes the passes as delivered
    over them (the frame's ``light_passes`` step; module docstring)."""

    name = "light_passes"

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.program = shader_loader.compute(ctx, "film/light_passes.comp.glsl")
        self._sums = None
        self.size: tuple[int, int] | None = None
        self.count = 0

    def io(self, settings: RenderSettings) -> PassIO:
        return PassIO(reads=("light_samples",), writes=("light_film",))

    def run(self, frame: FrameContext) -> None:
        frame.write("light_film", self.add(frame.read("light_samples"), frame.sample))

    def add(self, layers, sample: int):
        """Add ``layers`` as sample ``sample`` of the view (0 starts over) and resolve them."""
        size = view_size(layers)
        if sample != 0 and (sample != self.count or size != self.size):
            raise AccumulationError(f"light pass sample {sample} of a {size[0]}x{size[1]} view does not follow "
                                    f"the {self.count} samples so far; start again at sample 0")
        if size != self.size:
            self.release()
            self._sums = tiled(self.ctx, size)
            self.size = size
        self.count = 1 if sample == 0 else self.count + 1
        self.ctx.memory_barrier(moderngl.SHADER_IMAGE_ACCESS_BARRIER_BIT)
        bind(self.program, images={"u_light_samples": Image(layers, read=True, write=True),
                                   "u_light_sums": Image(self._sums, read=True, write=True)},
             uniforms={"u_size": size, "u_light_view": size, "u_restart": int(sample == 0),
                       "u_count": float(self.count)})
        self.program.run(math.ceil(size[0] / WORKGROUP), math.ceil(size[1] / WORKGROUP), 1)
        self.ctx.memory_barrier(moderngl.TEXTURE_UPDATE_BARRIER_BIT | moderngl.SHADER_IMAGE_ACCESS_BARRIER_BIT)
        return layers

    def release(self) -> None:
        if self._sums is not None:
            self._sums.release()
        self._sums, self.size, self.count = None, None, 0


def read_light_passes(layers, request: LightPassRequest) -> dict[str, np.ndarray]:
    """The passes ``request`` asks for, by Cycles' name, as float32 arrays of (H, W, channels),
    row 0 at the bottom, from the resolved layers (one read of the tiled image)."""
    width, height = view_size(layers)
    tiles = np.empty((ROWS, height, COLUMNS, width, 4), np.float32)
    layers.read_into(tiles)
    resolved = tiles.transpose(0, 2, 1, 3, 4).reshape(ROWS * COLUMNS, height, width, 4)  # a view: no copy
    out = {}
    for flag in request.flags:
        name, channels, _ids, _kind, layer, components = PASSES[flag]
        if layer is None:
            out[name] = np.zeros((height, width, channels), np.float32)
        elif name == "Ambient Occlusion":  # Cycles' AO is grey RGB
            out[name] = np.repeat(resolved[layer, :, :, 3:4], 3, axis=2)
        else:
            out[name] = np.ascontiguousarray(resolved[layer, :, :, components])
    return out
