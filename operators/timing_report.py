# SPDX-License-Identifier: GPL-3.0-or-later
"""``bpy.ops.hybrid_rt.timing_report``: render a frame range and write its timing report.

Each frame goes through the same path as F12 (``scene.frame_set``, the evaluated depsgraph,
``blender_adapter.engine.render_depsgraph``: extraction plus the renderer) without writing
images; ``hybrid_engine.reports.timing_report`` turns the frames into PREFIX.json, PREFIX.csv and
the stacked-bar charts PREFIX.svg and PREFIX.png (paper Figure 5; the PNG written by
``blender_adapter.chart_images``, its text drawn by Blender's font engine). With
``compare_full_bvh`` the range is rendered a second time in FULL_BVH mode (PREFIX_full_bvh.*)
and PREFIX_compare.png draws both frame times (paper Figure 6).

Everything is validated before the first frame is rendered (frame range, output directory,
camera, settings). The scene's current frame is restored afterwards, also after an error.
The report never writes the user's settings: each frame is rendered with the scene's
settings at that frame (keyframed settings change from frame to frame, as in F12), and the
FULL_BVH run hands its mode to ``render_depsgraph`` as an override, so ``scene.hybrid_rt``
reads the artist's values throughout and a crash cannot leave the file changed.
"""
from __future__ import annotations

import gc
import os
import tempfile
import traceback
from dataclasses import asdict, replace

import bpy

from ..blender_adapter import chart_images, engine, messages, properties, scene_cache
from ..blender_adapter.export.camera import render_resolution
from ..hybrid_engine.reports import timing_report
from ..hybrid_engine.frame.near_budget import NearCubeSizer
from ..hybrid_engine.scene.settings import RenderSettings, SettingsError

COMPARE_MODE = "FULL_BVH"
COMPARE_SUFFIX = "_full_bvh"
COMPARISON_CHART_SUFFIX = "_compare.png"


def default_prefix(scene) -> str:
    """Next to the .blend when it is saved, in the system's temporary folder otherwise."""
    name = bpy.path.clean_name(scene.name) or "scene"
    if bpy.data.filepath:
        return f"//timing/{name}"
    return os.path.join(tempfile.gettempdir(), "hybrid_rt_timing", name)


def target_fps(scene) -> float:
    """The scene's frame rate (Output Properties > Frame Rate)."""
    return scene.render.fps / scene.render.fps_base


def scene_info(scene) -> dict:
    return {
        "name": scene.name,
        "blend_file": bpy.data.filepath,
        "resolution": list(render_resolution(scene.render)),
        "fps": scene.render.fps,
        "fps_base": scene.render.fps_base,
        "blender": bpy.app.version_string,
    }


class HYBRID_RT_OT_timing_report(bpy.types.Operator):
    """Render every frame of a range with Hybrid RT and write per-pass frame times (JSON, CSV) and charts (PNG, SVG); Esc cancels"""

    bl_idname = "hybrid_rt.timing_report"
    bl_label = "Timing Report"
    bl_options = {"REGISTER"}  # no undo step: the operator changes no data

    filepath: bpy.props.StringProperty(
        name="File Prefix",
        description="Path and file name prefix of the report: PREFIX.json, PREFIX.csv, PREFIX.png and "
        "PREFIX.svg are written ('//' is the .blend's folder)",
        subtype="FILE_PATH",
        options={"PATH_SUPPORTS_BLEND_RELATIVE"},
        default="",
    )
    frame_start: bpy.props.IntProperty(
        name="Start Frame", description="First frame of the report (default: the scene's start frame)",
        options={"SKIP_SAVE"}, default=1,
    )
    frame_end: bpy.props.IntProperty(
        name="End Frame", description="Last frame of the report (default: the scene's end frame)",
        options={"SKIP_SAVE"}, default=250,
    )
    compare_full_bvh: bpy.props.BoolProperty(
        name="Compare with Full BVH",
        description="Render the range a second time in Full BVH mode and write PREFIX_full_bvh.* and "
        "a comparison chart PREFIX_compare.png (paper Figure 6)",
        default=False,
    )
    warmup_frames: bpy.props.IntProperty(
        name="Warm-up Frames",
        description="Renders of the start frame before the measured ones, left out of the report "
        "(the first frame compiles shaders and allocates GPU memory)",
        default=1, min=0, max=timing_report.MAX_WARMUP_FRAMES,
    )
    check_existing: bpy.props.BoolProperty(default=False, options={"HIDDEN", "SKIP_SAVE"})

    @classmethod
    def poll(cls, context) -> bool:
        return context.scene is not None

    def invoke(self, context, _event):
        self._fill_defaults(context.scene)
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def _fill_defaults(self, scene) -> None:
        if not self.properties.is_property_set("frame_start"):
            self.frame_start = scene.frame_start
        if not self.properties.is_property_set("frame_end"):
            self.frame_end = scene.frame_end
        if not self.filepath:
            self.filepath = default_prefix(scene)

    def execute(self, context):
        scene = context.scene
        self._fill_defaults(scene)
        try:
            prefix, frames, settings = self._validate(scene)
        except (timing_report.TimingReportError, SettingsError) as exc:
            self.report({"ERROR"}, f"Timing report: {exc}")
            return {"CANCELLED"}
        if not bpy.app.background and context.window is not None:
            return self._start_modal(context, prefix, frames, settings)
        return self._run_blocking(context, prefix, frames, settings)

    def _run_blocking(self, context, prefix, frames, settings):
        """All frames in one call: headless runs (``blender --background``, scripts)."""
        scene = context.scene
        window_manager = context.window_manager
        if window_manager is not None:
            window_manager.progress_begin(0, (2 if self.compare_full_bvh else 1) * len(frames))
        saved_frame, saved_subframe = scene.frame_current, scene.frame_subframe
        main = _FrameRenderer(context, window_manager, progress_offset=0)
        compare = _FrameRenderer(context, window_manager, progress_offset=len(frames), mode=COMPARE_MODE)
        try:
            report, paths = timing_report.run_timing_report(
                prefix, frames.start, frames.stop - 1, main.render,
                requested_mode=settings.mode, settings=asdict(settings), target_fps=target_fps(scene),
                scene=scene_info(scene), progress=main.progress, warnings=main.warnings,
                warmup_frames=self.warmup_frames, chart_writer=chart_images.write_chart,
            )
            written = list(paths.values())
            if self.compare_full_bvh:
                written += self._compare(prefix, frames, settings, report, compare)
        except Exception as exc:  # noqa: BLE001 - any failure is reported, the scene restored
            if not messages.is_artist_error(exc):
                traceback.print_exc()
            failed = compare if compare.frame is not None else main
            where = f" at frame {failed.frame}" if failed.frame is not None else ""
            self.report({"ERROR"}, f"Timing report failed{where}: {exc}")
            return {"CANCELLED"}
        finally:
            main.source.close()
            compare.source.close()
            scene.frame_set(saved_frame, subframe=saved_subframe)
            if window_manager is not None:
                window_manager.progress_end()

        self._announce(report, written, main.warnings)
        return {"FINISHED"}

    def _validate(self, scene):
        """Everything that can fail before the first frame: range, path, camera, settings."""
        frames = timing_report.validate_frame_range(self.frame_start, self.frame_end)
        if self.filepath.startswith("//") and not bpy.data.filepath:
            raise timing_report.OutputPathError(
                f"{self.filepath!r} is relative to the .blend file, which is not saved yet: save it "
                "or give an absolute path"
            )
        suffixes = ("", COMPARE_SUFFIX) if self.compare_full_bvh else ("",)
        prefix = timing_report.prepare_output_prefix(bpy.path.abspath(self.filepath), suffixes=suffixes)
        if scene.camera is None:
            raise timing_report.TimingReportError(f"scene {scene.name!r} has no active camera")
        settings = properties.settings_from_scene(scene)
        return prefix, frames, settings

    def _compare(self, prefix, frames, settings, report, renderer: "_FrameRenderer") -> list:
        """The same range in FULL_BVH mode (the paper's Figure 6 comparison): ``renderer``
        carries the mode to the engine, the scene's settings are left alone."""
        compare_report, compare_paths = timing_report.run_timing_report(
            f"{prefix}{COMPARE_SUFFIX}", frames.start, frames.stop - 1, renderer.render,
            requested_mode=COMPARE_MODE, settings=asdict(replace(settings, mode=COMPARE_MODE)),
            target_fps=report.target_fps, scene=report.scene, progress=renderer.progress,
            warnings=renderer.warnings, warmup_frames=self.warmup_frames, chart_writer=chart_images.write_chart,
        )
        label = "+".join(report.rendered_modes)
        if label == COMPARE_MODE:
            label += " (SCENE)"
        chart = timing_report.write_comparison_chart(
            {label: report, COMPARE_MODE: compare_report}, f"{prefix}{COMPARISON_CHART_SUFFIX}",
            chart_images.write_chart,
        )
        return [*compare_paths.values(), chart]


    # -- interactive: one frame per timer event, Esc cancels -------------------------------------
    def _start_modal(self, context, prefix, frames, settings):
        """Render from a modal, timer-driven handler: Blender stays responsive between frames,
        the status bar shows the progress and Esc stops the report (its frames so far are
        written, marked incomplete)."""
        scene = context.scene
        self._frames, self._saved = frames, (scene.frame_current, scene.frame_subframe)
        # (prefix, the run's settings as reported, the mode handed to the engine: None is the scene's)
        self._runs = [(prefix, settings, None)]
        if self.compare_full_bvh:
            self._runs.append((f"{prefix}{COMPARE_SUFFIX}", replace(settings, mode=COMPARE_MODE), COMPARE_MODE))
        self._reports, self._written, self._job = [], [], None
        window_manager = context.window_manager
        window_manager.progress_begin(0, len(self._runs) * len(frames))
        self._start_job(context)
        self._timer = window_manager.event_timer_add(0.001, window=context.window)
        window_manager.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _start_job(self, context) -> None:
        scene = context.scene
        prefix, settings, mode = self._runs[len(self._reports)]
        self._renderer = _FrameRenderer(context, context.window_manager,
                                        progress_offset=len(self._reports) * len(self._frames), mode=mode)
        self._job = timing_report.TimingReportJob(
            prefix, self._frames.start, self._frames.stop - 1, self._renderer.render,
            requested_mode=settings.mode, settings=asdict(settings), target_fps=target_fps(scene),
            scene=scene_info(scene), progress=self._renderer.progress, warnings=self._renderer.warnings,
            warmup_frames=self.warmup_frames, chart_writer=chart_images.write_chart)

    def _close_job(self, context) -> None:
        """Write the current job's report (partial when cancelled) and stop its scene tracking."""
        job, self._job = self._job, None
        self._renderer.source.close()
        if job is not None and job.records:
            report, paths = job.finish()
            self._reports.append(report)
            self._written += list(paths.values())

    def modal(self, context, event):
        if event.type == "ESC":
            return self._end(context, cancelled=True)
        if event.type != "TIMER" or self._job is None:
            return {"PASS_THROUGH"}
        try:
            more = self._job.step()
        except Exception as exc:  # noqa: BLE001 - reported, the scene restored
            if not messages.is_artist_error(exc):
                traceback.print_exc()
            self.report({"ERROR"}, f"Timing report failed at frame {self._renderer.frame}: {exc}")
            return self._end(context, cancelled=True)
        done = len(self._reports) * len(self._frames) + len(self._job.records)
        context.workspace.status_text_set(
            f"Hybrid RT timing report: {done} of {len(self._runs) * len(self._frames)} frames - Esc to cancel")
        if more:
            return {"RUNNING_MODAL"}
        self._close_job(context)
        if len(self._reports) < len(self._runs):
            self._start_job(context)
            return {"RUNNING_MODAL"}
        return self._end(context, cancelled=False)

    def _end(self, context, *, cancelled: bool):
        if self._job is not None:
            self._close_job(context)
        window_manager = context.window_manager
        window_manager.event_timer_remove(self._timer)
        window_manager.progress_end()
        context.workspace.status_text_set(None)
        context.scene.frame_set(self._saved[0], subframe=self._saved[1])
        if len(self._reports) == 2 and not cancelled:
            label = "+".join(self._reports[0].rendered_modes)
            self._written.append(timing_report.write_comparison_chart(
                {label if label != COMPARE_MODE else f"{label} (SCENE)": self._reports[0],
                 COMPARE_MODE: self._reports[1]}, f"{self._runs[0][0]}{COMPARISON_CHART_SUFFIX}",
                chart_images.write_chart))
        if not self._reports:
            self.report({"WARNING"}, "Timing report cancelled before its first frame: nothing written")
            return {"CANCELLED"}
        self._announce(self._reports[0], self._written, self._renderer.warnings, incomplete=cancelled)
        _show_in_image_editor(context, next(path for path in self._written if path.suffix == ".png"))
        return {"CANCELLED"} if cancelled else {"FINISHED"}

    def _announce(self, report, written, warnings, *, incomplete: bool = False) -> None:
        """The run's warnings, then what was written, in Blender's report."""
        for message in warnings:
            self.report({"WARNING"}, message)
        summary = report.summary()
        self.report(
            {"WARNING" if incomplete else "INFO"},
            f"Timing report{' cancelled' if incomplete else ''}: {len(report.records)} frames, mean "
            f"{summary['frame_ms']['mean']:.2f} ms ({summary['fps']['mean'] or 0.0:.1f} FPS), written to "
            f"{', '.join(str(p) for p in written)}",
        )


def _show_in_image_editor(context, png_path) -> None:
    """Open the chart in an Image Editor of the current screen, when there is one."""
    screen = getattr(context, "screen", None)
    editors = [area for area in (screen.areas if screen is not None else ()) if area.type == "IMAGE_EDITOR"]
    if not editors:
        return
    image = bpy.data.images.load(str(png_path), check_existing=True)
    image.reload()
    editors[0].spaces.active.image = image


class _FrameRenderer:
    """Renders one frame of a run through the engine and keeps what the run needs to know:
    the frame being rendered (for error messages), the engine's warnings (each once), and the
    progress shown in Blender's window.

    ``mode``: the mode this run renders in whatever the scene says (the FULL_BVH comparison),
    handed to the engine with the frame's settings instead of being written to the scene;
    None renders in the scene's own mode."""

    def __init__(self, context, window_manager, progress_offset: int, mode: str | None = None) -> None:
        self.context = context
        self.window_manager = window_manager
        self.progress_offset = progress_offset
        self.mode = mode
        self.frame: int | None = None
        self.warnings: list[str] = []
        # The scene kept across the run's frames: each re-reads what its frame changed.
        self.source = scene_cache.TrackedScene()
        # Frame Budget: the near cube's size chosen from the run's own frame times.
        self.sizer = NearCubeSizer()

    def warn(self, _levels, message: str) -> None:
        if message not in self.warnings:
            self.warnings.append(message)

    def settings_for_frame(self) -> RenderSettings:
        """The scene's settings at its current frame (read after ``frame_set``: keyframed
        settings change per frame) with this run's mode, without writing the scene."""
        settings = properties.settings_from_scene(self.context.scene)
        return settings if self.mode is None else replace(settings, mode=self.mode)

    def render(self, frame: int):
        self.frame = frame
        scene = self.context.scene
        self.source.listen()
        scene.frame_set(frame)
        # A collection of the interpreter's garbage is no part of a frame: take it here, not
        # at a random point between two of the frame's timed passes.
        gc.collect()
        return engine.render_depsgraph(self.context.evaluated_depsgraph_get(), report=self.warn,
                                       source=self.source, sizer=self.sizer, settings=self.settings_for_frame(),
                                       timing=True)

    def progress(self, done: int, _total: int) -> None:
        if self.window_manager is not None:
            self.window_manager.progress_update(self.progress_offset + done)


_CLASSES = (HYBRID_RT_OT_timing_report,)


def register() -> None:
    for cls in _CLASSES:
        bpy.utils.register_class(cls)


def unregister() -> None:
    for cls in reversed(_CLASSES):
        if cls.is_registered:
            bpy.utils.unregister_class(cls)
