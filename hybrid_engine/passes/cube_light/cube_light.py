# SPDX-License-Identifier: GPL-3.0-or-later
"""The lit cube map: the G-buffer cube map's faces (paper §3.2) shaded into light once per frame.

The paper's cube map stores G-buffers, and the tracer shades every cube-map hit of every ray
again (§3.4, §3.5): the lamps' shadow lookups and the World's light per ray, and a rough
reflection of the map can only be sampled, never read prefiltered. This pass shades each
texel's diffuse, view-independent light once (``gpu_shaders/cube_light/``):

* **shade** (``cube_light_shade.comp.glsl``): the lamps through their shadow maps, and the
  World's irradiance times the sky the texel sees plus the light bounced onto it, into level 0
  of a radiance atlas laid out as the cube map (``include/cube_radiance.glsl``); no emission,
  which every reader adds from the hit's material where it counts (a float16 texel holding a
  bright emission would leave the light the emitter reflects to its rounding);
* **gather** (``cube_light_gather.comp.glsl``), before it, at a quarter of the resolution per
  side: one cosine ray per block of texels per frame, marched through the cube map, bringing
  the sky (escaped) or the light the previous frame stored where it hits (one bounce more
  each frame: multi-bounce by feedback), averaged over frames;
* **mips** (``cube_light_downsample.comp.glsl``): the box-filtered chain per face, so that a
  rough reflection reads the map at the level its ray cone spans.

The tracer, given the ``cube_light`` resource, returns the stored light at its cube-map hits
(``include/lit_cube.glsl``, define ``LIT_CUBE``) and adds the hit's emission, the lamps'
highlights and the traced reflections there, the parts the map does not hold.

Stability of the feedback. Each frame the gather blends a new sample into its running average
with weight ``BLEND`` (an exponential average). Light enters the loop only through emission,
lamps and the sky; a bounce returns at most albedo < 1 of what arrives (the cosine estimate of
a Lambertian surface), so the stored light obeys L' <= e + rho K L with ||rho K|| < 1 and its
frames converge to the bounded multi-bounce solution instead of growing; every sample and
texel is clamped to what float16 holds, so no estimate turns infinite. When a light goes, its
direct part goes at once (it is shaded anew each frame), and what it bounced decays by at most
(1 - BLEND) + BLEND rho per frame, rho the albedo times the share of bounce rays that meet a
surface, starting from the bounced share of the light (at most rho / (1 - rho) of the direct):
in a room of albedo 1/2 open on two sides it is below 1 % after ``FADE_FRAMES`` frames
(tests/test_cube_light.py). A closed room of white walls holds its light longer, as it
physically does, converging or fading at 1/2 + rho/2 per frame.

Motion. The map moves with the camera; the gather finds last frame's light and its own
history by reprojecting world points into the previous frame's map (its centre differs, its
face matrices differ only by that translation), and drops what the previous map held at
another distance (disocclusion). On the first frame, or when the map's size changes, it runs
``WARMUP`` gathers at once (a progressive average), so that the first image already has a few
bounces.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import moderngl
import numpy as np

from ...gpu import shader_loader
from ...gpu.bindings import Image, bind
from ...gpu.dispatch import storage_barrier
from ...scene.bounds import SceneBounds
from ...scene.settings import RenderSettings
from ..cube_map.cube_pyramid import face_size
from ..frame_context import FrameContext, PassIO
from ..trace.tracer import scene_bound_uniforms

WORKGROUP = 8  # local size of the pass's shaders in x and y
GATHER_BLOCK = 4  # texels per side of a gather block (cube_light_texels.glsl CUBE_GATHER_BLOCK)
BLEND = 0.5  # weight of a frame's gather sample in the running average
FADE_FRAMES = 8  # frames after which a light switched off leaves < 1 % (albedo 1/2, open room; docstring)
WARMUP = 4  # gathers run at once when there is no history


@dataclass(frozen=True)
class LitCubeMap:
    """What the tracer binds to read the lit cube map (include/lit_cube.glsl): its define, the
    radiance atlas and its uniforms."""

    defines: dict
    textures: dict
    uniforms: dict


class CubeLightPass:
    """Shades the cube map's texels into the radiance atlas, its feedback and its mips (the
    frame's ``cube_light`` pass, after ``cube_map_raster``); keeps the last frame's atlas and
    gather for the next."""

    name = "cube_light"

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.radiance: list[moderngl.Texture] = []  # [current, previous], mipmapped rgba16f
        self.gather: list[moderngl.Texture] = []  # [current, previous], rgba16f
        self.face_size = 0
        self.levels = 0
        self.gather_res = 0
        self._key: tuple | None = None  # the sizes the history was made for; None: no history
        self._prev_center: tuple = (0.0, 0.0, 0.0)
        self._frame = 0
        self.downsample_prog = shader_loader.compute(ctx, "cube_light/cube_light_downsample.comp.glsl")

    def io(self, settings: RenderSettings) -> PassIO:
        return PassIO(reads=("scene", "scene_buffers", "lighting", "cube_map"), writes=("cube_light",))

    def _ensure(self, resolution: int, rows: int) -> bool:
        """Textures for faces of ``resolution`` texels in ``rows`` layers; False when they were
        (re)made, so that there is no history."""
        key = (resolution, rows)
        if self._key == key and self.radiance:
            return True
        self.release()
        size = face_size(resolution)
        self.face_size, self.levels = size, int(math.log2(size)) + 1
        self.gather_res = math.ceil(resolution / GATHER_BLOCK)
        for _ in range(2):
            tex = self.ctx.texture((6 * size, rows * size), 4, dtype="f2")
            tex.build_mipmaps()  # allocates every level; the passes write them
            tex.filter = (moderngl.NEAREST_MIPMAP_NEAREST, moderngl.NEAREST)
            self.radiance.append(tex)
            g = self.ctx.texture((6 * self.gather_res, rows * self.gather_res), 4, dtype="f2")
            g.filter = (moderngl.NEAREST, moderngl.NEAREST)
            self.gather.append(g)
        self._key = key
        return False

    def forget(self) -> None:
        """Drop the history: the next frame starts its feedback over (tests, a new scene),
        and its gather's random numbers with it, so that it renders as a new pass's first
        frame would, whatever this one rendered before."""
        self._key = None
        self._frame = 0

    def run(self, frame: FrameContext) -> None:
        cube = frame.read("cube_map")
        resolution = int(cube.uniforms["u_cube_res"])
        rows = cube.textures["u_cube_depth"].height // resolution
        history = self._ensure(resolution, rows)
        center = tuple(float(v) for v in frame.center)
        materials = frame.read("scene_buffers").bindings()
        # The materials' node programs run at the texels they colour (cube_light_shade.comp.glsl),
        # with the camera their Texture Coordinate Camera and Window read.
        programs = frame.read("scene_buffers").defines
        lighting = frame.read("lighting").bindings()
        common = {**cube.uniforms, **scene_bound_uniforms(SceneBounds.of(frame.read("scene"))),
                  **(frame.view.node_camera_uniforms() if programs else {}),
                  "u_cube_radiance_res": self.face_size, "u_cube_radiance_levels": self.levels,
                  "u_gather_res": self.gather_res}
        # AO Distance 0 lights every surface by the whole sky (RenderSettings): then the
        # texels see it all, and no ray looks for what hides it or what it bounces.
        gathered = frame.settings.ao_distance > 0.0
        gathers = 1 if history or not gathered else WARMUP
        for k in range(gathers):
            # Swap: the previous frame's (or warm-up step's) atlas and gather become the history.
            self.radiance.reverse()
            self.gather.reverse()
            blend = BLEND if history else 1.0 / (k + 1)
            if gathered:
                self._gather(cube, materials, common, center, history or k > 0, blend,
                             frame.read("lighting").emitter_links)
            self._shade(cube, materials, lighting, {**common, "u_gathered": int(gathered)},
                        {**frame.read("lighting").defines, **programs})
            self._prev_center = center
        self._downsample()
        frame.write("cube_light", self.lit(rows))

    def _gather(self, cube, materials, common: dict, center: tuple, history: bool, blend: float,
                links) -> None:
        # The emissive objects' linking (passes/emitters/emitter_links.py): a linked emitter's
        # light bounces only onto the texels of its receivers.
        defines = {**cube.defines, **links.defines}
        prog = shader_loader.compute(self.ctx, "cube_light/cube_light_gather.comp.glsl", defines or None)
        bind(prog, materials, links.bindings(), storage={}, textures={**cube.textures, "u_cube_radiance": self.radiance[1],
                                                     "u_gather_prev": self.gather[1]},
             images={"u_gather": Image(self.gather[0], read=False, write=True)},
             uniforms={**common, "u_prev_center": self._prev_center if history else center,
                       "u_history": int(history), "u_blend": float(blend), "u_frame": self._frame})
        self._frame += 1
        g = self.gather[0]
        prog.run(math.ceil(g.width / WORKGROUP), math.ceil(g.height / WORKGROUP), 1)
        self.ctx.memory_barrier(moderngl.TEXTURE_FETCH_BARRIER_BIT | moderngl.SHADER_IMAGE_ACCESS_BARRIER_BIT)

    def _shade(self, cube, materials, lighting, common: dict, lighting_defines: dict) -> None:
        defines = {**cube.defines, **lighting_defines}  # light linking
        prog = shader_loader.compute(self.ctx, "cube_light/cube_light_shade.comp.glsl", defines or None)
        bind(prog, materials, lighting, textures={**cube.textures, "u_gather": self.gather[0]},
             images={"u_radiance": Image(self.radiance[0], read=False, write=True, level=0)},
             uniforms=common)
        r = self.radiance[0]
        prog.run(math.ceil(r.width / WORKGROUP), math.ceil(r.height / WORKGROUP), 1)
        self.ctx.memory_barrier(moderngl.TEXTURE_FETCH_BARRIER_BIT | moderngl.SHADER_IMAGE_ACCESS_BARRIER_BIT)

    def _downsample(self) -> None:
        texture = self.radiance[0]
        prog = self.downsample_prog
        for level in range(1, self.levels):
            cells = (texture.width >> level, texture.height >> level)
            bind(prog, images={"u_finer": Image(texture, read=True, write=False, level=level - 1),
                               "u_coarser": Image(texture, read=False, write=True, level=level)},
                 uniforms={"u_size": cells, "u_from_base": int(level == 1)})
            prog.run(math.ceil(cells[0] / WORKGROUP), math.ceil(cells[1] / WORKGROUP), 1)
            self.ctx.memory_barrier(moderngl.SHADER_IMAGE_ACCESS_BARRIER_BIT)
        self.ctx.memory_barrier(moderngl.TEXTURE_FETCH_BARRIER_BIT | moderngl.SHADER_IMAGE_ACCESS_BARRIER_BIT)
        storage_barrier(self.ctx)

    def lit(self, rows: int) -> LitCubeMap:
        """The current atlas, as the tracer binds it."""
        return LitCubeMap(defines={"LIT_CUBE": 1}, textures={"u_cube_radiance": self.radiance[0]},
                          uniforms={"u_cube_radiance_res": self.face_size, "u_cube_radiance_levels": self.levels})

    def read_level(self, level: int = 0) -> np.ndarray:
        """The current atlas's ``level`` as float32 (H, W, 4) (tests, diagnostics)."""
        texture = self.radiance[0]
        w, h = max(texture.width >> level, 1), max(texture.height >> level, 1)
        data = np.frombuffer(texture.read(level=level), np.float16).astype(np.float32)
        return data.reshape(h, w, 4)

    def release(self) -> None:
        for tex in (*self.radiance, *self.gather):
            tex.release()
        self.radiance, self.gather = [], []
        self._key = None
