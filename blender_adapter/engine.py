# SPDX-License-Identifier: GPL-3.0-or-later
"""The ``HYBRID_RT`` RenderEngine: a thin layer over ``hybrid_engine.Renderer``.

Each callback forwards to plain functions; no exception escapes a Blender callback (it is
reported to the user with ``error_set`` and the console gets the traceback). The renderer
and its GPU state live at module level because Blender creates a new engine instance for
every render; they are released on unregister.
"""
from __future__ import annotations

import time
import traceback
from dataclasses import replace
from operator import attrgetter

import bpy
import numpy as np

from ..hybrid_engine.frame import views
from ..hybrid_engine.frame.antialias import render_antialiased
from ..hybrid_engine.frame.camera_effects import CameraEffects
from ..hybrid_engine.scene.camera import Camera
from ..hybrid_engine.frame.film import FrameOutputs
from ..hybrid_engine.passes.film.light_passes import PASSES as LIGHT_PASSES
from ..hybrid_engine.passes.film.light_passes import LightPassRequest
from ..hybrid_engine.passes.film.vector import PASS as VECTOR_PASS
from ..hybrid_engine.passes.film.vector import VectorRequest
from ..hybrid_engine.frame.renderer import FrameResult, RenderCancelled, Renderer
from ..hybrid_engine.frame.near_budget import NearCubeSizer
from ..hybrid_engine.gpu import gl_context
from ..hybrid_engine.reports.diagnostic_legend import draw_legend
from ..hybrid_engine.scene import cryptomatte
from ..hybrid_engine.scene.cryptomatte import CryptomatteRequest
from ..hybrid_engine.scene.data import SceneData
from ..hybrid_engine.scene.settings import RenderSettings
from . import effective_values, features, messages, preview, properties, viewport
from .export.camera import camera_from_scene, thin_lens_from_scene
from .export.motion import frame_motion, motion_steps, shutter
from .gl_host import gl_block
from .scene_cache import Changes, SceneCache, SyncReport, TrackedScene, extract_scene

_renderer: Renderer | None = None
last_frame: FrameResult | None = None  # the most recent final render's result (image, passes, counts)
# Whether F12 times each pass (``FrameResult.passes``). Timing brackets every pass with
# ``ctx.finish()``, which drains the GPU between passes, so an artist's render does without;
# tools that print or record the per-pass times of a final render (the demo, the pictures
# script) switch it on.
time_final_renders = False
# F12's synced scene per view layer, (render depsgraph pointer, cache), kept while Persistent
# Data is on (``final_scene_data``).
_final_scenes: dict[str, tuple[int, SceneCache]] = {}
last_final_sync: SyncReport | None = None  # what the most recent F12 re-read
_final_cache: SceneCache | None = None  # the cache behind the most recent F12's scene (motion blur reads it)


def shared_renderer() -> Renderer:
    """The process's final-render Renderer (created on first use, GL state kept)."""
    global _renderer
    if _renderer is None:
        _renderer = Renderer()
    return _renderer


def final_scene_data(depsgraph) -> SceneData:
    """The scene of a final render. With Persistent Data (``render.use_persistent_data``, as in
    Cycles) Blender hands every render of a view layer the same depsgraph and its
    ``updates`` say what changed since the last: the cache kept for it re-reads only that,
    so a second F12 or the next frame of an animation render re-reads nothing that stood
    still. Without it each render reads the scene afresh and nothing is kept."""
    global last_final_sync, _final_cache
    layer = depsgraph.view_layer.name
    if not depsgraph.scene.render.use_persistent_data:
        _final_scenes.clear()
        cache, changes, full = SceneCache(), Changes(), True
    else:
        key = depsgraph.as_pointer()
        kept = _final_scenes.get(layer)
        full = kept is None or kept[0] != key
        cache = SceneCache() if full else kept[1]
        changes = Changes() if full else Changes.from_updates(depsgraph.updates)
        _final_scenes[layer] = (key, cache)
    last_final_sync = cache.sync(depsgraph, changes, full=full)
    _final_cache = cache
    return cache.scene_data


def release_renderer() -> None:
    global _renderer, _final_cache
    _final_scenes.clear()
    _final_cache = None
    if _renderer is not None:
        try:
            with gl_block():
                _renderer.release()
        finally:
            _renderer = None


# The view layer's data passes this engine writes: (property of ViewLayer, dotted for our
# own, that asks for it; Blender's pass name, channels, channel ids, pass type), as
# register_pass and the render result name them. The denoising passes are named as Cycles'
# Denoising Data names them, so a compositor setup made for Cycles finds them.
DATA_PASSES = {
    "depth": ("use_pass_z", "Depth", 1, "Z", "VALUE"),
    "normal": ("use_pass_normal", "Normal", 3, "XYZ", "VECTOR"),
    "denoising_albedo": ("hybrid_rt.denoising_store_passes", "Denoising Albedo", 3, "RGB", "COLOR"),
    "denoising_normal": ("hybrid_rt.denoising_store_passes", "Denoising Normal", 3, "XYZ", "VECTOR"),
}


def pass_wanted(view_layer, flag: str) -> bool:
    """Whether ``view_layer`` asks for a pass: ``flag`` is a DATA_PASSES property path."""
    owner, _, name = flag.rpartition(".")
    return bool(getattr(attrgetter(owner)(view_layer) if owner else view_layer, name))


# The view layer's Cryptomatte switches, by the kind they ask for (scene/cryptomatte.py KINDS).
CRYPTOMATTE_FLAGS = {"object": "use_pass_cryptomatte_object", "material": "use_pass_cryptomatte_material",
                     "asset": "use_pass_cryptomatte_asset"}


def cryptomatte_kinds(view_layer) -> tuple[str, ...]:
    """The Cryptomatte kinds ``view_layer`` asks for, in Blender's order."""
    return tuple(kind for kind, flag in CRYPTOMATTE_FLAGS.items() if getattr(view_layer, flag))


def asset_name(name: str) -> str:
    """The asset of a geometry object (``object`` or an instance's ``parent/object``): the
    topmost parent of the object, or of the instancer, as Cycles names it."""
    owner = bpy.data.objects.get(name.split("/", 1)[0])
    if owner is None:
        return cryptomatte.object_name(name)
    while owner.parent is not None:
        owner = owner.parent
    return owner.name


def light_request(scene, view_layer) -> LightPassRequest | None:
    """The light passes and Mist ``view_layer`` asks for (ViewLayer's own switches, as Cycles
    reads them) with the World's mist settings, or None when it asks for none."""
    flags = tuple(flag for flag in LIGHT_PASSES if getattr(view_layer, flag))
    if not flags:
        return None
    world = scene.world
    if world is None:  # no World: Cycles' film keeps Blender's default mist
        return LightPassRequest(flags)
    mist = world.mist_settings
    return LightPassRequest(flags, float(mist.start), float(mist.depth), str(mist.falloff))


def frame_outputs(scene, view_layer, scene_data: SceneData | None = None) -> FrameOutputs:
    """What the final render delivers besides the colour: the Film panel's transparency, the
    view layer's Z and Normal passes, our Denoising Data (film.py gives their conventions),
    the Cryptomatte passes at the view layer's Levels (``scene_data``'s objects give the
    assets) and Cycles' light passes and Mist (passes/film/light_passes.py)."""
    kinds = cryptomatte_kinds(view_layer)
    request = None
    if kinds:
        assets = ()
        if "asset" in kinds and scene_data is not None:
            assets = tuple(asset_name(name) for name in scene_data.geometry.object_names)
        request = CryptomatteRequest(kinds, int(view_layer.pass_cryptomatte_depth), assets)
    return FrameOutputs(transparent=bool(scene.render.film_transparent),
                        depth=pass_wanted(view_layer, DATA_PASSES["depth"][0]),
                        normal=pass_wanted(view_layer, DATA_PASSES["normal"][0]),
                        denoising=pass_wanted(view_layer, DATA_PASSES["denoising_albedo"][0]),
                        cryptomatte=request, light=light_request(scene, view_layer))


def cryptomatte_metadata(view_layer, scene_data: SceneData) -> dict[str, str]:
    """The render result's Cryptomatte metadata (``cryptomatte/<key>/name``, ``hash``,
    ``conversion``, ``manifest``) for the kinds ``view_layer`` asks for, as Blender writes it
    into the EXR: lamps are objects and assets in Cycles' manifest too, so they are listed."""
    objects = [cryptomatte.object_name(n) for n in scene_data.geometry.object_names]
    lamps = list(scene_data.lights.names)
    names = {"object": objects + lamps, "material": list(scene_data.materials.names),
             "asset": [asset_name(n) for n in scene_data.geometry.object_names] + lamps}
    fields: dict[str, str] = {}
    for kind in cryptomatte_kinds(view_layer):
        fields.update(cryptomatte.metadata(view_layer.name, kind, names[kind]))
    return fields


def final_camera(scene, depsgraph) -> Camera:
    """The camera of a final render: one that renders exactly the render region's pixels
    (``render.use_border``), which is all Blender's pipeline asks the engine for, or the
    scene camera when there is no region."""
    camera = camera_from_scene(scene, depsgraph)
    render = scene.render
    if not render.use_border:
        return camera
    rect = views.border_pixels(camera.width, camera.height, (render.border_min_x, render.border_min_y),
                              (render.border_max_x, render.border_max_y))
    return views.region_camera(camera, rect)


def final_effects(engine, depsgraph) -> CameraEffects | None:
    """A final render's Depth of Field and Motion Blur (None: neither). Motion needs the
    ``engine`` to evaluate sub-frames, and F12's scene cache to read the matrices of."""
    scene = depsgraph.scene
    lens = thin_lens_from_scene(scene, depsgraph)
    motion = None
    if engine is not None and _final_cache is not None and scene.render.use_motion_blur:
        motion = motion_steps(engine, depsgraph, _final_cache)
    if lens is None and motion is None:
        return None
    opening, closing = shutter(scene) if motion is not None else (0.0, 0.0)
    return CameraEffects(lens=lens, motion=motion, opening=opening, closing=closing)


def final_vector(engine, depsgraph) -> VectorRequest | None:
    """The motion a final render's Vector pass follows: the frames before and after, when
    the view layer asks for the pass and Motion Blur is off (with it on, Cycles leaves the
    pass at 0, and so does this engine: ``HybridRTRenderEngine._render``). Needs the
    ``engine`` to evaluate those frames, and F12's scene cache to read the matrices of."""
    scene = depsgraph.scene
    if (engine is None or _final_cache is None or scene.render.use_motion_blur
            or not depsgraph.view_layer.use_pass_vector):
        return None
    return VectorRequest(frame_motion(engine, depsgraph, _final_cache))


def final_render_settings(settings: RenderSettings) -> RenderSettings:
    """F12's settings: the artist's, with the cube map's back layer (*Back Faces*) on.

    The paper's single layer (§3.4; §4.1: objects with some thickness are not represented)
    stretches each stored surface behind itself by its material's thickness. Reflections
    seldom pass there, but the traced World light's paths leave every surface in all
    directions, and those that pass behind a closed object as the camera sees it meet its
    visible side, lit as the camera sees it, where the object is not: a sunlit ball lights
    the wall beside it with its camera-facing side's light. The farther a scene lies from
    the near cube, the more paths do so (all of them where the near cube holds nothing). The
    back layer ends a closed object at its far side and gives a ray from behind its hidden
    side. The setting stays off by default for the viewport, which a CPU driver redraws at
    every change (README "Cube map"); a final render is drawn once.
    """
    return replace(settings, cube_back_layer=True)


def render_depsgraph(depsgraph, *, cancel=None, progress=None, report=None, final=False,
                     source: TrackedScene | None = None, sizer: NearCubeSizer | None = None,
                     settings: RenderSettings | None = None, timing: bool | None = None,
                     engine=None) -> FrameResult:
    """Export the evaluated scene and render one frame with the scene's settings, or with
    ``settings`` when given: a caller that renders with other settings than the artist's
    (the timing report's FULL_BVH comparison) passes them here instead of writing them
    into ``scene.hybrid_rt``, so the artist's file is never changed.

    The scene comes from ``source`` (a job's tracked scene: only what changed is re-read),
    else from F12's kept scene (``final``, ``final_scene_data``), else it is read afresh.

    ``final``: as F12 renders it, the render region only, ``render_samples`` samples per
    pixel, with the film's transparency and the view layer's data passes
    (``frame_outputs``); otherwise one sample of the whole frame, opaque (timing reports,
    which time the frame the viewport and the paper render). What the export found for
    the artist (a missing image, an unsupported node) goes to ``report(levels, message)``.

    The near cube's size: with *Frame Budget*, a job's ``sizer`` chooses it frame by frame
    from the frames it timed; F12 takes the size the viewport settled on.

    ``timing``: time each pass (``FrameResult.passes``; the timing report asks), at the cost
    of a ``ctx.finish()`` around every pass. Default: only F12 with ``time_final_renders``.
    ``total_ms`` is measured either way (the frame ends by reading its image back).

    A final render takes the camera's Depth of Field (thin lens) and, given the ``engine``
    that evaluates sub-frames, the Motion Blur over the shutter (export/motion.py), both
    sampled across the render's samples (hybrid_engine/frame/camera_effects.py), and the
    Vector pass's motion between the frames around it (``final_vector``).
    """
    scene = depsgraph.scene
    if settings is None:
        settings = properties.settings_from_scene(scene)
    start = time.perf_counter()
    with messages.collecting() as gathered:
        if source is not None:
            scene_data = source.scene_data(depsgraph)
        elif final:
            scene_data = final_scene_data(depsgraph)
        else:
            scene_data = extract_scene(depsgraph)
        features.tell_used_features(scene, depsgraph, final=True)
        effects = final_effects(engine, depsgraph) if final else None
        vector = final_vector(engine, depsgraph) if final else None
    messages.report_all(report, gathered)
    # After the scene is read: Frame Budget's Automatic limits follow its scale.
    if sizer is not None:
        settings = sizer.settings_for_frame(settings, scene_data)
    elif final:
        settings = viewport.budgeted_settings(scene, settings, scene_data)
    if final:
        settings = final_render_settings(settings)
        camera = final_camera(scene, depsgraph)
        outputs = replace(frame_outputs(scene, depsgraph.view_layer, scene_data), vector=vector)
        samples = settings.render_samples
    else:
        camera, outputs, samples = camera_from_scene(scene, depsgraph), FrameOutputs(), 1
    extract_ms = (time.perf_counter() - start) * 1e3
    if timing is None:
        timing = final and time_final_renders
    with gl_block():
        renderer = shared_renderer()
        result = render_antialiased(renderer, scene_data, camera, settings, samples, outputs=outputs,
                                    timing=timing, cancel=cancel, progress=progress,
                                    filter_width=float(scene.render.filter_size),
                                    denoise=settings.denoise_render if final else settings.denoise_viewport,
                                    effects=effects)
    if final and outputs.cryptomatte is not None:
        result.metadata = cryptomatte_metadata(depsgraph.view_layer, scene_data)
    draw_legend(result.image, result.legend)  # a diagnostic view's legend, kept in the render
    effective_values.remember(result.effective)  # for the panels (Automatic settings)
    result.passes = {"extract": extract_ms, **result.passes}
    result.total_ms += extract_ms
    if sizer is not None:
        sizer.observe(result.total_ms, settings)
    return result


class HybridRTRenderEngine(bpy.types.RenderEngine):
    """Hybrid rasterization + ray tracing (Ganestam & Doggett 2014)."""

    bl_idname = "HYBRID_RT"
    bl_label = "Hybrid RT"
    bl_use_preview = True  # Material, World and Light previews (blender_adapter/preview.py)
    bl_use_shading_nodes_custom = False  # materials are edited with Blender's own nodes
    bl_use_eevee_viewport = True  # Material Preview uses EEVEE
    # The viewport renders in its own EGL context and uploads the image through ``gpu``;
    # it needs no Blender GPU context during view_update.
    bl_use_gpu_context = False

    def render(self, depsgraph) -> None:
        try:
            self._render(depsgraph)
        except RenderCancelled:
            pass
        except Exception as exc:  # noqa: BLE001 - nothing may escape a Blender callback
            if not messages.is_artist_error(exc):
                traceback.print_exc()
            message = f"Hybrid RT: {exc}"
            self.report({"ERROR"}, message)
            if not bpy.app.background:
                # The render window's header; in background mode Blender would print the
                # message a second time, after the report's own line.
                self.error_set(message)

    def _render(self, depsgraph) -> None:
        if self.is_preview:
            preview.write_result(self, preview.render_preview(depsgraph, cancel=self.test_break))
            return

        def progress(step: str, fraction: float) -> None:
            self.update_progress(fraction)
            self.update_stats("", f"Hybrid RT | {step}")

        global last_frame
        result = render_depsgraph(depsgraph, cancel=self.test_break, progress=progress, report=self.report,
                                  final=True, engine=self)
        last_frame = result
        height, width = result.image.shape[:2]
        # The result's origin is the render region's corner: Blender places the region in the
        # full frame itself (or crops to it). Blender calls render() once per view layer, each
        # with that layer's depsgraph: the result must be that layer's, not the first one.
        render_result = self.begin_result(0, 0, width, height, layer=depsgraph.view_layer.name)
        try:
            passes = render_result.layers[0].passes
            passes["Combined"].rect.foreach_set(np.ascontiguousarray(result.image, np.float32).ravel())
            # update_render_passes registered every pass the view layer asked for.
            for name, data in result.data_passes.items():
                name = DATA_PASSES[name][1] if name in DATA_PASSES else name  # the others: Blender's own
                passes[name].rect.foreach_set(np.ascontiguousarray(data, np.float32).ravel())
            if depsgraph.view_layer.use_pass_vector and VECTOR_PASS[0] not in result.data_passes:
                # Motion Blur is on: Cycles writes no motion there and leaves the pass at 0.
                passes[VECTOR_PASS[0]].rect.foreach_set(np.zeros(width * height * VECTOR_PASS[1], np.float32))
        finally:
            self.end_result(render_result)
        if result.metadata:
            # The Cryptomatte manifest, in the image's metadata as Cycles writes it: on the
            # engine's whole result (a layer's result from begin_result keeps no metadata).
            whole = self.get_result()
            for field, value in result.metadata.items():
                whole.stamp_data_add_field(field, value)
        triangles = result.counts.get("triangles_total", 0)
        self.update_stats(
            "", f"Hybrid RT | {result.mode} | {result.total_ms:.1f} ms | {triangles:,} triangles"
        )
        # Once per process: a farm task's log says which device rendered (a software one plainly).
        device = gl_context.device_report_once()
        if device is not None:
            self.report({"INFO"}, f"Hybrid RT: {device}")

    def update_render_passes(self, scene=None, renderlayer=None) -> None:
        """The passes this engine writes for a view layer (the compositor's Render Layers
        node shows them as sockets)."""
        self.register_pass(scene, renderlayer, "Combined", 4, "RGBA", "COLOR")
        for flag, name, channels, chan_id, kind in DATA_PASSES.values():
            if pass_wanted(renderlayer, flag):
                self.register_pass(scene, renderlayer, name, channels, chan_id, kind)
        for kind in cryptomatte_kinds(renderlayer):
            for name in cryptomatte.pass_names(kind, int(renderlayer.pass_cryptomatte_depth)):
                self.register_pass(scene, renderlayer, name, 4, "rgba", "COLOR")  # as Cycles
        for flag, (name, channels, chan_id, kind, *_where) in LIGHT_PASSES.items():
            if getattr(renderlayer, flag):
                self.register_pass(scene, renderlayer, name, channels, chan_id, kind)
        if renderlayer.use_pass_vector:  # with Motion Blur on too, as Cycles (left at 0 then)
            self.register_pass(scene, renderlayer, *VECTOR_PASS)

    # -- viewport (blender_adapter/viewport.py does the work) --------------------------------
    def view_update(self, context, depsgraph) -> None:
        try:
            viewport.view_update(self, context, depsgraph)
        except Exception as exc:  # noqa: BLE001 - nothing may escape a Blender callback
            viewport.callback_failed(self, "view_update", exc)

    def view_draw(self, context, depsgraph) -> None:
        try:
            viewport.view_draw(self, context, depsgraph)
        except Exception as exc:  # noqa: BLE001 - nothing may escape a Blender callback
            viewport.callback_failed(self, "view_draw", exc)


def register() -> None:
    bpy.utils.register_class(HybridRTRenderEngine)
    viewport.register()


def unregister() -> None:
    viewport.unregister()
    release_renderer()
    preview.release()
    bpy.utils.unregister_class(HybridRTRenderEngine)
