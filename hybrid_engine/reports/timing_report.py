# SPDX-License-Identifier: GPL-3.0-or-later
"""Timing reports of an animation: per-frame pass times, summary statistics, JSON/CSV/SVG/PNG.

The paper evaluates the method on animations (§4, Figures 5 and 6): every frame of a
200-frame sequence broken down into its passes, and the hybrid method's frame time next to a
full-BVH tracer's. This module reproduces those measurements from whatever renders frames:
a ``TimingReportJob`` calls a ``render_frame(frame_number)`` callback one frame per step
(the Blender operator passes one that steps the scene and renders through the engine, from
a modal handler that can cancel between frames; ``run_timing_report`` steps it to the end)
and keeps each ``FrameResult``'s passes and counts, which ``write_report`` turns into
``PREFIX.json``, ``PREFIX.csv`` and the stacked-bar chart ``PREFIX.svg``, and ``PREFIX.png``
when the caller hands in a ``ChartWriter``: the core has no image library and no font
engine, so it hands the chart over as data (``chart_raster.ChartPicture``: text-free pixels
and the labels to draw on them); inside Blender, ``blender_adapter.chart_images`` writes it.

Pass names and counts are not fixed here: a report carries whatever the frames carry.
Passes are ordered by ``PIPELINE_PASSES`` (the order of paper §3's frame), names it does not
know come after, in natural order ("pass_2" before "pass_10"); counts likewise, with the
triangle counts first. The order is the same for every frame and every report.

Validation (``validate_frame_range``, ``prepare_output_prefix``) happens before anything is
rendered, so a typing error in a path fails at once rather than after a long render.
"""
from __future__ import annotations

import csv
import json
import math
import os
import platform
import re
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping, Protocol, Sequence

import numpy as np

from . import chart_raster, chart_svg
from .chart_raster import ChartPicture

# The passes of one frame in the order they run (paper §3): host extraction, upload, shadow
# maps (§3.5), primary G-buffer (§3.1), cube map (§3.2), near-cube culling and LBVH (§3.3),
# deferred shading, the recursive tracer (§3.4), the running mean of the samples, read-back.
PIPELINE_PASSES = (
    "extract", "upload", "instance_transform", "shadow_maps", "lighting", "primary_raster",
    "cube_map_raster", "cull", "lbvh_build", "shade", "trace", "accumulate", "data_passes", "readback",
)
# Counts that come first in tables; the rest (ray counts per bounce...) follow in natural order.
LEADING_COUNTS = ("triangles_total", "triangles_bvh")
# Counts every frame record has, 0 when the frame did not report them (RASTER builds no BVH).
DEFAULT_COUNTS = {"triangles_bvh": 0}
# The rays' story of a traced frame (RayStory), as CSV columns after the passes.
RAY_STORY_COLUMNS = ("rays_ended_bvh", "rays_ended_cube_map", "rays_ended_sky", "bvh_nodes_per_ray",
                     "cube_steps_per_ray")


@dataclass(frozen=True)
class RayStory:
    """Where a frame's secondary rays ended and what they cost: the shares of the rays traced
    that ended at a BVH hit, a cube-map hit or in the sky (they add up to 1), and the BVH
    nodes visited and cube-map march steps taken per ray (tracer.COUNTER_KINDS)."""

    rays: int
    ended_bvh: float
    ended_cube_map: float
    ended_sky: float
    bvh_nodes_per_ray: float
    cube_steps_per_ray: float

    @classmethod
    def of(cls, counts: Mapping[str, int]) -> "RayStory | None":
        """The story told by a frame's counts; None for a frame that traced no rays."""
        rays = int(counts.get("rays_traced", 0))
        if rays <= 0:
            return None
        return cls(rays, counts.get("rays_bvh_hit", 0) / rays, counts.get("rays_cube_hit", 0) / rays,
                   counts.get("rays_sky", 0) / rays, counts.get("bvh_nodes", 0) / rays,
                   counts.get("cube_steps", 0) / rays)

    def columns(self) -> list[float]:
        return [self.ended_bvh, self.ended_cube_map, self.ended_sky, self.bvh_nodes_per_ray, self.cube_steps_per_ray]

    def to_dict(self) -> dict[str, float]:
        return {"rays": self.rays, **dict(zip(RAY_STORY_COLUMNS, self.columns()))}

MAX_FRAMES = 100_000  # longer ranges are almost certainly a typing error
MAX_WARMUP_FRAMES = 100
P95 = 95.0  # percentile of the frame-time summary
SUFFIXES = (".json", ".csv", ".png", ".svg")


class TimingReportError(ValueError):
    """A timing report cannot be made with these arguments (nothing was rendered)."""


class FrameRangeError(TimingReportError):
    """The frame range is empty, reversed, or absurdly long."""


class OutputPathError(TimingReportError):
    """The report files cannot be written where asked."""


class FrameResultLike(Protocol):
    passes: dict[str, float]
    counts: dict[str, int]
    timing_source: str
    total_ms: float
    mode: str


RenderFrame = Callable[[int], FrameResultLike]
# Writes a chart (pixels and labels) as an image file at the path: the caller's image library.
ChartWriter = Callable[[Path, ChartPicture], None]
ProgressCallback = Callable[[int, int], None]  # (frames done, frames in all)


# ---------------------------------------------------------------------------------------------
# Validation.

def validate_frame_range(frame_start: int, frame_end: int, max_frames: int = MAX_FRAMES) -> range:
    """The frames to render, ``frame_start`` to ``frame_end`` inclusive.

    Raises FrameRangeError when the range is reversed (a negative frame count) or longer
    than ``max_frames``.
    """
    for name, value in (("frame_start", frame_start), ("frame_end", frame_end)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise FrameRangeError(f"{name} must be a whole frame number, got {value!r}")
    count = int(frame_end) - int(frame_start) + 1
    if count < 1:
        raise FrameRangeError(
            f"frame range {frame_start}..{frame_end} is empty: frame_end must not be smaller than "
            f"frame_start (that would be {count} frames)"
        )
    if count > max_frames:
        raise FrameRangeError(
            f"frame range {frame_start}..{frame_end} has {count} frames; a report covers at most "
            f"{max_frames}"
        )
    return range(int(frame_start), int(frame_end) + 1)


def output_paths(prefix: str | os.PathLike) -> dict[str, Path]:
    """The files a report may write: ``{'json': PREFIX.json, 'csv': PREFIX.csv, 'png': PREFIX.png,
    'svg': PREFIX.svg}`` (the PNG only with a chart writer, see ``write_report``)."""
    base = str(prefix)
    return {suffix[1:]: Path(base + suffix) for suffix in SUFFIXES}


def prepare_output_prefix(prefix: str | os.PathLike, *, suffixes: Sequence[str] = ("",)) -> Path:
    """Check that ``PREFIX<suffix>.json/.csv/.png`` can be written; return the absolute prefix.

    A prefix that ends in .json, .csv or .png loses that ending (``out/report.json`` means
    the prefix ``out/report``). The folder must exist: a mistyped path would otherwise create
    folders wherever it points (a report to ``/nonexistent_dir/x`` would make a folder at the
    filesystem's root). Raises OutputPathError when the prefix is empty or names a directory,
    when the folder does not exist, is not a folder or cannot be written
    (checked by creating and deleting a probe file, which also works for the superuser, for
    whom permission bits say nothing), or when a report file's name is taken by a directory.
    """
    text = os.fspath(prefix).strip() if prefix is not None else ""
    if not text:
        raise OutputPathError("no output path given: set filepath to a file prefix such as out/report")
    if text.endswith(("/", os.sep)):
        raise OutputPathError(f"output path {text!r} is a directory; add a file name prefix such as {text}report")
    base = Path(text).expanduser()
    if base.suffix.lower() in SUFFIXES:
        base = base.with_suffix("")
    base = base.absolute()
    if base.is_dir():
        raise OutputPathError(f"output path {str(base)!r} is a directory; add a file name prefix")
    directory = base.parent
    if not directory.exists():
        raise OutputPathError(f"the report folder {str(directory)!r} does not exist: create it first, "
                              "or choose a prefix in an existing folder")
    if not directory.is_dir():
        raise OutputPathError(f"cannot write a report into {str(directory)!r}: it is a file, not a folder")
    try:
        with tempfile.NamedTemporaryFile(dir=directory, prefix=".hybrid_rt_probe_"):
            pass
    except OSError as exc:
        raise OutputPathError(f"cannot write into the report directory {str(directory)!r}: {exc.strerror or exc}") from exc
    for suffix in suffixes:
        for path in output_paths(str(base) + suffix).values():
            if path.is_dir():
                raise OutputPathError(f"cannot write {str(path)!r}: a directory has that name")
    return base


# ---------------------------------------------------------------------------------------------
# Frames.

@dataclass
class FrameRecord:
    """What a report keeps of one rendered frame (the image is not kept)."""

    frame: int
    total_ms: float
    passes: dict[str, float]
    counts: dict[str, int]
    mode: str
    timing_source: str
    near_size: float | None = None  # the near cube's half-size the frame used

    @classmethod
    def from_result(cls, frame: int, result: FrameResultLike) -> "FrameRecord":
        counts = {**DEFAULT_COUNTS, **{name: int(value) for name, value in result.counts.items()}}
        return cls(
            frame=int(frame),
            total_ms=float(result.total_ms),
            passes={name: float(ms) for name, ms in result.passes.items()},
            counts=counts,
            mode=str(result.mode),
            timing_source=str(result.timing_source),
            near_size=None if getattr(result, "near_size", None) is None else float(result.near_size),
        )

    def to_dict(self, pass_names: Sequence[str], count_names: Sequence[str]) -> dict[str, Any]:
        """The frame as the JSON report writes it: passes and counts in report order, the
        triangle counts also at top level."""
        return {
            "frame": self.frame,
            "mode": self.mode,
            "total_ms": self.total_ms,
            "passes": {name: self.passes[name] for name in pass_names if name in self.passes},
            "triangles_total": int(self.counts.get("triangles_total", 0)),
            "triangles_bvh": int(self.counts.get("triangles_bvh", 0)),
            "counts": {name: self.counts[name] for name in count_names if name in self.counts},
            "near_size": self.near_size,
            "ray_story": None if self.ray_story is None else self.ray_story.to_dict(),
        }

    @property
    def ray_story(self) -> RayStory | None:
        return RayStory.of(self.counts)


def _natural_key(name: str) -> list:
    """'rays_bounce_10' after 'rays_bounce_2': digit runs compare as numbers."""
    return [(0, int(part), "") if part.isdigit() else (1, 0, part) for part in re.split(r"(\d+)", name) if part]


def ordered_pass_names(names: Iterable[str]) -> list[str]:
    """Pass names in report order: those of PIPELINE_PASSES in pipeline order, then the
    others in natural order. Independent of the order the names arrive in."""
    unique = set(names)
    known = [name for name in PIPELINE_PASSES if name in unique]
    return known + sorted(unique.difference(PIPELINE_PASSES), key=_natural_key)


def ordered_count_names(names: Iterable[str]) -> list[str]:
    """Count names in report order: LEADING_COUNTS first, the others in natural order."""
    unique = set(names)
    leading = [name for name in LEADING_COUNTS if name in unique]
    return leading + sorted(unique.difference(LEADING_COUNTS), key=_natural_key)


# ---------------------------------------------------------------------------------------------
# Statistics.

def summarize(records: Sequence[FrameRecord], target_fps: float | None = None) -> dict[str, Any]:
    """Frame-time statistics of a run.

    ``frame_ms``: mean, median, 95th percentile (linear interpolation between closest ranks,
    numpy's default), min and max. ``fps``: 1000 / those frame times (so ``fps.p95`` is the
    rate that 95 % of frames reach, ``fps.min`` the slowest frame's). ``pass_mean_ms``: each
    pass's mean over the frames that ran it; ``pass_share``: its share of the summed mean
    frame time. ``count_mean``: the mean of each count. With ``target_fps``: the target frame
    time and how many frames missed it.
    """
    if not records:
        raise TimingReportError("no frames to summarize")
    totals = np.array([record.total_ms for record in records], dtype=np.float64)
    stats = {
        "mean": float(totals.mean()),
        "median": float(np.median(totals)),
        "p95": float(np.percentile(totals, P95)),
        "min": float(totals.min()),
        "max": float(totals.max()),
    }

    def rate(ms: float) -> float | None:
        return 1000.0 / ms if ms > 0.0 else None

    pass_names = ordered_pass_names(name for record in records for name in record.passes)
    count_names = ordered_count_names(name for record in records for name in record.counts)
    pass_mean = {
        name: float(np.mean([r.passes[name] for r in records if name in r.passes])) for name in pass_names
    }
    summed = sum(pass_mean.values())
    summary: dict[str, Any] = {
        "frames": len(records),
        "frame_ms": stats,
        "fps": {
            "mean": rate(stats["mean"]),
            "median": rate(stats["median"]),
            "p95": rate(stats["p95"]),
            "min": rate(stats["max"]),
            "max": rate(stats["min"]),
        },
        "pass_mean_ms": pass_mean,
        "pass_share": {name: (ms / summed if summed > 0.0 else 0.0) for name, ms in pass_mean.items()},
        "count_mean": {
            name: float(np.mean([r.counts.get(name, 0) for r in records])) for name in count_names
        },
    }
    if target_fps:
        target_ms = 1000.0 / target_fps
        summary["target_fps"] = float(target_fps)
        summary["target_ms"] = target_ms
        summary["frames_over_target"] = int((totals > target_ms).sum())
    return summary


def machine_info() -> dict[str, Any]:
    """The machine a report was measured on."""
    return {
        "platform": platform.platform(),
        "machine": platform.machine(),
        "processor": platform.processor() or platform.machine(),
        "cpu_count": os.cpu_count(),
        "python": sys.version.split()[0],
        "python_implementation": platform.python_implementation(),
    }


def gl_renderer_name() -> str:
    """The GL renderer string, or why there is none (a report never fails on it)."""
    from ..gpu import gl_context

    try:
        return gl_context.renderer_name()
    except gl_context.GLUnavailableError as exc:
        return f"unavailable: {exc}"


# ---------------------------------------------------------------------------------------------
# The report.

@dataclass
class TimingReport:
    """Frames of one run plus everything needed to interpret them."""

    records: list[FrameRecord]
    requested_mode: str = ""
    settings: dict[str, Any] = field(default_factory=dict)
    target_fps: float | None = None
    scene: dict[str, Any] = field(default_factory=dict)
    machine: dict[str, Any] = field(default_factory=machine_info)
    gl_renderer: str = ""
    warnings: list[str] = field(default_factory=list)
    warmup_frames: int = 0  # unrecorded renders of the first frame before the measured ones
    complete: bool = True  # False: cancelled, the records cover the frames rendered before

    @property
    def pass_names(self) -> list[str]:
        return ordered_pass_names(name for record in self.records for name in record.passes)

    @property
    def count_names(self) -> list[str]:
        return ordered_count_names(name for record in self.records for name in record.counts)

    @property
    def rendered_modes(self) -> list[str]:
        return sorted({record.mode for record in self.records})

    @property
    def timing_source(self) -> str:
        sources = sorted({record.timing_source for record in self.records})
        return sources[0] if len(sources) == 1 else "; ".join(sources)

    @property
    def target_ms(self) -> float | None:
        return 1000.0 / self.target_fps if self.target_fps else None

    def summary(self) -> dict[str, Any]:
        return summarize(self.records, self.target_fps)

    def to_dict(self) -> dict[str, Any]:
        pass_names, count_names = self.pass_names, self.count_names
        return {
            "requested_mode": self.requested_mode,
            "rendered_modes": self.rendered_modes,
            "timing_source": self.timing_source,
            "warmup_frames": self.warmup_frames,
            "pass_order": pass_names,
            "count_order": count_names,
            "summary": self.summary(),
            "frames": [record.to_dict(pass_names, count_names) for record in self.records],
            "settings": self.settings,
            "scene": self.scene,
            "machine": self.machine,
            "gl_renderer": self.gl_renderer,
            "warnings": list(self.warnings),
            "complete": self.complete,
        }


def _json_safe(value):
    """Replace non-finite floats by None: JSON has no NaN or infinity."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {key: _json_safe(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(item) for item in value]
    if isinstance(value, np.generic):
        return _json_safe(value.item())
    return value


def write_json(report: TimingReport, path: str | os.PathLike) -> None:
    with open(path, "w", encoding="utf-8") as handle:
        json.dump(_json_safe(report.to_dict()), handle, indent=2, allow_nan=False)
        handle.write("\n")


def csv_header(report: TimingReport) -> list[str]:
    """``frame, mode, total_ms, near_size, <pass>_ms..., <count>...`` in report order
    (``near_size``: the near cube's half-size each frame used, empty where it used none)."""
    return (["frame", "mode", "total_ms", "near_size"] + [f"{name}_ms" for name in report.pass_names]
            + list(RAY_STORY_COLUMNS) + list(report.count_names))


def write_csv(report: TimingReport, path: str | os.PathLike) -> None:
    """One row per frame. A pass a frame did not run is an empty cell, not 0."""
    pass_names, count_names = report.pass_names, report.count_names
    with open(path, "w", encoding="utf-8", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(csv_header(report))
        for record in report.records:
            writer.writerow(
                [record.frame, record.mode, f"{record.total_ms:.6f}",
                 "" if record.near_size is None else f"{record.near_size:.6f}"]
                + [f"{record.passes[name]:.6f}" if name in record.passes else "" for name in pass_names]
                + ([f"{v:.6f}" for v in record.ray_story.columns()] if record.ray_story is not None
                   else [""] * len(RAY_STORY_COLUMNS))
                + [record.counts.get(name, "") for name in count_names]
            )


def pass_colors(pass_names: Sequence[str]) -> list[chart_raster.RGB]:
    """A colour per pass that does not depend on which other passes a report has: pipeline
    passes keep their own palette entry, other names take the entries after them."""
    palette = chart_raster.PALETTE
    colors = []
    extra = len(PIPELINE_PASSES)
    for name in pass_names:
        if name in PIPELINE_PASSES:
            colors.append(palette[PIPELINE_PASSES.index(name) % len(palette)])
        else:
            colors.append(palette[extra % len(palette)])
            extra += 1
    return colors


def chart_title(report: TimingReport) -> str:
    name = report.scene.get("name", "")
    modes = "+".join(report.rendered_modes)
    frames = f"{len(report.records)} frames" + ("" if report.complete else " (cancelled: incomplete)")
    return " - ".join(part for part in (name, modes, frames) if part)


def render_chart(report: TimingReport, **chart_options) -> ChartPicture:
    """The stacked per-pass bars of every frame (paper Figure 5): pixels and labels."""
    pass_names = report.pass_names
    series = {name: [record.passes.get(name, 0.0) for record in report.records] for name in pass_names}
    return chart_raster.stacked_bar_chart(
        [record.frame for record in report.records], series, colors=pass_colors(pass_names),
        target_ms=report.target_ms, target_fps=report.target_fps, title=chart_title(report),
        **chart_options,
    )


def chart_summary(report: TimingReport) -> str:
    """The lines under the chart: mean and 95th-percentile frame time, the slowest pass; and
    for traced frames the rays' story (where they ended, BVH nodes and march steps per ray)."""
    summary = report.summary()
    frame = summary["frame_ms"]
    passes = summary.get("pass_mean_ms", {})
    slowest = max(passes, key=passes.get) if passes else None
    text = f"mean {frame['mean']:.1f} ms ({1000.0 / frame['mean']:.1f} fps), 95th percentile {frame['p95']:.1f} ms"
    if slowest is not None:
        text += f", slowest pass {slowest} ({passes[slowest]:.1f} ms mean)"
    stories = [record.ray_story for record in report.records if record.ray_story is not None]
    if stories:
        rays = sum(story.rays for story in stories)
        share = {kind: sum(getattr(story, kind) * story.rays for story in stories) / rays
                 for kind in ("ended_bvh", "ended_cube_map", "ended_sky", "bvh_nodes_per_ray",
                              "cube_steps_per_ray")}
        text += (f"\nrays ended {share['ended_bvh']:.0%} BVH, {share['ended_cube_map']:.0%} cube map, "
                 f"{share['ended_sky']:.0%} sky; {share['bvh_nodes_per_ray']:.1f} BVH nodes and "
                 f"{share['cube_steps_per_ray']:.1f} cube-map steps per ray")
    return text


def render_chart_svg(report: TimingReport) -> str:
    """The chart of ``render_chart`` as SVG, with axes, legend and summary (chart_svg.py)."""
    pass_names = report.pass_names
    series = {name: [record.passes.get(name, 0.0) for record in report.records] for name in pass_names}
    return chart_svg.stacked_bar_svg(
        [record.frame for record in report.records], series, pass_colors(pass_names),
        title=chart_title(report), summary=chart_summary(report), target_ms=report.target_ms,
        target_fps=report.target_fps, near_sizes=[record.near_size for record in report.records],
        ray_shares=[None if r.ray_story is None else (r.ray_story.ended_bvh, r.ray_story.ended_cube_map,
                                                      r.ray_story.ended_sky) for r in report.records])


def write_report(report: TimingReport, prefix: str | os.PathLike,
                 chart_writer: ChartWriter | None = None) -> dict[str, Path]:
    """Write PREFIX.json, PREFIX.csv and PREFIX.svg, and PREFIX.png through ``chart_writer``
    when one is given; return the paths written, keyed by suffix ('png' only with a writer)."""
    candidates = output_paths(prefix)
    paths = {key: candidates[key] for key in ("json", "csv", "svg")}
    write_json(report, paths["json"])
    write_csv(report, paths["csv"])
    paths["svg"].write_text(render_chart_svg(report), encoding="utf-8")
    if chart_writer is not None:
        chart_writer(candidates["png"], render_chart(report))
        paths["png"] = candidates["png"]
    return paths


def render_comparison_chart(reports: Mapping[str, TimingReport]) -> ChartPicture:
    """Total frame time of several runs over the same frames as lines (paper Figure 6).
    Frames missing from a run are dropped from all of them."""
    if not reports:
        raise TimingReportError("no reports to compare")
    common = sorted(set.intersection(*({r.frame for r in rep.records} for rep in reports.values())))
    if not common:
        raise TimingReportError("the reports share no frame")
    series = {}
    for label, rep in reports.items():
        by_frame = {record.frame: record.total_ms for record in rep.records}
        series[label] = [by_frame[frame] for frame in common]
    first = next(iter(reports.values()))
    title = " - ".join(part for part in (first.scene.get("name", ""), "frame time", " vs ".join(reports)) if part)
    return chart_raster.line_chart(common, series, target_ms=first.target_ms, target_fps=first.target_fps,
                                   title=title)


def write_comparison_chart(reports: Mapping[str, TimingReport], path: str | os.PathLike,
                           chart_writer: ChartWriter) -> Path:
    """``render_comparison_chart`` written at ``path`` by ``chart_writer``; returns the path."""
    path = Path(path)
    chart_writer(path, render_comparison_chart(reports))
    return path


class TimingReportJob:
    """A timing report rendered one frame per ``step()``, so that an interactive caller (the
    operator's modal handler) returns to Blender between frames and can cancel: ``finish()``
    writes the report of the frames rendered so far, marked incomplete when it stopped early.
    Everything that can fail before rendering (range, output path, warm-up count) fails in
    the constructor."""

    def __init__(self, prefix: str | os.PathLike, frame_start: int, frame_end: int, render_frame: RenderFrame, *,
                 requested_mode: str = "", settings: Mapping[str, Any] | None = None,
                 target_fps: float | None = None, scene: Mapping[str, Any] | None = None,
                 progress: ProgressCallback | None = None, warnings: Sequence[str] | None = None,
                 warmup_frames: int = 0, chart_writer: ChartWriter | None = None) -> None:
        self.frames = validate_frame_range(frame_start, frame_end)
        if isinstance(warmup_frames, bool) or not 0 <= int(warmup_frames) <= MAX_WARMUP_FRAMES:
            raise TimingReportError(f"warmup_frames must lie in [0, {MAX_WARMUP_FRAMES}], got {warmup_frames!r}")
        self.base = prepare_output_prefix(prefix)
        self.render_frame, self.progress, self.chart_writer = render_frame, progress, chart_writer
        self.warmup_frames = int(warmup_frames)
        self._warmups_left = self.warmup_frames
        self._next = 0  # index into frames of the next recorded frame
        self.records: list[FrameRecord] = []
        self._meta = dict(requested_mode=requested_mode, settings=dict(settings or {}), target_fps=target_fps,
                          scene=dict(scene or {}))
        self._warnings = warnings  # read when finishing: render_frame may add to it

    @property
    def done(self) -> bool:
        return self._next >= len(self.frames)

    @property
    def current_frame(self) -> int | None:
        """The frame the next step renders (None when done)."""
        return None if self.done else self.frames[self._next]

    def step(self) -> bool:
        """Render the next warm-up or recorded frame; True while frames remain."""
        if self._warmups_left:
            self.render_frame(self.frames.start)
            self._warmups_left -= 1
            return True
        if not self.done:
            frame = self.frames[self._next]
            self.records.append(FrameRecord.from_result(frame, self.render_frame(frame)))
            self._next += 1
            if self.progress is not None:
                self.progress(self._next, len(self.frames))
        return not self.done

    def finish(self) -> tuple[TimingReport, dict[str, Path]]:
        """Write the report of the frames rendered so far (incomplete unless all were)."""
        if not self.records:
            raise TimingReportError("the timing report was cancelled before its first frame: nothing to write")
        report = TimingReport(records=list(self.records), gl_renderer=gl_renderer_name(),
                              warnings=list(self._warnings or ()), warmup_frames=self.warmup_frames,
                              complete=self.done, **self._meta)
        return report, write_report(report, self.base, self.chart_writer)


def run_timing_report(
    prefix: str | os.PathLike,
    frame_start: int,
    frame_end: int,
    render_frame: RenderFrame,
    *,
    requested_mode: str = "",
    settings: Mapping[str, Any] | None = None,
    target_fps: float | None = None,
    scene: Mapping[str, Any] | None = None,
    progress: ProgressCallback | None = None,
    warnings: Sequence[str] | None = None,
    warmup_frames: int = 0,
    chart_writer: ChartWriter | None = None,
) -> tuple[TimingReport, dict[str, Path]]:
    """Validate, render every frame of the range, write the report; return it and its paths.

    Raises FrameRangeError or OutputPathError before the first frame is rendered.
    ``warmup_frames`` renders of the first frame come first and are not recorded: the first
    frame of a process compiles shaders and allocates GPU buffers, which a steady-state
    measurement (the paper's) leaves out. ``warnings`` is read after the last frame, so
    ``render_frame`` may add to it. ``chart_writer`` writes PREFIX.png (see ``write_report``).
    """
    job = TimingReportJob(prefix, frame_start, frame_end, render_frame, requested_mode=requested_mode,
                          settings=settings, target_fps=target_fps, scene=scene, progress=progress,
                          warnings=warnings, warmup_frames=warmup_frames, chart_writer=chart_writer)
    while job.step():
        pass
    return job.finish()
