# SPDX-License-Identifier: GPL-3.0-or-later
"""The interactive viewport (Rendered shading): Blender-facing glue, kept thin.

``HybridRTRenderEngine.view_update`` and ``view_draw`` forward here. The work is split so
that everything but the final texture draw runs in tests without a window:

- ``ViewportSession.update(depsgraph)``: what ``view_update`` does. Reads
  ``depsgraph.updates`` and refreshes the per-object extraction cache (``scene_cache``):
  only changed geometry is read again, moved objects only get new world arrays.
- ``ViewportSession.frame(region, settings)``: what ``view_draw`` does up to the draw. Turns
  the region's matrices into a ``ViewportView`` (``hybrid_engine.frame.views``), renders it
  with the session's ``Renderer`` at ``viewport_scale`` and returns the image, where it goes
  in the region and the statistics line. It never raises: a failing frame comes back with
  an error message (printed to the console once) and the next frame is tried afresh.
- ``_draw_frame``: the only code that needs Blender's ``gpu`` module. It uploads the image
  as a ``gpu.types.GPUTexture`` and draws it with ``engine.bind_display_space_shader`` so
  Blender's colour management (view transform, look, exposure) applies, as for its own
  engines.

The image is rendered by our own OpenGL context (EGL, see ``hybrid_engine.gpu.gl_context``),
read back to numpy and uploaded through ``gpu``; Blender's drawing never shares GL objects
with it. This readback path therefore works whatever GPU backend Blender itself draws with
(OpenGL, Vulkan or Metal): ``gpu`` accepts a float buffer on all of them.

State outlives engine instances (Blender creates a new viewport engine when the shading
mode or the engine changes): sessions live at module level, one per view layer, each with
its own ``Renderer`` (GL buffers, targets, shaders on the shared context) and scene cache.
They are freed explicitly by ``release_all()`` on unregister and when a file is loaded,
never by an engine's ``__del__`` (not called reliably, and possibly on another thread).
"""
from __future__ import annotations

import logging
import time
import traceback
from dataclasses import dataclass, replace

import bpy
import numpy as np

from ..hybrid_engine.frame.accumulation import DEFAULT_FILTER_WIDTH, SampleSchedule
from ..hybrid_engine.frame.antialias import jittered_camera
from ..hybrid_engine.frame.camera_effects import aperture_uv, lens_camera
from ..hybrid_engine.frame.film import FrameOutputs
from ..hybrid_engine.gpu.gl_context import GLUnavailableError
from ..hybrid_engine.frame.near_budget import NearCubeSizer
from ..hybrid_engine.reports.diagnostic_legend import draw_legend
from ..hybrid_engine.scene.settings import RenderSettings
from ..hybrid_engine.scene.scale import auto_near_size, near_limits
from ..hybrid_engine.frame.viewport import RegionInput, accumulation_key, plan_frame
from ..hybrid_engine.frame.viewport_status import FrameClock, MessageLatch, StatsRefresh, stats_line
from . import effective_values, features, messages, properties
from .export.camera import camera_from_scene, thin_lens_from_scene
from .gl_host import gl_block
from .scene_cache import Changes, SceneCache, SyncReport

log = logging.getLogger(__name__)

ERROR_PREFIX = "Hybrid RT viewport"


@dataclass
class ViewportFrame:
    """One frame for ``view_draw``: ``image`` (H, W, 4) float32 linear, row 0 at the bottom,
    to be stretched over ``rect`` = (x0, y0, x1, y1) region pixels; ``error`` is set (and
    ``image`` may be None) when the frame failed; ``stats`` is the line for the header.
    ``image`` is the session's read-back array, overwritten by the next frame (a redraw
    allocates nothing): copy it to keep it."""

    image: np.ndarray | None
    rect: tuple[int, int, int, int]
    stats: str
    error: str | None = None
    mode: str = ""
    counts: dict | None = None
    converged: bool = True  # False: more samples are due, so the viewport asks for a redraw


class ViewportSession:
    """Scene cache + renderer of one view layer's viewports (see module docstring)."""

    def __init__(self, renderer_factory=None) -> None:
        self.cache = SceneCache()
        self._renderer_factory = renderer_factory
        self.renderer = None
        self.clock = FrameClock()
        # The header's counts are a read-back: taken only when the line refreshes.
        self.stats_refresh = StatsRefresh()
        self._counts: dict = {}
        self._last_mode = ""
        self.latch = MessageLatch()
        self.features_told: set[str] = set()  # feature messages of the last update
        self.last_sync: SyncReport | None = None
        self.frames = 0
        self._last: ViewportFrame | None = None
        # Samples of the view while nothing changes (accumulation.py; their mean is kept on
        # the GPU); every view_update is a change of the scene and starts them over.
        self.schedule = SampleSchedule()
        self.readback = None  # the frame's one read-back (frame/readback.py), with the renderer
        # Frame Budget: the near cube sized from this viewport's frame times (later samples
        # of a view reuse the cube map and BVH, so only first samples are timed).
        self.sizer = NearCubeSizer()
        self.scene_version = 0

    # -- view_update -----------------------------------------------------------------------
    def update(self, depsgraph, *, full: bool = False) -> SyncReport:
        """Apply ``depsgraph.updates`` to the cache (``full`` re-reads every mesh)."""
        report = self.cache.sync(depsgraph, Changes.from_updates(depsgraph.updates), full=full)
        self.last_sync = report
        self.scene_version += 1
        return report

    # -- view_draw -------------------------------------------------------------------------
    def frame(self, region: RegionInput, settings: RenderSettings, *, transparent: bool = False,
              filter_width: float = DEFAULT_FILTER_WIDTH) -> ViewportFrame:
        """Render one frame of ``region`` (never raises; see ``ViewportFrame.error``);
        ``transparent``: the film's transparency, the background drawn through (alpha 0);
        ``filter_width``: the pixel filter the accumulated samples are spread over."""
        start = time.perf_counter()
        rect = (0, 0, int(region.width), int(region.height))
        try:
            plan = plan_frame(region, settings.viewport_scale)
            rect = plan.rect
            settings = self.sizer.settings_for_frame(settings, self.cache.scene_data)
            if plan.view is None:
                return ViewportFrame(None, rect, f"{ERROR_PREFIX} | render border outside the view")
            key = (accumulation_key(plan.view, settings, self.scene_version, transparent), filter_width,
                   region.lens)
            self.schedule.filter_width = filter_width
            target = settings.viewport_samples
            if not self.schedule.wants(key, target) and self._last is not None:
                return self._unchanged(rect)  # nothing changed: no render
            index = self.schedule.count
            view = jittered_camera(plan.view, *self.schedule.offset())
            if region.lens is not None and region.lens.active:  # each redraw from its aperture point
                view = lens_camera(view, region.lens, region.lens.aperture_point(*aperture_uv(index)))
            # The header's counts only when it refreshes (or shows another mode).
            counted = self.stats_refresh.due() or settings.mode != self._last_mode
            with gl_block():
                result = self._render(view, settings, FrameOutputs(transparent=transparent), index, counted)
                if self.readback.image is None:  # nothing of this size on the host yet
                    self.readback.collect(wait=True)
                # The GPU's counts are read while our context is current: outside this block
                # another one may be (Blender's, after an EEVEE render), and the read would fail.
                counts = dict(result.counts) if counted else result.counts.host
            self.schedule.advance()
            effective_values.remember(getattr(result, "effective", None))  # for the panels (Automatic settings)
            if index == 0:
                self.sizer.observe(result.total_ms, settings)
            image = self.readback.image
            draw_legend(image, result.legend)  # a diagnostic view's legend, over the mean
        except Exception as exc:  # noqa: BLE001 - a viewport frame must never raise
            self.schedule.restart()
            return self._failed(exc, rect)
        self.latch.clear()  # a later failure is news again
        self.frames += 1
        fps = self.clock.tick()
        frame_ms = (time.perf_counter() - start) * 1e3
        size = (plan.view.width, plan.view.height)
        samples = f"sample {self.schedule.count}/{target}"
        if settings.near_cube_mode == "BUDGET":
            samples += f" | near {settings.near_size:.2f}"
        # The host's counts every frame (they cost nothing); the GPU's when the line refreshes.
        self._counts = {**self._counts, **counts}
        self._last_mode = result.mode
        stats = stats_line(result.mode, frame_ms, fps, self._counts, size, samples=samples)
        self._last = ViewportFrame(image, rect, stats, mode=result.mode, counts=dict(self._counts),
                                   converged=self.schedule.count >= target and not self.readback.pending)
        return self._last

    def _unchanged(self, rect) -> ViewportFrame:
        """The last frame again, with the view's newest mean once an asynchronous read-back
        has brought it (converged only then)."""
        if self.readback is not None and self.readback.pending:
            with gl_block():
                self.readback.collect(wait=True)
            self._last = replace(self._last, image=self.readback.image)
        return replace(self._last, rect=rect, converged=True)

    def _render(self, view, settings: RenderSettings, outputs: FrameOutputs, sample: int = 0,
                statistics: bool = True):
        """Render sample ``sample`` of the view with the scene's mode (later samples keep
        the first's cube map and BVH); ``statistics``: copy the GPU's counts for reading."""
        renderer = self._ensure_renderer()
        if self.readback is None:
            from ..hybrid_engine.frame.readback import ImageReadback

            self.readback = ImageReadback(renderer.ctx)
        return renderer.render(self.cache.scene_data, view, settings, timing=False, outputs=outputs,
                               sample=sample, reuse_world=sample > 0, accumulate=True, readback=self.readback,
                               statistics=statistics, denoise=settings.denoise_viewport)

    def _ensure_renderer(self):
        if self.renderer is None:
            if self._renderer_factory is not None:
                self.renderer = self._renderer_factory()
            else:
                from ..hybrid_engine.frame.renderer import Renderer

                self.renderer = Renderer()
        return self.renderer

    def _failed(self, exc: Exception, rect) -> ViewportFrame:
        if isinstance(exc, GLUnavailableError):
            message = f"{ERROR_PREFIX}: {exc}"
        else:
            message = f"{ERROR_PREFIX}: {type(exc).__name__}: {exc}"
        self._tell(message, exc, unexpected=not messages.is_artist_error(exc))
        return ViewportFrame(None, rect, message, error=message)

    def _tell(self, message: str, exc: Exception, *, unexpected: bool) -> None:
        """Print a message (with the traceback of unexpected errors) once, not every redraw."""
        if self.latch.first_time(message):
            print(message)
            if unexpected:
                traceback.print_exception(exc)

    def release(self) -> None:
        """Free the session's GL objects (the shared context stays) and its cached arrays."""
        renderer, self.renderer = self.renderer, None
        readback, self.readback = self.readback, None
        if renderer is not None:
            with gl_block():
                if readback is not None:
                    readback.release()
                renderer.release()
        self.cache.reset()


# ---------------------------------------------------------------------------------------
# Sessions (module level: they outlive engine instances)
# ---------------------------------------------------------------------------------------
_sessions: dict[tuple, ViewportSession] = {}


def session_key(depsgraph) -> tuple:
    return (depsgraph.scene.original.as_pointer(), depsgraph.view_layer.name)


def session_for(depsgraph) -> ViewportSession:
    key = session_key(depsgraph)
    session = _sessions.get(key)
    if session is None:
        session = _sessions[key] = ViewportSession()
    return session


def budgeted_settings(scene, settings: RenderSettings, scene_data=None) -> RenderSettings:
    """A final render's settings: with *Frame Budget*, the near size this scene's viewport
    settled on, else the near size (Automatic: from ``scene_data``, the core's scene) held
    within the budget's limits."""
    if settings.near_cube_mode != "BUDGET":
        return settings
    near_min, near_max = near_limits(settings, scene_data)
    pointer = scene.original.as_pointer()
    sizes = [session.sizer.size for key, session in _sessions.items()
             if key[0] == pointer and session.sizer.size is not None]
    start = settings.near_size if settings.near_size > 0.0 else auto_near_size(scene_data)
    size = sizes[0] if sizes else min(max(start, near_min), near_max)
    return replace(settings, near_size=size, near_min=near_min, near_max=near_max)


def release_all() -> None:
    """Free every session (unregister, file load). Errors in one do not keep others alive."""
    while _sessions:
        _key, session = _sessions.popitem()
        try:
            session.release()
        except Exception:  # noqa: BLE001 - teardown must finish
            traceback.print_exc()


# ---------------------------------------------------------------------------------------
# The two engine callbacks (HybridRTRenderEngine forwards here)
# ---------------------------------------------------------------------------------------
def view_update(engine, context, depsgraph) -> None:
    """``RenderEngine.view_update``: sync the cache with this depsgraph's changes."""
    session = session_for(depsgraph)
    # A new engine instance may have missed updates consumed by none: read everything once.
    first = not getattr(engine, "_hybrid_rt_synced", False)
    with messages.collecting() as gathered:
        session.update(depsgraph, full=first)
        with messages.collecting() as feature_messages:
            # Settings alone on every update; the walk over objects on the first sync only.
            features.tell_used_features(depsgraph.scene, depsgraph, final=first)
    engine._hybrid_rt_synced = True
    # Reported when found: a sync re-reads only what changed, so a missing image is told
    # when its material is read, not on every redraw; a feature in use is told when it
    # comes into use, not on every update while it stays on.
    told, session.features_told = session.features_told, set(feature_messages)
    messages.report_all(engine.report, [m for m in gathered if m not in feature_messages or m not in told])


_callback_latch = MessageLatch()


def callback_failed(engine, where: str, exc: Exception) -> None:
    """An exception reached an engine callback: show it in the header, print it (with its
    traceback) once rather than on every redraw, and report it to the user once."""
    message = f"{ERROR_PREFIX} ({where}): {type(exc).__name__}: {exc}"
    try:
        engine.update_stats("", message)
        if _callback_latch.first_time(message):
            if not messages.is_artist_error(exc):
                traceback.print_exception(exc)
            engine.report({"ERROR"}, message)
    except Exception:  # noqa: BLE001 - reporting itself must not raise into Blender
        log.exception("could not report a viewport error")


def region_input(context, depsgraph) -> RegionInput:
    """Copy what a frame needs from ``context.region``/``context.region_data`` (thin glue)."""
    region, rv3d, scene = context.region, context.region_data, depsgraph.scene
    perspective = rv3d.view_perspective
    camera = border = None
    if perspective == "CAMERA" and scene.render.use_border and scene.camera is not None:
        camera = camera_from_scene(scene, depsgraph)
        render = scene.render
        border = ((render.border_min_x, render.border_min_y), (render.border_max_x, render.border_max_y))
    return RegionInput(
        view_matrix=np.array(rv3d.view_matrix, np.float64),
        window_matrix=np.array(rv3d.window_matrix, np.float64),
        width=int(region.width), height=int(region.height),
        perspective=perspective, camera=camera, border=border,
        lens=thin_lens_from_scene(scene, depsgraph) if perspective == "CAMERA" else None,
    )


def view_draw(engine, context, depsgraph) -> None:
    """``RenderEngine.view_draw``: render the region's view and draw it."""
    session = session_for(depsgraph)
    if not session.cache.synced:  # view_draw before any view_update (e.g. after reload)
        view_update(engine, context, depsgraph)
    try:
        settings = properties.settings_from_scene(depsgraph.scene)
        region = region_input(context, depsgraph)
    except Exception as exc:  # noqa: BLE001 - bad settings or camera: show it, keep drawing
        frame = session._failed(exc, (0, 0, context.region.width, context.region.height))
    else:
        render = depsgraph.scene.render
        frame = session.frame(region, settings, transparent=bool(render.film_transparent),
                              filter_width=float(render.filter_size))
    engine.update_stats("", frame.stats)
    _draw_frame(engine, depsgraph.scene, frame)
    if not frame.converged:
        engine.tag_redraw()  # the next sample of the same view


def _draw_frame(engine, scene, frame: ViewportFrame) -> None:
    """Upload the frame as a GPU texture and draw it through the display transform; an
    error is written into the viewport (the only part of a frame tests cannot run)."""
    import gpu
    from gpu_extras.presets import draw_texture_2d

    x0, y0, x1, y1 = frame.rect
    if frame.image is not None:
        image = np.ascontiguousarray(frame.image, np.float32)  # the read-back array: no copy
        height, width = image.shape[:2]
        # Buffer wraps an object with the buffer protocol without copying it
        # (pygpu_buffer__tp_new in Blender's gpu_py_buffer.cc). The texture is made anew
        # each redraw, as Python's GPUTexture has no update (clear, read only); RGBA32F, the
        # data's own format, is uploaded as it is, where RGBA16F would be converted first.
        pixels = gpu.types.Buffer("FLOAT", width * height * 4, image.reshape(-1))
        texture = gpu.types.GPUTexture((width, height), format="RGBA32F", data=pixels)
        gpu.state.blend_set("ALPHA_PREMULT")
        engine.bind_display_space_shader(scene)
        try:
            draw_texture_2d(texture, (x0, y0), x1 - x0, y1 - y0)
        finally:
            engine.unbind_display_space_shader()
            gpu.state.blend_set("NONE")
    if frame.error:
        _draw_message(frame.error, x0 + 20, y1 - 40)


def _draw_message(text: str, x: int, y: int) -> None:
    import blf

    font = 0
    blf.size(font, 14)
    blf.color(font, 1.0, 0.35, 0.3, 1.0)
    for line_number, line in enumerate(_wrap(text, 110)[:6]):
        blf.position(font, x, y - 20 * line_number, 0)
        blf.draw(font, line)


def _wrap(text: str, width: int) -> list[str]:
    lines, line = [], ""
    for word in text.split():
        if line and len(line) + 1 + len(word) > width:
            lines.append(line)
            line = word
        else:
            line = f"{line} {word}" if line else word
    return lines + ([line] if line else [])


# ---------------------------------------------------------------------------------------
# Registration: free sessions when another file is loaded
# ---------------------------------------------------------------------------------------
@bpy.app.handlers.persistent
def _on_load_pre(*_args) -> None:
    release_all()


def register() -> None:
    if _on_load_pre not in bpy.app.handlers.load_pre:
        bpy.app.handlers.load_pre.append(_on_load_pre)


def unregister() -> None:
    if _on_load_pre in bpy.app.handlers.load_pre:
        bpy.app.handlers.load_pre.remove(_on_load_pre)
    release_all()
