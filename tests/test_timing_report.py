# SPDX-License-Identifier: GPL-3.0-or-later
"""Timing reports: hybrid_engine/reports/timing_report.py (core) and ``bpy.ops.hybrid_rt.timing_report``.

The core is tested with frames whose timings are known (fake render callbacks returning
FrameResults with the tracer's pass names), so statistics, ordering and files can be checked
against numpy and hand computation. The operator is tested on a small animated Blender scene:
the files it writes, that the animation really reaches the extracted geometry frame by frame,
that bad input fails before anything is rendered, and that the user's scene is left as it was.
"""
from __future__ import annotations

import csv
import inspect
import itertools
import json
import subprocess
import sys

import numpy as np
import pytest

from conftest import REPO_ROOT
from image_io import read_png
from hybrid_engine.reports import chart_raster
from hybrid_engine.reports import timing_report
from hybrid_engine.frame.renderer import FrameResult
from hybrid_engine.gpu.timing import TIMING_SOURCE_WALL
from hybrid_engine.reports.timing_report import (
    FrameRangeError, OutputPathError, TimingReportError, ordered_count_names, ordered_pass_names,
    prepare_output_prefix, run_timing_report, summarize, validate_frame_range,
)

# Pass times are wall-clock intervals bracketed by ctx.finish(); the frame total also covers
# the small host work between passes (callbacks, view set-up, GL error checks in tests).
PASS_SUM_RTOL = 0.10
# ... and, for frames of a few milliseconds, a scheduler's pause between two passes on a loaded
# machine (the gap is real host time, but not the passes').
PASS_SUM_ATOL_MS = 2.0
# Keyframed x-location per frame of the animated scene (each frame keyed: exact at every frame).
CUBE_X_PER_FRAME = 2.0
# Float32 vertex positions of a unit cube moved by a few units.
POSITION_ATOL = 1e-5
TINY = (32, 24)
FRAMES = (1, 5)
# The band above the plot where the chart's title is drawn; the core leaves it white.
TITLE_ROWS = 24


def fake_result(passes: dict[str, float], counts: dict[str, int] | None = None, mode: str = "HYBRID",
                extra_ms: float = 0.0) -> FrameResult:
    return FrameResult(image=np.zeros((1, 1, 4), np.float32), passes=dict(passes), counts=dict(counts or {}),
                       timing_source=TIMING_SOURCE_WALL, total_ms=sum(passes.values()) + extra_ms, mode=mode)


class RecordingChartWriter:
    """A chart writer that keeps what it is handed (and writes a placeholder file)."""

    def __init__(self) -> None:
        self.charts: list[tuple[object, chart_raster.ChartPicture]] = []

    def __call__(self, path, picture: chart_raster.ChartPicture) -> None:
        self.charts.append((path, picture))
        path.write_bytes(b"")


class CountingRenderer:
    """A render_frame callback with known per-frame timings that counts its calls."""

    def __init__(self, passes_of_frame=None) -> None:
        self.calls: list[int] = []
        self.passes_of_frame = passes_of_frame or (lambda frame: {
            "trace": 3.0 * frame, "extract": 1.0, "cube_map_raster": 2.0, "composite": 0.5,
        })

    def __call__(self, frame: int) -> FrameResult:
        self.calls.append(frame)
        return fake_result(self.passes_of_frame(frame),
                           {"rays_bounce_10": 7, "rays_bounce_2": 40 + frame, "triangles_total": 100})


# ---------------------------------------------------------------------------------------------
# Core: ordering, statistics, validation, files.

def test_passes_are_ordered_by_pipeline_then_naturally_whatever_order_they_arrive_in():
    names = ["trace", "zeta_2", "extract", "zeta_10", "cull", "shade", "alpha", "lbvh_build"]
    expected = ["extract", "cull", "lbvh_build", "shade", "trace", "alpha", "zeta_2", "zeta_10"]
    for permutation in itertools.islice(itertools.permutations(names), 0, 40320, 997):
        assert ordered_pass_names(permutation) == expected
    assert ordered_pass_names(timing_report.PIPELINE_PASSES[::-1]) == list(timing_report.PIPELINE_PASSES)


def test_counts_put_triangles_first_then_natural_order():
    names = ["rays_bounce_10", "lights", "triangles_bvh", "rays_bounce_2", "triangles_total"]
    assert ordered_count_names(names) == ["triangles_total", "triangles_bvh", "lights", "rays_bounce_2",
                                          "rays_bounce_10"]


def test_summary_statistics_match_hand_computation():
    totals = [10.0, 20.0, 30.0, 40.0, 100.0]
    records = [timing_report.FrameRecord.from_result(i, fake_result({"shade": t / 2}, extra_ms=t / 2))
               for i, t in enumerate(totals)]
    records[0].passes["trace"] = 4.0  # a pass only one frame ran: its mean is over that frame
    summary = summarize(records, target_fps=25.0)
    ms = summary["frame_ms"]
    assert ms["mean"] == pytest.approx(40.0)
    assert ms["median"] == pytest.approx(30.0)
    # Linear interpolation between closest ranks: rank 0.95 * 4 = 3.8 -> 40 + 0.8 * (100 - 40).
    assert ms["p95"] == pytest.approx(88.0)
    assert ms["max"] == pytest.approx(100.0) and ms["min"] == pytest.approx(10.0)
    assert summary["fps"]["mean"] == pytest.approx(25.0)
    assert summary["fps"]["min"] == pytest.approx(10.0)
    assert summary["pass_mean_ms"] == pytest.approx({"shade": 20.0, "trace": 4.0})
    assert summary["target_ms"] == pytest.approx(40.0)
    assert summary["frames_over_target"] == 1  # 100 ms; 40 ms is on target, not over
    assert summary["count_mean"]["triangles_bvh"] == 0.0  # absent count -> 0


@pytest.mark.parametrize(("start", "end", "message"), [
    (5, 1, "frame_end must not be smaller"),
    (0, -1, "is empty"),
    (1, timing_report.MAX_FRAMES + 1, "at most"),
    (1.5, 3, "whole frame number"),
])
def test_invalid_frame_ranges_are_rejected(start, end, message):
    with pytest.raises(FrameRangeError, match=message):
        validate_frame_range(start, end)


def test_frame_range_limits_are_inclusive():
    assert list(validate_frame_range(-2, 2)) == [-2, -1, 0, 1, 2]
    assert len(validate_frame_range(1, timing_report.MAX_FRAMES)) == timing_report.MAX_FRAMES


def test_output_prefix_drops_a_report_suffix_and_leaves_nothing_behind(tmp_path):
    base = prepare_output_prefix(tmp_path / "run.json")
    assert base == tmp_path / "run"
    assert list(base.parent.iterdir()) == []  # the write probe leaves nothing behind


def test_output_prefix_in_a_missing_folder_is_refused_and_creates_nothing(tmp_path):
    with pytest.raises(OutputPathError, match="does not exist: create it first"):
        prepare_output_prefix(tmp_path / "missing" / "deeper" / "run")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("case", ["parent_is_a_file", "prefix_is_a_directory", "json_is_a_directory", "empty"])
def test_unwritable_output_paths_fail_before_any_frame_is_rendered(tmp_path, case):
    (tmp_path / "file").write_text("x")
    (tmp_path / "taken.json").mkdir()
    prefix = {
        "parent_is_a_file": tmp_path / "file" / "report",
        "prefix_is_a_directory": tmp_path,
        "json_is_a_directory": tmp_path / "taken",
        "empty": "",
    }[case]
    renderer = CountingRenderer()
    with pytest.raises(OutputPathError) as error:
        run_timing_report(prefix, 1, 3, renderer)
    assert str(error.value)  # a message naming the problem
    assert renderer.calls == []


def test_the_svg_chart_parses_and_names_every_pass_the_axes_the_target_and_the_summary(tmp_path):
    import xml.etree.ElementTree as ElementTree

    renderer = CountingRenderer()
    _report, paths = run_timing_report(tmp_path / "r", 3, 6, renderer, requested_mode="HYBRID",
                                       settings={"mode": "HYBRID"}, target_fps=30.0, scene={"name": "Test"})
    root = ElementTree.fromstring(paths["svg"].read_text())
    ns = "{http://www.w3.org/2000/svg}"
    texts = ["".join(t.itertext()) for t in root.iter(f"{ns}text")]
    legend = [t.text for t in root.iter(f"{ns}text") if t.get("class") == "pass"]
    assert legend == ["extract", "cube_map_raster", "trace", "composite"]
    assert "frame time (ms)" in texts and "frames per second" in texts and "30" in texts
    assert any(line.get("class") == "target" for line in root.iter(f"{ns}line"))
    summary = next(t.text for t in root.iter(f"{ns}text") if t.get("class") == "summary")
    # Frames 3-6 cost 3.5 + 3 f ms: mean 17.0; the trace (3 f) is the slowest pass.
    assert "mean 17.0 ms" in summary and "slowest pass trace" in summary
    bars = [r for r in root.iter(f"{ns}rect") if r.find(f"{ns}title") is not None]
    assert len(bars) == 4 * 4  # a bar segment per pass and frame


def test_a_job_cancelled_after_two_frames_writes_them_and_says_it_is_incomplete(tmp_path):
    from hybrid_engine.reports.timing_report import TimingReportJob

    renderer = CountingRenderer()
    job = TimingReportJob(tmp_path / "r", 1, 5, renderer, warmup_frames=1, target_fps=24.0)
    assert job.current_frame == 1
    while len(job.records) < 2:
        assert job.step()
    report, paths = job.finish()  # the caller stops here: Esc
    assert renderer.calls == [1, 1, 2]  # one warm-up, then frames 1 and 2
    data = json.loads(paths["json"].read_text())
    assert data["complete"] is False and [f["frame"] for f in data["frames"]] == [1, 2]
    with open(paths["csv"], newline="") as handle:
        assert [row["frame"] for row in csv.DictReader(handle)] == ["1", "2"]
    assert "incomplete" in paths["svg"].read_text()


def test_a_job_stepped_to_the_end_writes_what_the_one_call_report_writes(tmp_path):
    from hybrid_engine.reports.timing_report import TimingReportJob

    job = TimingReportJob(tmp_path / "a", 2, 4, CountingRenderer())
    while job.step():
        pass
    _report, stepped = job.finish()
    _report, called = run_timing_report(tmp_path / "b", 2, 4, CountingRenderer())
    stepped_data, called_data = (json.loads(p["json"].read_text()) for p in (stepped, called))
    assert stepped_data["complete"] is True and called_data["complete"] is True
    assert stepped_data["frames"] == called_data["frames"]
    assert stepped["csv"].read_text() == called["csv"].read_text()


def test_a_job_cancelled_before_its_first_frame_writes_nothing_and_says_so(tmp_path):
    from hybrid_engine.reports.timing_report import TimingReportJob

    job = TimingReportJob(tmp_path / "r", 1, 3, CountingRenderer(), warmup_frames=2)
    job.step()  # a warm-up only
    with pytest.raises(TimingReportError, match="before its first frame"):
        job.finish()
    assert list(tmp_path.iterdir()) == []


def test_reversed_range_fails_before_any_frame_is_rendered(tmp_path):
    renderer = CountingRenderer()
    with pytest.raises(FrameRangeError):
        run_timing_report(tmp_path / "r", 3, 1, renderer)
    with pytest.raises(TimingReportError, match="warmup"):
        run_timing_report(tmp_path / "r", 1, 3, renderer, warmup_frames=-1)
    assert renderer.calls == []
    assert list(tmp_path.iterdir()) == []


def test_report_files_carry_whatever_passes_and_counts_the_frames_have(tmp_path):
    """Tracer pass names and per-bounce ray counts (unknown to RASTER) reach JSON and CSV in
    the documented order; warm-up renders are not recorded."""
    renderer = CountingRenderer()
    writer = RecordingChartWriter()
    report, paths = run_timing_report(tmp_path / "r", 3, 6, renderer, requested_mode="HYBRID",
                                      settings={"mode": "HYBRID"}, target_fps=30.0, scene={"name": "Test"},
                                      warmup_frames=2, chart_writer=writer)
    assert renderer.calls == [3, 3, 3, 4, 5, 6]
    data = json.loads(paths["json"].read_text())
    assert [f["frame"] for f in data["frames"]] == [3, 4, 5, 6]
    assert data["pass_order"] == ["extract", "cube_map_raster", "trace", "composite"]
    assert list(data["frames"][0]["passes"]) == data["pass_order"]
    assert data["frames"][1]["passes"]["trace"] == pytest.approx(12.0)
    assert data["frames"][0]["counts"] == {"triangles_total": 100, "triangles_bvh": 0, "rays_bounce_2": 43,
                                           "rays_bounce_10": 7}
    assert data["frames"][0]["triangles_bvh"] == 0 and data["frames"][0]["triangles_total"] == 100
    assert data["timing_source"] == TIMING_SOURCE_WALL
    assert data["warmup_frames"] == 2
    assert data["summary"]["frame_ms"]["mean"] == pytest.approx(np.mean([3.5 + 3 * f for f in range(3, 7)]))
    assert data["settings"] == {"mode": "HYBRID"}
    assert {"platform", "cpu_count", "python"} <= set(data["machine"])
    assert data["gl_renderer"]

    with open(paths["csv"], newline="") as handle:
        rows = list(csv.reader(handle))
    assert rows[0] == ["frame", "mode", "total_ms", "near_size", "extract_ms", "cube_map_raster_ms", "trace_ms",
                       "composite_ms", *timing_report.RAY_STORY_COLUMNS, "triangles_total", "triangles_bvh",
                       "rays_bounce_2", "rays_bounce_10"]
    assert [int(row[0]) for row in rows[1:]] == [3, 4, 5, 6]
    assert float(rows[2][6]) == pytest.approx(12.0)
    assert all(row[3] == "" for row in rows[1:])  # these frames used no near cube
    assert all(row[8:13] == [""] * 5 for row in rows[1:])  # nor traced rays: no rays' story

    ((png, chart),) = writer.charts
    assert png == paths["png"] == tmp_path / "r.png"
    assert chart.pixels.shape == (520, 1000, 3)
    # Every pass's colour appears in the chart, and its name in the labels.
    for color in timing_report.pass_colors(data["pass_order"]):
        assert np.all(chart.pixels == np.array(color, np.uint8), axis=-1).any()
    assert set(data["pass_order"]) <= {label.text for label in chart.labels}


def test_without_a_chart_writer_the_report_writes_json_csv_and_svg_and_says_so(tmp_path):
    """The core has no image library: without a writer it writes no PNG, and the paths it
    returns are the files written."""
    _report, paths = run_timing_report(tmp_path / "r", 1, 2, CountingRenderer())
    assert set(paths) == {"json", "csv", "svg"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.csv", "r.json", "r.svg"]
    assert all(path.is_file() for path in paths.values())


def test_a_pass_missing_from_a_frame_is_an_empty_csv_cell(tmp_path):
    renderer = CountingRenderer(lambda frame: {"extract": 1.0, **({"trace": 2.0} if frame == 2 else {})})
    _, paths = run_timing_report(tmp_path / "r", 1, 2, renderer)
    with open(paths["csv"], newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert rows[0]["trace_ms"] == "" and float(rows[1]["trace_ms"]) == pytest.approx(2.0)


def test_comparison_chart_draws_each_run(tmp_path):
    fast, _ = run_timing_report(tmp_path / "fast", 1, 4, CountingRenderer(lambda f: {"trace": 5.0}))
    slow, _ = run_timing_report(tmp_path / "slow", 1, 4, CountingRenderer(lambda f: {"trace": 20.0}))
    writer = RecordingChartWriter()
    path = timing_report.write_comparison_chart({"HYBRID": fast, "FULL_BVH": slow}, tmp_path / "cmp.png", writer)
    ((written, chart),) = writer.charts
    assert written == path == tmp_path / "cmp.png"
    for color in chart_raster.PALETTE[:2]:
        assert np.all(chart.pixels == np.array(color, np.uint8), axis=-1).sum() > 50
    assert {"HYBRID", "FULL_BVH"} <= {label.text for label in chart.labels}


# ---------------------------------------------------------------------------------------------
# The operator, on an animated scene.

def build_animated_scene(bpy):
    """Blender's default scene (cube, light, camera) at 32x24, RASTER, with the cube's x
    location keyed at every frame of FRAMES: x = CUBE_X_PER_FRAME * frame."""
    scene = bpy.context.scene
    scene.render.engine = "HYBRID_RT"
    scene.render.resolution_x, scene.render.resolution_y = TINY
    scene.render.resolution_percentage = 100
    scene.hybrid_rt.mode = "RASTER"
    scene.hybrid_rt.shadow_resolution = 64
    scene.frame_start, scene.frame_end = FRAMES
    cube = bpy.data.objects["Cube"]
    for frame in range(FRAMES[0], FRAMES[1] + 1):
        cube.location.x = CUBE_X_PER_FRAME * frame
        cube.keyframe_insert("location", index=0, frame=frame)
    scene.frame_set(3)
    return scene


@pytest.fixture
def extraction_log(addon, monkeypatch):
    """Every extraction the engine does: (scene frame, bounds of the cube's triangles)."""
    import bpy

    tracked = addon.blender_adapter.scene_cache.TrackedScene
    original = tracked.scene_data
    log = []

    def logged(self, depsgraph):
        data = original(self, depsgraph)
        geometry = data.geometry
        index = geometry.object_names.index("Cube")
        first, count = geometry.object_ranges[index]
        triangles = geometry.triangles[first:first + count].reshape(-1, 3)
        log.append((bpy.context.scene.frame_current, triangles.min(axis=0), triangles.max(axis=0)))
        return data

    monkeypatch.setattr(tracked, "scene_data", logged)
    return log


def test_operator_writes_a_row_per_frame_whose_passes_sum_to_the_total(addon, extraction_log, tmp_path):
    import bpy

    scene = build_animated_scene(bpy)
    prefix = tmp_path / "report"
    result = bpy.ops.hybrid_rt.timing_report(filepath=str(prefix), frame_start=1, frame_end=5)
    assert result == {"FINISHED"}

    data = json.loads((tmp_path / "report.json").read_text())
    frames = data["frames"]
    assert [f["frame"] for f in frames] == [1, 2, 3, 4, 5]
    for frame in frames:
        assert {"extract", "shade"} <= set(frame["passes"])
        assert sum(frame["passes"].values()) == pytest.approx(frame["total_ms"], rel=PASS_SUM_RTOL, abs=PASS_SUM_ATOL_MS)
        assert frame["triangles_total"] == 12 and frame["triangles_bvh"] == 0
    assert data["timing_source"] == TIMING_SOURCE_WALL
    assert data["requested_mode"] == "RASTER" and data["rendered_modes"] == ["RASTER"]
    assert data["settings"]["mode"] == "RASTER" and data["settings"]["shadow_resolution"] == 64
    assert data["summary"]["target_fps"] == pytest.approx(scene.render.fps / scene.render.fps_base)
    assert data["scene"]["resolution"] == list(TINY)
    assert data["gl_renderer"] == addon.hybrid_engine.gpu.gl_context.renderer_name()
    assert data["machine"]["cpu_count"] >= 1

    with open(tmp_path / "report.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert [int(row["frame"]) for row in rows] == [1, 2, 3, 4, 5]
    for row, frame in zip(rows, frames):
        assert float(row["total_ms"]) == pytest.approx(frame["total_ms"], rel=1e-6)
        assert float(row["extract_ms"]) == pytest.approx(frame["passes"]["extract"], rel=1e-5)

    png = tmp_path / "report.png"
    decoded = read_png(png)
    assert decoded.shape == (520, 1000, 3)
    # Blender's font engine drew the title into the band the core leaves white.
    assert (decoded[:TITLE_ROWS] < 128).all(axis=-1).sum() > 20
    image = bpy.data.images.load(str(png))
    try:
        assert tuple(image.size) == (decoded.shape[1], decoded.shape[0])
        pixels = np.empty(image.size[0] * image.size[1] * image.channels, np.float32)
        image.pixels.foreach_get(pixels)
        blender_rgb = pixels.reshape(image.size[1], image.size[0], image.channels)[::-1, :, :3]
        np.testing.assert_array_equal(np.round(blender_rgb * 255).astype(np.uint8), decoded[..., :3])
    finally:
        bpy.data.images.remove(image)


def test_animation_reaches_the_extracted_geometry_and_the_scene_frame_is_restored(addon, extraction_log, tmp_path):
    """The cube's keyed x location moves its extracted triangles frame by frame; the warm-up
    render is the start frame; the user's current frame and data come back unchanged."""
    import bpy

    scene = build_animated_scene(bpy)
    cube = bpy.data.objects["Cube"]
    before = (scene.frame_current, tuple(cube.location), scene.hybrid_rt.mode)
    bpy.ops.hybrid_rt.timing_report(filepath=str(tmp_path / "r"), frame_start=2, frame_end=5, warmup_frames=1)
    assert [entry[0] for entry in extraction_log] == [2, 2, 3, 4, 5]
    for frame, low, high in extraction_log:
        centre = (low + high) / 2
        np.testing.assert_allclose(centre, [CUBE_X_PER_FRAME * frame, 0.0, 0.0], atol=POSITION_ATOL)
        np.testing.assert_allclose(high - low, [2.0, 2.0, 2.0], atol=POSITION_ATOL)
    assert (scene.frame_current, tuple(cube.location), scene.hybrid_rt.mode) == before


def test_operator_defaults_to_the_scene_frame_range(addon, extraction_log, tmp_path):
    import bpy

    scene = build_animated_scene(bpy)
    scene.frame_start, scene.frame_end = 2, 3
    bpy.ops.hybrid_rt.timing_report(filepath=str(tmp_path / "r"), warmup_frames=0)
    data = json.loads((tmp_path / "r.json").read_text())
    assert [f["frame"] for f in data["frames"]] == [2, 3]
    assert [entry[0] for entry in extraction_log] == [2, 3]


@pytest.mark.parametrize(("start", "end", "message"), [
    (5, 1, "frame_end must not be smaller"),
    (1, timing_report.MAX_FRAMES + 1, "at most"),
])
def test_operator_rejects_a_bad_frame_range_before_rendering(addon, extraction_log, tmp_path, start, end, message):
    import bpy

    scene = build_animated_scene(bpy)
    with pytest.raises(RuntimeError, match=message):
        bpy.ops.hybrid_rt.timing_report(filepath=str(tmp_path / "r"), frame_start=start, frame_end=end)
    assert extraction_log == []
    assert list(tmp_path.iterdir()) == []
    assert scene.frame_current == 3


@pytest.mark.parametrize("case", ["under_a_file", "relative_to_an_unsaved_blend"])
def test_operator_rejects_an_unwritable_path_before_rendering(addon, extraction_log, tmp_path, case):
    import bpy

    build_animated_scene(bpy)
    (tmp_path / "file").write_text("x")
    path = str(tmp_path / "file" / "report") if case == "under_a_file" else "//timing/report"
    with pytest.raises(RuntimeError, match="not a folder|not saved"):
        bpy.ops.hybrid_rt.timing_report(filepath=path, frame_start=1, frame_end=2)
    assert extraction_log == []


def test_a_failure_mid_range_is_reported_and_restores_the_frame(addon, monkeypatch, tmp_path):
    import bpy

    scene = build_animated_scene(bpy)
    engine = addon.blender_adapter.engine
    original = engine.render_depsgraph

    def failing(depsgraph, **kwargs):
        if depsgraph.scene.frame_current == 4:
            raise RuntimeError("GPU went away")
        return original(depsgraph, **kwargs)

    monkeypatch.setattr(engine, "render_depsgraph", failing)
    with pytest.raises(RuntimeError, match="failed at frame 4: GPU went away"):
        bpy.ops.hybrid_rt.timing_report(filepath=str(tmp_path / "r"), frame_start=1, frame_end=5)
    assert scene.frame_current == 3


def _full_bvh_stand_in(addon, monkeypatch):
    """A cheap FULL_BVH: RASTER passes labelled FULL_BVH plus a 'trace' pass, so the
    comparison's files can be checked quickly. Returns the mode the renderer was asked
    for at each render."""
    renderer = addon.blender_adapter.engine.shared_renderer()
    original = renderer.render
    modes_seen = []

    def render(scene_data, camera, settings=None, **kwargs):
        modes_seen.append(settings.mode)
        if settings.mode != "FULL_BVH":
            return original(scene_data, camera, settings, **kwargs)
        from dataclasses import replace
        result = original(scene_data, camera, replace(settings, mode="RASTER"), **kwargs)
        result.mode = "FULL_BVH"
        result.passes["trace"] = 1.0
        return result

    monkeypatch.setattr(renderer, "render", render)
    return modes_seen


def test_full_bvh_comparison_writes_its_own_report_and_a_comparison_chart(addon, monkeypatch, tmp_path):
    import bpy

    scene = build_animated_scene(bpy)
    modes_seen = _full_bvh_stand_in(addon, monkeypatch)
    bpy.ops.hybrid_rt.timing_report(filepath=str(tmp_path / "r"), frame_start=1, frame_end=3,
                                    compare_full_bvh=True, warmup_frames=0)
    assert modes_seen == ["RASTER"] * 3 + ["FULL_BVH"] * 3
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "r.csv", "r.json", "r.png", "r.svg", "r_compare.png", "r_full_bvh.csv", "r_full_bvh.json",
        "r_full_bvh.png", "r_full_bvh.svg"]
    compare = json.loads((tmp_path / "r_full_bvh.json").read_text())
    assert compare["requested_mode"] == "FULL_BVH" and compare["rendered_modes"] == ["FULL_BVH"]
    assert compare["settings"]["mode"] == "FULL_BVH"
    assert [f["frame"] for f in compare["frames"]] == [1, 2, 3]
    assert read_png(tmp_path / "r_compare.png").shape == (520, 1000, 3)
    assert scene.hybrid_rt.mode == "RASTER" and scene.frame_current == 3


def _settings_snapshot(scene) -> dict:
    """Every RNA property of ``scene.hybrid_rt``: its value and whether it is stored in the
    .blend (a write that puts the old value back still leaves the property set)."""
    group = scene.hybrid_rt
    snapshot = {}
    for prop in group.bl_rna.properties:
        name = prop.identifier
        if name == "rna_type":
            continue
        value = getattr(group, name)
        snapshot[name] = (tuple(value) if getattr(prop, "is_array", False) else value, group.is_property_set(name))
    return snapshot


def _watch_renders(addon, monkeypatch, scene, *, fail_on_call: int | None = None):
    """Wrap the adapter's ``render_depsgraph``: each call logs (the mode of the settings it
    was handed, or None when it was handed none; the scene's mode; whether every scene
    setting still reads as before the report), and call number ``fail_on_call`` (from 1)
    raises after logging, as a crash in the middle of the report would."""
    engine = addon.blender_adapter.engine
    original = engine.render_depsgraph
    before = _settings_snapshot(scene)
    calls = []

    def watched(depsgraph, **kwargs):
        settings = kwargs.get("settings")
        scene = depsgraph.scene.original
        calls.append((None if settings is None else settings.mode, scene.hybrid_rt.mode,
                      _settings_snapshot(scene) == before))
        if len(calls) == fail_on_call:
            raise RuntimeError("GPU went away")
        return original(depsgraph, **kwargs)

    monkeypatch.setattr(engine, "render_depsgraph", watched)
    return before, calls


def _assert_rendered_without_writing_the_scene(calls, handed_modes: list[str]) -> None:
    """Every render saw the user's RASTER and untouched settings in the scene, and the engine
    was handed ``handed_modes`` in order (the scene is checked first: it is what matters)."""
    assert [scene_mode for _handed, scene_mode, _kept in calls] == ["RASTER"] * len(handed_modes)
    assert all(kept for _handed, _scene_mode, kept in calls)
    assert [handed for handed, _scene_mode, _kept in calls] == handed_modes


def test_full_bvh_comparison_renders_with_handed_settings_and_never_writes_the_scene_settings(
        addon, monkeypatch, tmp_path):
    """The comparison run must not switch ``scene.hybrid_rt.mode`` to FULL_BVH, even for a
    moment: a crash while it renders would leave the artist's file changed. The engine is
    handed FULL_BVH settings while the scene keeps reading the user's RASTER, and afterwards
    every scene setting (value and stored state) is as it was."""
    import bpy

    scene = build_animated_scene(bpy)
    _full_bvh_stand_in(addon, monkeypatch)
    before, calls = _watch_renders(addon, monkeypatch, scene)
    result = bpy.ops.hybrid_rt.timing_report(filepath=str(tmp_path / "r"), frame_start=1, frame_end=3,
                                             compare_full_bvh=True, warmup_frames=0)
    assert result == {"FINISHED"}
    _assert_rendered_without_writing_the_scene(calls, ["RASTER"] * 3 + ["FULL_BVH"] * 3)
    assert _settings_snapshot(scene) == before
    assert json.loads((tmp_path / "r_full_bvh.json").read_text())["rendered_modes"] == ["FULL_BVH"]


def test_a_failure_mid_comparison_is_reported_and_the_scene_settings_were_never_written(
        addon, monkeypatch, tmp_path):
    """A frame of the FULL_BVH run that raises is reported with its frame; at the moment it
    raised the scene's settings were still the user's (so even a crash that skips every
    clean-up would leave the file as it was), and they are the user's afterwards."""
    import bpy

    scene = build_animated_scene(bpy)
    _full_bvh_stand_in(addon, monkeypatch)
    before, calls = _watch_renders(addon, monkeypatch, scene, fail_on_call=5)  # the comparison's second frame
    with pytest.raises(RuntimeError, match="failed at frame 2: GPU went away"):
        bpy.ops.hybrid_rt.timing_report(filepath=str(tmp_path / "r"), frame_start=1, frame_end=3,
                                        compare_full_bvh=True, warmup_frames=0)
    _assert_rendered_without_writing_the_scene(calls, ["RASTER"] * 3 + ["FULL_BVH"] * 2)
    assert _settings_snapshot(scene) == before
    assert scene.frame_current == 3


def test_keyframed_settings_reach_each_frame_of_both_runs(addon, monkeypatch, tmp_path):
    """The settings handed to the engine are the scene's at the frame being rendered, as F12
    renders an animation: a keyframed setting changes from frame to frame in the report's
    run and in the FULL_BVH comparison alike (only the comparison's mode is overridden)."""
    import bpy

    scene = build_animated_scene(bpy)
    scene.hybrid_rt.shadow_resolution = 64
    scene.hybrid_rt.keyframe_insert("shadow_resolution", frame=1)
    scene.hybrid_rt.shadow_resolution = 128
    scene.hybrid_rt.keyframe_insert("shadow_resolution", frame=2)
    scene.frame_set(3)
    _full_bvh_stand_in(addon, monkeypatch)
    engine = addon.blender_adapter.engine
    original = engine.render_depsgraph
    seen = []

    def watched(depsgraph, **kwargs):
        seen.append((kwargs["settings"].mode, kwargs["settings"].shadow_resolution))
        return original(depsgraph, **kwargs)

    monkeypatch.setattr(engine, "render_depsgraph", watched)
    bpy.ops.hybrid_rt.timing_report(filepath=str(tmp_path / "r"), frame_start=1, frame_end=2,
                                    compare_full_bvh=True, warmup_frames=0)
    assert seen == [("RASTER", 64), ("RASTER", 128), ("FULL_BVH", 64), ("FULL_BVH", 128)]


def test_operator_and_button_are_registered(addon):
    import bpy

    assert bpy.ops.hybrid_rt.timing_report.idname() == "HYBRID_RT_OT_timing_report"
    source = inspect.getsource(addon.ui.panels.RENDER_PT_hybrid_rt_diagnostics.draw)
    assert '"hybrid_rt.timing_report"' in source


@pytest.mark.slow
def test_script_writes_a_report_of_a_saved_blend(addon, tmp_path):
    """scripts/timing_report.py in a fresh interpreter, on a .blend saved from the animated scene."""
    import bpy

    build_animated_scene(bpy)
    blend = tmp_path / "animated.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
    blend_bytes = blend.read_bytes()
    completed = subprocess.run(
        [sys.executable, str(REPO_ROOT / "scripts" / "timing_report.py"), "--blend", str(blend),
         "--prefix", str(tmp_path / "report"), "--start", "2", "--end", "4"],
        capture_output=True, text=True, timeout=300,
    )
    assert completed.returncode == 0, completed.stdout + completed.stderr
    assert "3 frames" in completed.stdout
    data = json.loads((tmp_path / "report.json").read_text())
    assert [f["frame"] for f in data["frames"]] == [2, 3, 4]
    assert blend.read_bytes() == blend_bytes  # the .blend is never saved


@pytest.mark.parametrize("budget_ms,expected", [(0.001, "near_min"), (1.0e5, "near_max")])
def test_a_frame_budget_report_sizes_the_near_cube_per_frame_and_writes_it(addon, tmp_path, budget_ms, expected):
    """Frame Budget in a timing report: an unreachable budget shrinks the near cube to its
    minimum, a generous one grows it to its maximum, and the CSV and JSON say the size each
    frame used."""
    import bpy

    scene = build_animated_scene(bpy)
    settings = scene.hybrid_rt
    settings.mode = "HYBRID"
    settings.cube_resolution = 32
    settings.near_cube_mode = "BUDGET"
    settings.near_min, settings.near_max, settings.near_size = 0.5, 4.0, 2.0
    settings.frame_budget_ms = budget_ms
    bpy.ops.hybrid_rt.timing_report(filepath=str(tmp_path / "r"), frame_start=1, frame_end=16, warmup_frames=0)
    with open(tmp_path / "r.csv", newline="") as handle:
        sizes = [float(row["near_size"]) for row in csv.DictReader(handle)]
    assert sizes[0] == pytest.approx(2.0), sizes
    assert all(0.5 - 1e-6 <= size <= 4.0 + 1e-6 for size in sizes)
    assert sizes[-1] == pytest.approx(getattr(settings, expected)), sizes
    frames = json.loads((tmp_path / "r.json").read_text())["frames"]
    assert [f["near_size"] for f in frames] == pytest.approx(sizes)


class _FakeWindowManager:
    """The window manager calls of the modal report, recorded (background Blender has no
    event loop, so the test plays Blender: it sends the timer and Esc events itself)."""

    def __init__(self) -> None:
        self.calls = []

    def __getattr__(self, name):
        return lambda *args, **kwargs: self.calls.append(name)


def _modal_context(bpy):
    import types

    status = []
    return types.SimpleNamespace(
        scene=bpy.context.scene, window=object(), screen=None, window_manager=_FakeWindowManager(),
        workspace=types.SimpleNamespace(status_text_set=status.append),
        evaluated_depsgraph_get=bpy.context.evaluated_depsgraph_get), status


def _modal_operator(addon, tmp_path, reports, **properties):
    """The operator's methods on a plain object: what Blender's instance would hold."""
    import types

    operator = addon.operators.timing_report.HYBRID_RT_OT_timing_report
    values = dict(filepath=str(tmp_path / "r"), frame_start=1, frame_end=5, compare_full_bvh=False, warmup_frames=0)
    fake = types.SimpleNamespace(**{**values, **properties},
                                 report=lambda levels, text: reports.append((levels, text)))
    for name in ("_start_modal", "_start_job", "_close_job", "modal", "_end", "_announce"):
        setattr(fake, name, types.MethodType(getattr(operator, name), fake))
    return fake


@pytest.mark.parametrize("cancel_after", [None, 2])
def test_the_interactive_report_renders_a_frame_per_timer_event_and_esc_writes_what_it_has(
        addon, tmp_path, cancel_after):
    import types

    import bpy

    scene = build_animated_scene(bpy)
    reports = []
    fake = _modal_operator(addon, tmp_path, reports)
    context, status = _modal_context(bpy)
    settings = addon.blender_adapter.properties.settings_from_scene(scene)
    assert fake._start_modal(context, tmp_path / "r", range(1, 6), settings) == {"RUNNING_MODAL"}
    assert {"modal_handler_add", "event_timer_add", "progress_begin"} <= set(context.window_manager.calls)
    timer, esc = types.SimpleNamespace(type="TIMER"), types.SimpleNamespace(type="ESC")
    results = []
    for step in range(10):
        event = esc if cancel_after is not None and step == cancel_after else timer
        results.append(fake.modal(context, event))
        if results[-1] != {"RUNNING_MODAL"}:
            break
    data = json.loads((tmp_path / "r.json").read_text())
    if cancel_after is None:
        assert results[-1] == {"FINISHED"} and len(results) == 5  # the UI had the loop back after every frame
        assert data["complete"] is True and [f["frame"] for f in data["frames"]] == [1, 2, 3, 4, 5]
    else:
        assert results[-1] == {"CANCELLED"}
        assert data["complete"] is False and [f["frame"] for f in data["frames"]] == [1, 2]
        assert any("cancelled" in text for _levels, text in reports)
    assert status[-1] is None and "Esc to cancel" in status[0]  # the status bar was used, then cleared
    assert {"event_timer_remove", "progress_end"} <= set(context.window_manager.calls)
    assert scene.frame_current == 3 and scene.hybrid_rt.mode == "RASTER"  # put back


@pytest.mark.parametrize("fail_on_call", [None, 5], ids=["completed", "failed_mid_comparison"])
def test_the_interactive_comparison_never_writes_the_scene_settings(addon, monkeypatch, tmp_path, fail_on_call):
    """The modal report's FULL_BVH run, played to the end or stopped by a frame that raises,
    hands FULL_BVH to the engine while ``scene.hybrid_rt`` keeps every user value: the modal
    path must not store and restore the mode around the run either."""
    import types

    import bpy

    scene = build_animated_scene(bpy)
    _full_bvh_stand_in(addon, monkeypatch)
    before, calls = _watch_renders(addon, monkeypatch, scene, fail_on_call=fail_on_call)
    reports = []
    fake = _modal_operator(addon, tmp_path, reports, compare_full_bvh=True, frame_end=3)
    context, _status = _modal_context(bpy)
    settings = addon.blender_adapter.properties.settings_from_scene(scene)
    assert fake._start_modal(context, tmp_path / "r", range(1, 4), settings) == {"RUNNING_MODAL"}
    timer = types.SimpleNamespace(type="TIMER")
    results = []
    for _step in range(10):
        results.append(fake.modal(context, timer))
        if results[-1] != {"RUNNING_MODAL"}:
            break
    if fail_on_call is None:
        assert results[-1] == {"FINISHED"}
        _assert_rendered_without_writing_the_scene(calls, ["RASTER"] * 3 + ["FULL_BVH"] * 3)
        assert (tmp_path / "r_compare.png").is_file()
    else:
        assert results[-1] == {"CANCELLED"}
        assert any("failed at frame 2: GPU went away" in text for _levels, text in reports)
        _assert_rendered_without_writing_the_scene(calls, ["RASTER"] * 3 + ["FULL_BVH"] * 2)
    assert _settings_snapshot(scene) == before
    assert scene.frame_current == 3
