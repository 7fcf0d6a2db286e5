# SPDX-License-Identifier: GPL-3.0-or-later
"""farm/flamenco/hybrid_rt_render.js, the Flamenco job type: compiled under Node.js with
Flamenco's job-authoring globals stubbed (tests/flamenco_harness.js), its engine check run in
bpy, and its timing reports written and merged as the job's tasks would."""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
import textwrap

import pytest

from conftest import REPO_ROOT

JOB_TYPE = REPO_ROOT / "farm" / "flamenco" / "hybrid_rt_render.js"
HARNESS = REPO_ROOT / "tests" / "flamenco_harness.js"
RENDER_DIR = "/render/shot/2024-05-06_070809"  # the harness's {timestamp}
SETTINGS = {
    "frames": "1-10", "chunk_size": 4, "render_output_path": "/render/shot/{timestamp}/######",
    "blendfile": "/projects/shot.blend", "format": "OPEN_EXR", "engine": "HYBRID_RT",
}

pytestmark = pytest.mark.skipif(shutil.which("node") is None, reason="needs Node.js")


def compile_job(**settings) -> dict:
    """The compiled job: tasks with their commands and dependencies, and the job type's Python."""
    job = {"settings": {**SETTINGS, **settings}}
    completed = subprocess.run(["node", str(HARNESS), str(JOB_TYPE), json.dumps(job)],
                               capture_output=True, text=True, timeout=60)
    assert completed.returncode == 0, completed.stderr
    return json.loads(completed.stdout)


@pytest.fixture(scope="module")
def python_sources() -> dict[str, str]:
    return compile_job()["python"]


def render_args(check: str, frames: str) -> list[str]:
    return ["--python-exit-code", "1", "--python-expr", check,
            "--render-output", f"{RENDER_DIR}/######", "--render-format", "OPEN_EXR", "--render-frame", frames]


# ---------------------------------------------------------------------------------------------
# The compiled job.

def test_a_frame_range_becomes_one_checked_render_task_per_chunk():
    job = compile_job()
    check = job["python"]["ENGINE_CHECK_PY"]
    assert job["error"] is None
    assert [(t["name"], t["type"], t["dependencies"]) for t in job["tasks"]] == [
        ("render-1-4", "blender", []), ("render-5-8", "blender", []), ("render-9-10", "blender", [])]
    for task, frames in zip(job["tasks"], ("1..4", "5..8", "9..10")):
        (command,) = task["commands"]
        assert command == {"name": "blender-render", "parameters": {
            "exe": "{blender}", "exeArgs": "{blenderArgs}", "argsBefore": [], "blendfile": "/projects/shot.blend",
            "args": render_args(check, frames)}}
    assert job["settings"]["render_output_path"] == f"{RENDER_DIR}/######"


def test_timing_reports_add_a_report_per_chunk_and_a_merge_after_every_chunk():
    job = compile_job(timing_reports=True, frames="1-3,7-9", chunk_size=4)
    check = job["python"]["ENGINE_CHECK_PY"]
    *renders, merge = job["tasks"]
    assert [t["name"] for t in renders] == ["render-1-3,7", "render-8-9"]
    folder = f"{RENDER_DIR}/hybrid_rt_timing_chunks"
    expected_ranges = ([[1, 3, f"{folder}/hybrid_rt_timing_1-3"], [7, 7, f"{folder}/hybrid_rt_timing_7-7"]],
                       [[8, 9, f"{folder}/hybrid_rt_timing_8-9"]])
    for task, frames, ranges in zip(renders, ("1..3,7", "8..9"), expected_ranges):
        args = task["commands"][0]["parameters"]["args"]
        assert args[:10] == render_args(check, frames)
        assert args[10] == "--python-expr" and len(args) == 12
        binding, body = args[11].split("\n", 1)
        assert binding.startswith("HYBRID_RT_TIMING = ")
        assert json.loads(binding.removeprefix("HYBRID_RT_TIMING = ")) == {"folder": folder, "ranges": ranges}
        assert body == job["python"]["TIMING_PY"]
    assert merge["name"] == "merge-timing-reports" and merge["dependencies"] == [t["name"] for t in renders]
    (command,) = merge["commands"]
    assert command["parameters"]["blendfile"] == ""
    args = command["parameters"]["args"]
    assert args[:3] == ["--python-exit-code", "1", "--python-expr"]
    binding = args[3].split("\n", 1)[0]
    assert json.loads(binding.removeprefix("HYBRID_RT_MERGE = ")) == {
        "folder": folder, "prefix": f"{RENDER_DIR}/hybrid_rt_timing", "frames": "1-3,7-9"}


def test_a_scene_that_does_not_render_with_hybrid_rt_is_refused_at_submission():
    job = compile_job(engine="BLENDER_EEVEE_NEXT")
    assert "renders with BLENDER_EEVEE_NEXT, not Hybrid RT" in job["error"] and job["tasks"] == []
    assert "not \"FFMPEG\"" in compile_job(format="FFMPEG")["error"]


def test_the_job_type_offers_the_settings_of_a_blender_render_and_the_timing_option():
    keys = [s["key"] for s in compile_job()["job_type"]["settings"]]
    for key in ("frames", "chunk_size", "render_output_path", "blendfile", "format", "timing_reports"):
        assert key in keys


# ---------------------------------------------------------------------------------------------
# The engine check, in bpy.

def run_check(source: str) -> None:
    exec(compile(source, "<hybrid_rt engine check>", "exec"), {"__name__": "__main__"})


def test_the_engine_check_passes_with_hybrid_rt(addon, python_sources, capsys):
    import bpy

    bpy.context.scene.render.engine = "HYBRID_RT"
    run_check(python_sources["ENGINE_CHECK_PY"])
    assert "Hybrid RT farm check passed: scene 'Scene'" in capsys.readouterr().out


def test_the_engine_check_fails_a_scene_that_renders_with_eevee(addon, python_sources):
    import bpy

    bpy.context.scene.render.engine = "BLENDER_EEVEE"
    with pytest.raises(RuntimeError, match="scene 'Scene' of the file renders with BLENDER_EEVEE, not Hybrid RT"):
        run_check(python_sources["ENGINE_CHECK_PY"])


def test_the_engine_check_fails_where_the_addon_is_not_registered(python_sources):
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=False)
    with pytest.raises(RuntimeError, match="Hybrid RT render engine is not registered on this worker"):
        run_check(python_sources["ENGINE_CHECK_PY"])


def test_a_saved_hybrid_rt_file_opened_on_a_worker_without_the_extension_fails_the_check(python_sources, tmp_path):
    """Blender opens the file and would render it with EEVEE; the check fails the chunk first."""
    blend = tmp_path / "shot.blend"
    save = f"""
        from addon_loader import load_addon
        import bpy
        load_addon().register()
        bpy.context.scene.render.engine = "HYBRID_RT"
        bpy.ops.wm.save_as_mainfile(filepath={str(blend)!r})
        """
    worker = f"""
        import bpy
        bpy.ops.wm.open_mainfile(filepath={str(blend)!r})
        print("ENGINE", bpy.context.scene.render.engine)
        check = {python_sources["ENGINE_CHECK_PY"]!r}
        try:
            exec(check, {{"__name__": "__main__"}})
            print("RENDERS")
        except RuntimeError as exc:
            print("FAILED:", exc)
        """
    for code in (save, worker):
        completed = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                                   timeout=120, cwd=REPO_ROOT / "scripts")
        assert completed.returncode == 0, completed.stdout + completed.stderr
    assert "RENDERS" not in completed.stdout
    assert "ENGINE BLENDER_EEVEE" in completed.stdout  # the silent fallback the check stops
    assert f"FAILED: Hybrid RT farm check failed: the Hybrid RT render engine is not registered on this worker, " \
           f"so Blender would render {blend}" in completed.stdout


# ---------------------------------------------------------------------------------------------
# Timing reports: each chunk's, and the merge task's.

def test_chunk_reports_written_by_the_tasks_merge_into_one_report(addon, python_sources, tmp_path):
    import bpy

    scene = bpy.context.scene
    scene.render.engine = "HYBRID_RT"
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 16, 12, 100
    scene.hybrid_rt.mode = "RASTER"
    scene.hybrid_rt.shadow_resolution = 64
    folder = tmp_path / "frames" / "hybrid_rt_timing_chunks"  # does not exist yet: the task makes it
    chunks = [[[3, 3, str(folder / "hybrid_rt_timing_3-3")]], [[1, 2, str(folder / "hybrid_rt_timing_1-2")]]]
    for ranges in chunks:
        exec(python_sources["TIMING_PY"], {"HYBRID_RT_TIMING": {"folder": str(folder), "ranges": ranges}})
    assert sorted(p.name for p in folder.glob("*.json")) == ["hybrid_rt_timing_1-2.json", "hybrid_rt_timing_3-3.json"]

    entry = bpy.context.preferences.addons.new()  # enabled through the loader: give it its entry
    entry.module = addon.__name__
    try:
        prefix = tmp_path / "frames" / "hybrid_rt_timing"
        exec(python_sources["MERGE_PY"],
             {"HYBRID_RT_MERGE": {"folder": str(folder), "prefix": str(prefix), "frames": "1-3"}})
    finally:
        bpy.context.preferences.addons.remove(entry)
    merged = json.loads(prefix.with_suffix(".json").read_text())
    assert [frame["frame"] for frame in merged["frames"]] == [1, 2, 3]
    assert merged["summary"]["frames"] == 3
    totals = [frame["total_ms"] for frame in merged["frames"]]
    assert merged["summary"]["frame_ms"]["mean"] == pytest.approx(sum(totals) / 3)
    assert all(prefix.with_suffix(suffix).is_file() for suffix in (".csv", ".svg", ".png"))


def test_the_merge_script_merges_two_chunk_reports_with_the_summary_recomputed(tmp_path):
    from hybrid_engine.reports.timing_report import summarize, write_json
    from test_timing_merge import chunk

    folder = tmp_path / "chunks"
    folder.mkdir()
    write_json(chunk([4, 5, 6]), folder / "hybrid_rt_timing_4-6.json")
    write_json(chunk([1, 2, 3]), folder / "hybrid_rt_timing_1-3.json")
    prefix = tmp_path / "merged"
    script = [sys.executable, str(REPO_ROOT / "scripts" / "merge_timing_reports.py"), "--prefix", str(prefix),
              "--folder", str(folder)]
    completed = subprocess.run(script + ["--frames", "1-6"], capture_output=True, text=True, timeout=60)
    assert completed.returncode == 0, completed.stderr
    merged = json.loads(prefix.with_suffix(".json").read_text())
    assert [frame["frame"] for frame in merged["frames"]] == [1, 2, 3, 4, 5, 6]
    expected = summarize(chunk([1, 2, 3, 4, 5, 6]).records, 30.0)
    assert merged["summary"]["frame_ms"] == pytest.approx(expected["frame_ms"])
    assert merged["summary"]["pass_mean_ms"] == pytest.approx(expected["pass_mean_ms"])
    assert len(prefix.with_suffix(".csv").read_text().splitlines()) == 7

    missing = subprocess.run(script + ["--frames", "1-7"], capture_output=True, text=True, timeout=60)
    assert missing.returncode == 1 and "no chunk reported the frames [7]" in missing.stderr
