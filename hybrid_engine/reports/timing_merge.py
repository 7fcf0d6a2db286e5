# SPDX-License-Identifier: GPL-3.0-or-later
"""One timing report from the reports of a render farm's chunks.

A farm job renders an animation in chunks of frames on several workers, and each chunk writes
the timing report of its own frames (``timing_report.py``). An artist wants one report of the
whole shot: every frame in order and a summary over all of them, not a folder of pieces whose
means cannot be averaged. The reports are read back into ``TimingReport`` and ``FrameRecord``,
so the merged summary is recomputed from the frames by the same ``summarize`` a single run
uses. Frames rendered on different machines are only comparable per machine: the merged report
names every machine and GL renderer and warns when there were several.

No bpy: the job's final task runs this inside Blender (where the extension is installed), and
``scripts/merge_timing_reports.py`` runs it from a checkout.
"""
from __future__ import annotations

import json
import os
import re
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

from .timing_report import FrameRecord, TimingReport, TimingReportError, write_report

ChartWriter = Callable[..., None]


def report_from_dict(data: dict[str, Any]) -> TimingReport:
    """A report as ``write_json`` wrote it, read back (the summary is recomputed, not read)."""
    source = str(data.get("timing_source", ""))
    try:
        records = [
            FrameRecord(
                frame=int(frame["frame"]),
                total_ms=float(frame["total_ms"]),
                passes={name: float(ms) for name, ms in frame.get("passes", {}).items()},
                counts={name: int(value) for name, value in frame.get("counts", {}).items()},
                mode=str(frame.get("mode", "")),
                timing_source=source,
                near_size=None if frame.get("near_size") is None else float(frame["near_size"]),
            )
            for frame in data["frames"]
        ]
    except (KeyError, TypeError, ValueError) as exc:
        raise TimingReportError(f"not a Hybrid RT timing report: {exc!r}") from exc
    return TimingReport(
        records=records,
        requested_mode=str(data.get("requested_mode", "")),
        settings=dict(data.get("settings", {})),
        target_fps=data.get("summary", {}).get("target_fps"),
        scene=dict(data.get("scene", {})),
        machine=dict(data.get("machine", {})),
        gl_renderer=str(data.get("gl_renderer", "")),
        warnings=list(data.get("warnings", [])),
        warmup_frames=int(data.get("warmup_frames", 0)),
        complete=bool(data.get("complete", True)),
    )


def load_report(path: str | os.PathLike) -> TimingReport:
    """Read one report's ``.json``; the message names the file that is not one."""
    try:
        with open(path, encoding="utf-8") as handle:
            return report_from_dict(json.load(handle))
    except (OSError, json.JSONDecodeError, TimingReportError) as exc:
        raise TimingReportError(f"cannot read the timing report {os.fspath(path)!r}: {exc}") from exc


def parse_frames(frames: str) -> list[int]:
    """Flamenco's frame notation (``1-10``, ``3, 5-10, 47``) as a sorted list of frames."""
    result: set[int] = set()
    for part in frames.replace(" ", "").split(","):
        if not part:
            continue
        match = re.fullmatch(r"(-?\d+)(?:(?:-|\.\.)(-?\d+))?", part)
        if match is None:
            raise TimingReportError(f"cannot read the frames {frames!r} (at {part!r})")
        start = int(match.group(1))
        end = int(match.group(2)) if match.group(2) is not None else start
        result.update(range(min(start, end), max(start, end) + 1))
    return sorted(result)


def _distinct(values: Iterable[Any]) -> list[Any]:
    seen: list[Any] = []
    for value in values:
        if value not in seen:
            seen.append(value)
    return seen


def merge_reports(reports: Sequence[TimingReport], expected_frames: Sequence[int] | None = None) -> TimingReport:
    """The chunks' reports as one: frames in order, the first chunk's settings and scene.

    A frame in two chunks, or a frame of ``expected_frames`` that no chunk reported (a chunk
    that failed to write its report), is an error rather than a summary over the wrong frames.
    """
    if not reports:
        raise TimingReportError("no timing reports to merge")
    records = sorted((record for report in reports for record in report.records), key=lambda r: r.frame)
    frames = [record.frame for record in records]
    repeated = sorted({frame for frame in frames if frames.count(frame) > 1})
    if repeated:
        raise TimingReportError(f"frames {repeated} appear in more than one chunk's report")
    if expected_frames is not None:
        missing = sorted(set(expected_frames) - set(frames))
        if missing:
            raise TimingReportError(f"no chunk reported the frames {missing}")
    first = reports[0]
    machines = _distinct(report.machine for report in reports)
    renderers = _distinct(report.gl_renderer for report in reports)
    warnings = _distinct(warning for report in reports for warning in report.warnings)
    if len(machines) > 1 or len(renderers) > 1:
        warnings.append(f"the frames were rendered on {len(machines)} machines with {len(renderers)} GL "
                        "renderers: compare frame times only between frames of one machine")
    if any(report.settings != first.settings for report in reports):
        warnings.append("the chunks were rendered with different settings")
    machine = machines[0] if len(machines) == 1 else {"machines": machines}
    return TimingReport(
        records=records, requested_mode=first.requested_mode, settings=first.settings,
        target_fps=first.target_fps, scene=first.scene, machine=machine, gl_renderer="; ".join(renderers),
        warnings=warnings, warmup_frames=first.warmup_frames, complete=all(r.complete for r in reports),
    )


def chunk_reports(folder: str | os.PathLike) -> list[Path]:
    """The reports' ``.json`` files in a folder, in name order."""
    folder = Path(folder)
    if not folder.is_dir():
        raise TimingReportError(f"the timing reports' folder {os.fspath(folder)!r} does not exist")
    return sorted(path for path in folder.glob("*.json") if path.is_file())


def merge_files(paths: Sequence[str | os.PathLike], prefix: str | os.PathLike, *,
                frames: str | None = None, chart_writer: ChartWriter | None = None) -> dict[str, Path]:
    """Merge the reports at ``paths`` into PREFIX.json, .csv, .svg (and .png with a writer)."""
    if not paths:
        raise TimingReportError("no timing reports to merge")
    merged = merge_reports([load_report(path) for path in paths],
                           None if frames is None else parse_frames(frames))
    return write_report(merged, prefix, chart_writer)


def merge_folder(folder: str | os.PathLike, prefix: str | os.PathLike, *, frames: str | None = None,
                 chart_writer: ChartWriter | None = None) -> dict[str, Path]:
    """Merge every report in ``folder`` (a farm job's chunk reports) into PREFIX.*."""
    return merge_files(chunk_reports(folder), prefix, frames=frames, chart_writer=chart_writer)
