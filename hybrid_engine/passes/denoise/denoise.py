# SPDX-License-Identifier: GPL-3.0-or-later
"""The ``denoise`` pass: a real-time spatio-temporal filter of the frame's ambient estimate,
after Schied et al. 2017 (Spatiotemporal Variance-Guided Filtering, SVGF), the family of
EEVEE Next's and most real-time path tracers' denoisers.

The ambient estimate (the G-buffer's ``ambient`` target: rgb diffuse irradiance, a the sky's
visibility) comes from a few rays or screen-space points per pixel and is noisy; the
deferred shading multiplies it by the albedo. Three compute steps filter it, every one on
the GPU (gpu_shaders/denoise/):

1. ``reproject``: each pixel finds where its surface point was in last frame's image through
   the camera's motion and its instance's (passes/surface_motion/: a moving object keeps
   its history, what it uncovers starts over) and blends with it; a pixel whose point was
   not seen (another depth, normal or material there) starts over. A still
   or moving camera thus gathers frames for every surface it keeps seeing, where the film
   (passes/film/) starts over at any change.
2. ``variance``: how noisy each pixel is, from the temporal moments, or from its
   neighbours' where its history is short.
3. ``atrous`` (``ITERATIONS`` levels): an edge-avoiding wavelet filter guided by depth,
   normal and that variance; its two coarsest levels fit a plane through their taps
   (``LINEAR_FIT``, ``LINEAR_LEVELS``), so that where the edges cut a kernel off on one side
   (a corner, a partition, the image's border) the light's gradient is not shifted by the
   kernel's width. Blurring irradiance rather than colour keeps textures sharp (the albedo
   multiplies after), and reflections and refractions, which the tracer adds to the colour,
   are never touched.

What the next frame reprojects is the temporal blend, not a filtered level as in SVGF (whose
history, filtered again every frame, keeps blurring a still view); instead the variance that
guides the filter is the variance of that blend's mean, which shrinks as the history grows,
so a view that stays still converges to the unfiltered mean while a moving one is filtered
hard where its history is short.

A frame that joins the film's mean of a still view (``FrameContext.accumulate``: the
viewport's redraws, a final render's samples) shows that mean, not the frame. While the
temporal blend is the plain mean of a still view's frames (its first ``FILM_SHARE_SAMPLES``,
1 / ALPHA_COLOR), the film's mean of the filtered means would weigh the first, noisiest and
most filtered frames most; the pass writes instead its share of the film's mean
(gpu_shaders/denoise/film_share.comp.glsl), so that the film shows the latest filtered
estimate itself. After that the film averages the frames as they come: their blends no
longer narrow (the exponential average's floor), and the film's mean goes on converging. The
pass writes the filtered estimate as the frame's ``ambient`` (a texture of its own; the
G-buffer's stays as it came), which the deferred shading then takes as it is, without its
own 3x3 smoothing.

A view that comes to rest (the film's second sample of one view, after the camera moved or
the scene changed) brings the history of its motion: many frames, each resampled from the
last and lagging the light. Counted at its length, that history keeps the diffuse gather,
which traces short paths and reads the radiance cache only where a history is short
(passes/diffuse_light/radiance_cache.py), from treating the resting view's pixels as new,
and a view stopped after a slide converged more slowly than one that starts from nothing
(docs/BENCHMARKS.md, "A view that comes to rest"). Its length is cut to ``REST_FRAMES``
then: the gather treats the pixels as new ones for the frames a new history gets, and the
blend takes the rest's frames as a mean with those (to the exponential average's floor).
"""
from __future__ import annotations

import math

import moderngl
import numpy as np

from ...gpu import shader_loader
from ...gpu.bindings import Bindings
from ...gpu.bindings import Image, bind
from ...scene.raster_view import RasterView
from ...scene.settings import RenderSettings
from ..frame_context import FrameContext, PassIO
from ..surface_motion.surface_motion import SurfaceMotion
from .history import DenoiseHistory

WORKGROUP = 8
# The wavelet filter's levels: steps 1, 2, 4, 8 reach 16 pixels either side.
ITERATIONS = 4
# The temporal blend's floor (SVGF: 0.05-0.2): the share of each new frame once the history
# is long. Lower is smoother and lags more behind a changing light (which takes
# ALPHA_COLOR_CHANGING while it changes).
ALPHA_COLOR = 0.07
# The floor while the scene's light changes: an instance moves (passes/surface_motion/: its
# shadow, the light it passes on move with it), a lamp or the World changes (an artist's
# edit, a lamp switched off). A long history lags behind such a change. A camera that moves
# over a still scene keeps ALPHA_COLOR: its view shows the same room's light. (It once took
# this floor too, while the surfaces entering a moving view stayed dark for frames; since a
# short history traces more paths, the lower floor gives the cleaner moving frames, in the
# bounce-lit room and the daylit one alike: docs/BENCHMARKS.md.)
ALPHA_COLOR_CHANGING = 0.25
# Frames that keep ALPHA_COLOR_CHANGING after the last change, so that the old light is gone
# (0.75^8: a tenth of it left) before the lower floor smooths again.
CHANGE_FRAMES = 8
ALPHA_MOMENTS = 0.2
# A history longer than this counts as this long (alpha is at its floor long before).
MAX_LENGTH = 64.0
# The frames that the history a view brings to its rest counts as, at most (module
# docstring, "A view that comes to rest"). Eight measured best after 8 and 16 samples of a
# view stopped after a slide, in the bounce-lit room and the daylit one; four or fewer left
# its first samples noisier, twelve kept the slide's light longer (docs/BENCHMARKS.md).
REST_FRAMES = 8
# Below this history length the variance is estimated from the neighbours (SVGF: 4).
MIN_LENGTH = 4.0
# Reprojection: last frame's point must lie within this share of the camera distance of
# this pixel's tangent plane, with a normal within arccos(NORMAL_COS) (about 25 degrees).
PLANE_TOLERANCE = 0.02
NORMAL_COS = 0.9
# How the reprojection fetches the history between last frame's texels: "catmull_rom" (a
# sharp cubic over 4x4 texels, held within the inner four's range, bilinear where a tap
# shows another surface) or "bilinear". A moving camera resamples the history every frame
# at some sub-pixel shift; the bilinear fetch blurs it a little each time and the blurs add
# up over the history's length, which softens the light's true gradients (its shadows' edges).
HISTORY_FILTER = "catmull_rom"
# The wavelet filter's edge stops: plane offset (share of the camera distance) and standard
# deviations of the guides; the normal's power is SVGF's 128 (include/denoise.glsl). SVGF's
# sigma_l is 4, for noise that is roughly symmetric; the paths' light is skewed (a few
# bright paths among many dim ones) and a stop that narrow keeps the bright ones out of
# their neighbours' means: the image loses energy. A wide stop leaves the edges to the
# geometry's stops (plane, normal) and to the albedo, which the filter never sees.
PLANE_SIGMA = 0.01
SIGMA_GUIDE = 16.0
# The coarsest levels fit a plane through their taps instead of taking their mean
# (atrous.comp.glsl): where the stops cut a kernel off on one side, its mean is the light of a
# place up to twice its step away, and the levels' shifts add up along every corner.
# LINEAR_LEVELS counts the levels that fit one, from the coarsest. Two: the finest levels'
# few taps fit slopes of the paths' noise, which the Wiener gain lets through in part, and
# with a plane at every level a bounce-lit room's blocks of pixels stray further from its
# converged light (docs/BENCHMARKS.md). LINEAR_FIT is a switch for benchmarks.
LINEAR_FIT = True
LINEAR_LEVELS = 2
# The film's samples of a still view during which the temporal blend is their plain mean
# (1 / n >= ALPHA_COLOR): the pass writes its share of the film's mean (module docstring).
FILM_SHARE_SAMPLES = round(1.0 / ALPHA_COLOR)


class DenoisePass:
    """Filters the frame's ``ambient`` (module docstring); keeps its history across frames."""

    name = "denoise"

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.reproject = shader_loader.compute(ctx, "denoise/reproject.comp.glsl")
        self.variance = shader_loader.compute(ctx, "denoise/variance.comp.glsl")
        self.atrous = shader_loader.compute(ctx, "denoise/atrous.comp.glsl")
        self.share = shader_loader.compute(ctx, "denoise/film_share.comp.glsl")
        self.history = DenoiseHistory(ctx)
        # The wavelet filter's levels (ITERATIONS); 0 keeps the temporal step alone, whose
        # mean over a still view's samples is unbiased: what a converged reference is made of
        # (benchmarks/light_noise.py), with the fed-back light the denoiser's history carries.
        self.levels = ITERATIONS
        # What the ambient estimate meant last frame: a history of another kind of estimate
        # (screen-space occlusion's visibility, rays' irradiance) is not blended with.
        self._estimate: tuple | None = None
        # The lamps and World of the last frame, to tell when they change, and how many more
        # frames take ALPHA_COLOR_CHANGING (CHANGE_FRAMES after the last change).
        self._lamps: tuple | None = None
        self._changing = 0
        # The film's sample whose share the last frame's estimate leads to (film_share), or None.
        self._film_next: int | None = None

    def io(self, settings: RenderSettings) -> PassIO:
        return PassIO(reads=("gbuffer", "ambient", "lighting", "surface_motion"), writes=("ambient",))

    def run(self, frame: FrameContext) -> None:
        if not frame.read("lighting").occludes:
            # No pass estimated the ambient: the shading takes the whole sky, nothing to filter.
            self.forget()
            return
        settings = frame.settings
        estimate = (settings.traces_diffuse, settings.diffuse_bounces, settings.diffuse_rays, settings.ao_distance,
                    settings.bounce_feedback)
        if estimate != self._estimate:
            self.forget()
            self._estimate = estimate
        # The lamps, and the World's light (how often the lighting recomputed it).
        lighting = frame.read("lighting")
        lamps = (lighting.lamp_updates, lighting.sky.updates)
        lamps_changed = self._lamps is not None and lamps != self._lamps
        self._lamps = lamps
        targets = frame.read("gbuffer")
        frame.write("ambient", self.filter(frame.read("ambient"), targets.depth, targets.normal_material, frame.view,
                                           frame.sample if frame.accumulate else None,
                                           frame.read("surface_motion"), lamps_changed))

    def filter(self, ambient, depth, normal_material, view: RasterView, film_sample: int | None = None,
               motion: SurfaceMotion | None = None, lamps_changed: bool = False):
        """The filtered ``ambient`` of the G-buffer (``depth``, ``normal_material``) of
        ``view``: a texture of this pass, valid until its next frame. ``film_sample``: the
        frame is that sample of the film's mean of a still view (module docstring); None: it
        is shown alone. ``motion``: the instances that moved since last frame, per pixel
        (passes/surface_motion/); ``lamps_changed``: a lamp or the World changed since last
        frame (both take ALPHA_COLOR_CHANGING, for CHANGE_FRAMES more frames)."""
        history = self.history
        history.ensure((view.width, view.height))
        work, variance = history.pair("work"), history.pair("variance")
        groups = (math.ceil(view.width / WORKGROUP), math.ceil(view.height / WORKGROUP), 1)
        camera = view.uniforms()
        moving = motion is not None and motion.moving
        # A frame that continues a film's mean keeps ALPHA_COLOR, whose first 1 / ALPHA_COLOR
        # blends are the plain mean that the film's share (FILM_SHARE_SAMPLES) relies on.
        if moving or lamps_changed:
            self._changing = CHANGE_FRAMES
        alpha = ALPHA_COLOR_CHANGING if self._changing > 0 and not film_sample else ALPHA_COLOR
        self._changing = max(self._changing - 1, 0)
        bind(self.reproject,
             textures={"u_depth": depth, "u_normal_material": normal_material, "u_ambient": ambient,
                       # Unread without motion (u_moving 0): any texture will do.
                       "u_motion": motion.texture if moving else depth,
                       "u_motion_turn": motion.turn if moving else depth,
                       **{f"u_prev_{name}": history.previous(name) for name in ("color", "moments", "surface", "length")}},
             images={"u_integrated": Image(history.current("color"), read=False, write=True),
                     **{f"u_{name}": Image(history.current(name), read=False, write=True)
                        for name in ("moments", "surface", "length")}},
             uniforms={**camera, **history.previous_uniforms(), "u_alpha_color": alpha,
                       "u_alpha_moments": ALPHA_MOMENTS, "u_plane_tolerance": PLANE_TOLERANCE,
                       "u_normal_cos": NORMAL_COS, "u_max_length": self.max_length(film_sample),
                       "u_history_filter": int(HISTORY_FILTER == "catmull_rom"), "u_moving": int(moving)})
        self._run(self.reproject, groups)
        surface = {"u_surface": history.current("surface")}
        bind(self.variance, textures={**surface, "u_moments": history.current("moments"),
                                      "u_length": history.current("length")},
             images={"u_variance": Image(variance[0], read=False, write=True)},
             uniforms={**camera, "u_min_length": MIN_LENGTH, "u_plane_sigma": PLANE_SIGMA,
                       "u_alpha_color": alpha})
        self._run(self.variance, groups)
        source, source_variance = history.current("color"), variance[0]
        for level in range(self.levels):
            target = work[level % 2]
            target_variance = variance[(level + 1) % 2]
            bind(self.atrous, textures={**surface, "u_color_in": source, "u_variance_in": source_variance,
                                        "u_length": history.current("length")},
                 images={"u_color_out": Image(target, read=False, write=True),
                         "u_variance_out": Image(target_variance, read=False, write=True)},
                 uniforms={**camera, "u_step": 1 << level, "u_plane_sigma": PLANE_SIGMA,
                           "u_sigma_guide": SIGMA_GUIDE, "u_min_length": MIN_LENGTH,
                           "u_linear": int(LINEAR_FIT and level >= self.levels - LINEAR_LEVELS)})
            self._run(self.atrous, groups)
            source, source_variance = target, target_variance
        source = self._film_share(source, work[self.levels % 2], view, groups, film_sample)
        history.advance(np.asarray(view.view_proj, np.float64))
        return source

    @staticmethod
    def max_length(film_sample: int | None) -> float:
        """The longest history this frame's blend may count (module docstring, "A view that
        comes to rest"): REST_FRAMES plus this frame in a film's second sample, whose first
        was the same view's, else MAX_LENGTH."""
        return REST_FRAMES + 1.0 if film_sample == 1 else MAX_LENGTH

    def _film_share(self, estimate, out, view: RasterView, groups: tuple[int, int, int],
                    film_sample: int | None):
        """What the film adds for ``estimate`` (module docstring): its share of the mean while
        the film's samples follow one another within FILM_SHARE_SAMPLES, else the estimate."""
        follows = film_sample is not None and film_sample < FILM_SHARE_SAMPLES and (
            film_sample == 0 or film_sample == self._film_next)
        if not follows:
            self._film_next = None
            return estimate
        history = self.history
        bind(self.share, textures={"u_estimate": estimate, "u_prev_shown": history.previous("shown")},
             images={"u_shown": Image(history.current("shown"), read=False, write=True),
                     "u_share": Image(out, read=False, write=True)},
             uniforms={"u_size": (view.width, view.height), "u_sample": float(film_sample)})
        self._run(self.share, groups)
        self._film_next = film_sample + 1
        return out

    def feedback(self) -> Bindings | None:
        """Last frame's diffuse light where the camera saw it (the temporal blend of the
        irradiance and the surface points it belongs to, and that frame's view-projection),
        for the diffuse gather's path ends (``DIFFUSE_FEEDBACK``), and how many frames the
        history holds (``u_feedback_frames``: the index whose numbers the gather draws, so
        that frames of a moving view, each its sample 0, still blend fresh paths); None
        without a history."""
        history = self.history
        if not history.valid:
            return None
        return Bindings(textures={"u_feedback_color": history.previous("color"),
                                  "u_feedback_surface": history.previous("surface"),
                                  "u_feedback_length": history.previous("length")},
                        uniforms={"u_feedback_view_proj": history.previous_uniforms()["u_prev_view_proj"],
                                  "u_feedback_size": tuple(int(v) for v in history.size),
                                  "u_feedback_frames": int(history.frames)})

    def forget(self) -> None:
        """Start every pixel over at the next frame (a frame this pass did not see, a final
        render's first sample)."""
        self.history.forget()
        self._film_next = None
        self._changing = 0

    def _run(self, program, groups: tuple[int, int, int]) -> None:
        program.run(*groups)
        # The next step samples what this one stored as images, or loads them as images.
        self.ctx.memory_barrier(moderngl.TEXTURE_FETCH_BARRIER_BIT | moderngl.SHADER_IMAGE_ACCESS_BARRIER_BIT)

    def release(self) -> None:
        self.history.release()
