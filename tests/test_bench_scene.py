# SPDX-License-Identifier: GPL-3.0-or-later
"""The scene-library benchmark (scripts/bench_scene.py): HYBRID against FULL_BVH on frames
extracted from a Blender scene, in a child process as a user runs it, must write every
figure the Chess benchmark reports (benchmarks/bench.py frame section) with a finite
speedup and FLIP; a scene without its files must stop the run with status 2, naming the file,
before anything is measured.
"""
from __future__ import annotations

import json
import math
import subprocess
import sys

import pytest

from conftest import REPO_ROOT, SHARED_SCENES
from test_bench import FRAME_KEYS, FULL_BVH_PASSES, HYBRID_PASSES

SCRIPT = REPO_ROOT / "scripts" / "bench_scene.py"
# Everything bench.frame_section reports but its Chess build time, and what the script adds.
COMPARISON_KEYS = FRAME_KEYS | {
    "detail", "near_size", "cube_resolution", "cube_far", "cube_march", "rounds", "flip_per_frame",
    "triangles_uploaded_median", "objects_near", "objects_total", "rays_hybrid", "rays_cube_map",
    "rays_full_bvh", "speedup_without_upload"}
SCRIPT_KEYS = {"scene_label", "credits", "scene_build_s", "extract_ms", "machine"}
TINY = ("--detail", "0.02", "--resolution", "64x36", "--rounds", "1")


def run_script(*args: str, cwd) -> subprocess.CompletedProcess:
    # Loading Sponza and compiling both modes' kernels took past 300 s on a machine running
    # three benchmarks beside the suite; the limit only has to catch a hang.
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True, timeout=900,
                          cwd=cwd)


def check_report(report: dict, stdout: str) -> None:
    assert COMPARISON_KEYS | SCRIPT_KEYS <= report.keys()
    assert report["resolution"] == "64x36" and report["max_depth"] == 4 and report["rounds"] == 1
    assert report["hybrid_ms"] > 0 and report["full_bvh_ms"] > 0
    assert math.isfinite(report["speedup"]) and math.isfinite(report["speedup_without_upload"])
    assert math.isclose(report["speedup"], report["full_bvh_ms"] / report["hybrid_ms"], rel_tol=1e-3)
    assert math.isfinite(report["flip_mean"]) and 0.0 <= report["flip_mean"] < 1.0
    assert len(report["flip_per_frame"]) == 1
    assert 0 < report["triangles_bvh"] < report["triangles_total"], "HYBRID culls to the near cube"
    assert set(report["passes_hybrid"]) == HYBRID_PASSES
    assert set(report["passes_full_bvh"]) == FULL_BVH_PASSES
    assert "speedup" in stdout and "FLIP" in stdout and "FULL_BVH ms" in stdout, "the frame table is printed"


def test_chess_from_the_scene_library_gives_every_figure(tmp_path):
    out = tmp_path / "chess.json"
    run = run_script("--scene", "chess", *TINY, "--json", str(out), cwd=tmp_path)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    report = json.loads(out.read_text())
    check_report(report, run.stdout)
    # The scene's own settings: the library gives chess the benchmark's near cube and far plane.
    assert report["near_size"] == 3.5 and report["cube_far"] == 100.0
    assert report["scene"].startswith("chess (scene library, detail 0.02, frames 2-2)")


@pytest.mark.skipif(not (SHARED_SCENES / "sponza").is_dir(), reason="the shared Sponza files are not here")
def test_sponza_with_a_command_line_override(tmp_path):
    out = tmp_path / "sponza.json"
    run = run_script("--scene", "sponza", "--assets", str(SHARED_SCENES), *TINY, "--near-size", "3",
                     "--json", str(out), cwd=tmp_path)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    report = json.loads(out.read_text())
    check_report(report, run.stdout)
    assert report["near_size"] == 3.0 and report["cube_far"] == 200.0  # overridden; the scene's own
    assert "Sponza" in report["scene_label"]


def test_a_scene_without_its_files_stops_before_anything_is_measured(tmp_path):
    assets, out = tmp_path / "empty_assets", tmp_path / "sponza.json"
    assets.mkdir()
    run = run_script("--scene", "sponza", "--assets", str(assets), *TINY, "--json", str(out), cwd=tmp_path)
    assert run.returncode == 2, run.stdout[-2000:] + run.stderr[-2000:]
    assert "Sponza_blender.gltf" in run.stderr and str(assets / "sponza") in run.stderr
    assert not out.exists() and "speedup" not in run.stdout
