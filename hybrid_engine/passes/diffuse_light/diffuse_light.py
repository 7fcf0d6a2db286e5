# SPDX-License-Identifier: GPL-3.0-or-later
"""The diffuse light of primary pixels, gathered by paths traced through the paper's structures.

The World lights a room only through its openings, and a wall lit by a lamp lights the room
in turn. Screen-space occlusion within a distance (passes/shading/screen_ao.py) cannot know
either: what hides the sky may lie behind the first surface, off screen or farther than its
reach, so closed rooms glow. The near-cube BVH and the cube map answer "what does this point
see in that direction" at any distance (paper §3.2-3.4), which is the question global
illumination asks: per diffuse primary pixel, ``diffuse_rays`` cosine-distributed paths of
up to ``diffuse_bounces`` bounces are traced through them as the reflections are
(``gpu_shaders/diffuse_light/diffuse_gather.comp.glsl`` with trace_ray.glsl; the hybrid
ambient occlusion of Reinbothe et al., the paper's reference [14], carried on to several
bounces). Escaping, a path takes the sky; at each surface it meets, that surface's lamp
light (shadow maps) and emission, then bounces on. A rough metal, whose reflection is too
rough to trace and which has no diffuse layer, starts its paths along its GGX lobe instead:
otherwise nothing would hide the sky from it, and indoors it would reflect the whole sky
(Sponza's curtains, metallic at roughness 1).

The pass writes the frame's ``ambient``: rgb the diffuse irradiance (demodulated, not times
the albedo, which the deferred shading applies: a denoiser may filter it without blurring
textures), a the sky's visibility. It is part of the frame's ``shade`` step, in place of the
screen-space occlusion when ``RenderSettings.traces_diffuse``. It binds what the tracer's
kernel binds (``HybridTracer.inputs``) with counters of its own, deposited in the frame's
statistics as ``gather_*`` counts (rays per path vertex).
"""
from __future__ import annotations

import math
from functools import partial
from typing import Callable

import numpy as np

from ...gpu import gl_context, shader_loader, variants
from ...gpu.bindings import Bindings, Image, bind
from ...gpu.dispatch import storage_barrier
from ...scene.settings import FIELD_LIMITS, RenderSettings
from ..frame_context import FrameContext, PassIO
from ..trace.tracer import (COUNTER_DEPTHS, COUNTER_KINDS, COUNTER_WORDS, HybridTracer, TraceStats,
                            traced_resources)
from .grazing import GrazingTriangles, grazing_defines
from .radiance_cache import RadianceCache, radiance_cache_defines

WORKGROUP = 8  # the per-pixel kernel's local size in x and y
# The persistent kernel (the "gather" kernel's GPU shape, diffuse_gather.comp.glsl
# PERSISTENT_PATHS): its local size, and how many invocations it launches at most. Each
# takes pixels from a shared counter until none are left, so more than the GPU holds at once
# only adds invocations that find the work gone; fewer would leave cores idle.
PERSISTENT_WORKGROUP = 64
PERSISTENT_INVOCATIONS = 1 << 17
# The paths per pixel, as a multiple of Diffuse Rays, where the denoiser's history holds
# nothing of the pixel's surface (diffuse_gather.comp.glsl history_paths): what the camera
# just uncovered, a moving object, the denoiser's first frame (a setting changed). Twice: four
# times cost a GPU's Chess frame five times what twice does (5 ms against 1 on an H200), for
# a small gain in the noise (docs/BENCHMARKS.md).
SHORT_HISTORY_PATHS = 2
# HYBRID's diffuse paths test the near cube's grazing triangles along the whole ray, not only
# inside the near cube (trace_ray.glsl BVH_WHOLE_RAY, grazing.py): a camera against a wall
# otherwise lets the sky in through it. A switch for benchmarks.
BVH_WHOLE_RAY = True


def short_history_paths(rays: int) -> int:
    """SHORT_HISTORY_PATHS for ``rays`` Diffuse Rays, lowered so that no pixel traces more
    paths in a frame than the setting's highest value would (16): a view set to many rays
    already converges fast, and more of its paths would stall its first frame."""
    most_rays = FIELD_LIMITS["diffuse_rays"][1]
    return max(1, min(SHORT_HISTORY_PATHS, most_rays // max(int(rays), 1)))
SHADER = "diffuse_light/diffuse_gather.comp.glsl"


def persistent_groups(width: int, height: int) -> int:
    """Workgroups of the persistent kernel for a width x height image: one invocation per
    pixel of its 8x8 tiles, at most PERSISTENT_INVOCATIONS."""
    items = math.ceil(width / 8) * math.ceil(height / 8) * 64
    return max(1, math.ceil(min(items, PERSISTENT_INVOCATIONS) / PERSISTENT_WORKGROUP))


def gather_counts(bounces: int, words: np.ndarray) -> dict[str, int]:
    """The kernel's counters as ``gather_*`` counts: ``gather_rays_traced`` and the others of
    tracer.COUNTER_KINDS, in total and per path vertex (``..._bounce_1`` the primary's rays)."""
    raw = np.asarray(words, np.uint32).reshape(len(COUNTER_KINDS), COUNTER_DEPTHS)
    vertices = range(1, int(bounces) + 2)  # a path's rays: the primary's, then one per bounce
    counts = TraceStats({kind: [int(raw[k, d]) for d in vertices]
                         for k, kind in enumerate(COUNTER_KINDS)}).as_counts()
    return {f"gather_{name}": value for name, value in counts.items()}


class DiffuseLightPass:
    """The diffuse-light kernel and its counters (the frame's ``shade`` step, before the
    deferred shading)."""

    name = "shade"

    def __init__(self, tracer: HybridTracer, feedback: Callable[[], Bindings | None] | None = None,
                 gather_seed: int = 0) -> None:
        self.tracer = tracer
        # Last frame's diffuse light where the camera saw it (the denoiser's history,
        # DenoisePass.feedback), or None: paths that end on such a surface take its light
        # instead of none, so bounces beyond the last traced one build up over frames.
        self.feedback = feedback
        self.ctx = tracer.ctx
        self._counters = self.ctx.buffer(reserve=COUNTER_WORDS * 4)
        self._zero_counters = bytes(self._counters.size)
        self._work = self.ctx.buffer(reserve=4)  # the persistent kernel's next pixel
        self.grazing = GrazingTriangles(self.ctx)
        # The paths' world-space radiance cache (radiance_cache.py), made on the first
        # denoised frame that uses it; it lives as long as the denoiser's history.
        self.cache: RadianceCache | None = None
        # Which set of numbers the paths draw (diffuse_gather.comp.glsl u_gather_seed): 0 the
        # product's; a measurement takes others to average its figures over several.
        self.gather_seed = int(gather_seed)

    def io(self, settings: RenderSettings) -> PassIO:
        return PassIO(reads=("scene", "scene_buffers", "world_triangles", "gbuffer", "lighting", "emitters", "delta",
                             *traced_resources(settings)),
                      writes=("ambient",), optional=("surface_motion",))

    def run(self, frame: FrameContext) -> None:
        settings = frame.settings
        inputs = self.tracer.inputs(frame, gather=True)
        targets = frame.read("gbuffer")
        # Emissive triangles are sampled towards (next-event estimation) only where some emit:
        # a scene without them runs the kernel without the emitters' code.
        emitters = frame.read("emitters")
        emitter_parts = (emitters.bindings(),) if emitters.count else ()
        defines = {**inputs.defines, **emitters.defines}
        storage = {**inputs.storage, "CounterBuffer": self._counters}
        if settings.trace_mode == "HYBRID":
            # A path that passes beside a surface into the space the cube map cannot see
            # takes the point where it leaves the scene's bounds, not that surface's
            # camera-facing side (cube_march.glsl "Hidden sides"). The diffuse paths only:
            # the tracer's mirror and glass rays stay the paper's.
            defines["CUBE_HIDDEN_SIDE"] = 1
            # The near cube's triangles reach beyond it: a path that leaves from outside
            # the near cube meets those the cube map sees edge-on (grazing.py), wherever it
            # crosses them (trace_ray.glsl).
            if BVH_WHOLE_RAY:
                defines.update(BVH_WHOLE_RAY=1, **grazing_defines())
                storage.update(self.grazing.collect(frame.read("bvh"), frame.center, settings.near_size))
                self.grazing.deposit(frame.statistics)
        history = self.feedback() if self.feedback is not None and settings.diffuse_bounces > 0 else None
        if history is not None:
            defines["DIFFUSE_FEEDBACK"] = 1
            if settings.bounce_feedback:
                defines["BOUNCE_FEEDBACK"] = 1
            emitter_parts = (*emitter_parts, history)
            # A moved instance's pixels find their history where they stood last frame, as
            # the denoiser finds it (passes/surface_motion/; a denoised frame's).
            motion = frame.read_optional("surface_motion")
            if motion is not None and motion.moving:
                defines["SURFACE_MOTION"] = 1
                emitter_parts = (*emitter_parts, Bindings(textures={"u_motion": motion.texture,
                                                                     "u_motion_turn": motion.turn}))
        elif frame.denoise:
            # The denoiser's first frame: no pixel has a history (history_paths).
            defines["DIFFUSE_NO_HISTORY"] = 1
        width, height = inputs.size
        cache = self._radiance_cache(frame, history is not None, height)
        if cache is not None:
            defines.update(RADIANCE_CACHE=1, **radiance_cache_defines())
            emitter_parts = (*emitter_parts, cache.bindings(height))
        uniforms = {**inputs.uniforms, "u_diffuse_bounces": int(settings.diffuse_bounces),
                    "u_diffuse_rays": int(settings.diffuse_rays),
                    "u_short_history_paths": short_history_paths(settings.diffuse_rays),
                    "u_gather_seed": int(self.gather_seed)}
        persistent = variants.choose("gather", renderer=str(self.ctx.info.get("GL_RENDERER", ""))) == "gpu"
        if persistent:
            groups = persistent_groups(width, height)
            defines["PERSISTENT_PATHS"] = 1
            storage["PathWork"] = self._work
            uniforms["u_invocations"] = groups * PERSISTENT_WORKGROUP
            self._work.write(bytes(4))
        prog = shader_loader.compute(self.ctx, SHADER, defines)
        self._counters.write(self._zero_counters)
        bounces = int(settings.diffuse_bounces)
        assert bounces <= FIELD_LIMITS["diffuse_bounces"][1]
        bind(prog, *inputs.parts, *emitter_parts, storage=storage,
             textures=inputs.textures, images={"u_ambient": Image(targets.ambient, read=False, write=True)},
             uniforms=uniforms)
        if persistent:
            prog.run(groups, 1, 1)
        else:
            prog.run(math.ceil(width / WORKGROUP), math.ceil(height / WORKGROUP), 1)
        storage_barrier(self.ctx)
        if cache is not None:
            cache.resolve()
        if gl_context.debug_checks_enabled():
            gl_context.check_error(f"{settings.trace_mode} diffuse light")
        frame.statistics.deposit(self._counters, COUNTER_WORDS, partial(gather_counts, bounces))
        frame.write("ambient", targets.ambient)

    def _radiance_cache(self, frame: FrameContext, has_history: bool, height: int) -> RadianceCache | None:
        """The radiance cache, where this frame uses it: a denoised frame whose paths bounce,
        with the setting on. The cells start over where the denoiser's history holds nothing
        (its first frame, or one after a frame without it): that frame's paths fill them,
        and the next frame's count them. They also start over where the light changed (a
        lamp, the World, a material, an object moved or deformed: the cells would go on giving
        the old light to the pixels that count them, those whose history is short), or what a cell
        is (Diffuse Bounces, which its paths trace; the image's height, which sizes it).
        Such a frame neither reads nor fills them: while an object moves, every frame would
        empty what the last one filled. With Bounce Feedback a first frame does not fill
        them either: its paths find no fed-back light where they end, and the cells would
        keep that darker light for as many frames as they hold."""
        settings = frame.settings
        if not (frame.denoise and settings.radiance_cache and settings.diffuse_bounces > 0):
            if self.cache is not None:
                self.cache.forget()
            return None
        if self.cache is None:
            self.cache = RadianceCache(self.ctx)
        cache = self.cache
        lighting = frame.read("lighting")
        key = (lighting.lamp_updates, lighting.sky.updates,
               frame.read("scene_buffers").materials_version, settings.diffuse_bounces, height)
        changed = not frame.read("delta").unchanged or key != cache.key
        cache.key = key
        if not has_history:
            cache.forget()
            return None if settings.bounce_feedback else cache
        if changed:
            cache.forget()
            return None
        return cache

    def release(self) -> None:
        if self.cache is not None:
            self.cache.release()
        self._counters.release()
        self._work.release()
        self.grazing.release()
