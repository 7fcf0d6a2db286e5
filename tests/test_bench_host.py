# SPDX-License-Identifier: GPL-3.0-or-later
"""The host section of the benchmark (scripts/bench_host.py, benchmarks/bench.py ``host``): run
as a user runs it, it follows five Blender scenes frame by frame and reports what each frame
cost the CPU; no frame walks the instances: nothing but the camera moved, or only known
objects moved or deformed."""
from __future__ import annotations

import json
import subprocess
import sys

from conftest import REPO_ROOT

SCRIPT = REPO_ROOT / "scripts" / "bench_host.py"


def test_the_host_script_reports_every_scene_and_skips_unchanged_ones(tmp_path):
    out = tmp_path / "host.json"
    done = subprocess.run([sys.executable, str(SCRIPT), "--quick", "--frames", "3", "--json", str(out)],
                          cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    report = json.loads(out.read_text())
    assert set(report) == {"static", "chess", "deform", "instances", "scatter"}
    for name, row in report.items():
        assert row["triangles"] > 0 and row["frames"] == 3, name
        assert row["host_ms"] == row["host_ms"] and row["host_ms"] >= 0, name  # finite
    assert report["instances"]["triangles"] == 320 * 200  # 200 instances of one 320-triangle mesh
    # Moving and deforming objects are followed without walking the instances.
    assert all(row["walked_frames"] == 0 for row in report.values()), report
    assert report["scatter"]["triangles"] > 80 * 400  # about 500 instances of 80 triangles
    assert "host: per frame after the first" in done.stdout


def test_the_benchmark_skips_the_host_section_without_bpy_and_says_why(monkeypatch):
    from benchmarks import bench

    monkeypatch.setattr("importlib.util.find_spec", lambda name, *a: None if name == "bpy" else object())
    section = bench.host_section(quick=True)
    assert "bpy" in section["skipped"]
    assert "host: skipped" in bench.format_tables({"machine": {"gl_renderer": "x", "cpu_count": 1,
                                                              "gpu_timing": "x"}, "host": section})
