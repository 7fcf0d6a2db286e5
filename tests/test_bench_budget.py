# SPDX-License-Identifier: GPL-3.0-or-later
"""scripts/bench_budget.py, run as a user runs it on a tiny Chess: it follows the camera path
in Fixed and Frame Budget mode and in FULL_BVH, and reports the share of frames within the
budget, the FLIP against FULL_BVH and the near sizes Budget mode chose (within its limits)."""
from __future__ import annotations

import json
import statistics
import subprocess
import sys

import pytest

from conftest import REPO_ROOT


def test_the_budget_script_compares_fixed_and_budget_modes_on_a_camera_path(tmp_path):
    out = tmp_path / "budget.json"
    done = subprocess.run(
        [sys.executable, str(REPO_ROOT / "scripts" / "bench_budget.py"), "--frames", "4", "--detail", "0.05",
         "--resolution", "96x54", "--budget-ms", "0.5", "--near-min", "0.5", "--near-max", "3.0", "--json", str(out)],
        cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    report = json.loads(out.read_text())
    assert report["budget_ms"] == 0.5 and report["frames"] == 4
    sizes = report["budget"]["near_sizes"]
    assert len(sizes) == 4 and all(0.5 <= s <= 3.0 for s in sizes)
    assert sizes[-1] < sizes[0]  # an unreachable budget shrinks the cube
    assert set(report["fixed"]["near_sizes"]) == {report["fixed_near_size"]}
    for mode in ("fixed", "budget", "fixed_at_budget_median_size"):
        assert 0.0 <= report[mode]["within_share"] <= 1.0 and report[mode]["flip_vs_full_bvh"] >= 0.0
    # The comparison at equal cost renders at the median size Budget mode chose.
    same_cost = report["fixed_at_budget_median_size"]["near_sizes"]
    assert same_cost == pytest.approx([statistics.median(sizes)] * 4, rel=1e-3)
    assert "budget:" in done.stdout


def load_replay():
    import importlib.util

    spec = importlib.util.spec_from_file_location("budget_replay", REPO_ROOT / "scripts" / "budget_replay.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_replay_interpolates_a_frame_between_recorded_sizes_in_log_time_over_log_size():
    replay = load_replay()
    recording = replay.Recording({"sizes": {"1.0": {"warm": [], "frames": [10.0, 30.0]},
                                            "4.0": {"warm": [], "frames": [40.0, 30.0]}}})
    assert recording.time(recording.frames, 0, 2.0) == pytest.approx(20.0)
    assert recording.time(recording.frames, 1, 2.0) == pytest.approx(30.0)
    assert recording.time(recording.frames, 0, 9.0) == pytest.approx(40.0)  # clamped to the recorded range


def test_a_replayed_controller_finds_the_size_that_meets_the_budget():
    """Frames cost 10 ms per unit of size: a budget of 30 ms from size 8 is met once the
    controller has walked down to about 3, and Fixed mode at 8 meets it on no frame."""
    replay = load_replay()
    import random

    frames = 40
    recording = replay.Recording({"sizes": {str(s): {"warm": [10.0 * s], "frames": [10.0 * s] * frames}
                                            for s in (1.0, 2.0, 4.0, 8.0)}})
    controller = replay.NearCubeBudget(30.0, 0.5, 10.0, 8.0)
    share = replay.replay(recording, controller, 0.0, random.Random(0))
    assert 0.8 <= share < 1.0 and controller.size == pytest.approx(3.0, rel=0.1)


def test_record_then_replay_as_a_user_runs_them(tmp_path):
    out = tmp_path / "sizes.json"
    script = str(REPO_ROOT / "scripts" / "budget_replay.py")
    done = subprocess.run([sys.executable, script, "record", "--frames", "3", "--detail", "0.05",
                           "--resolution", "96x54", "--sizes", "1,3", "--out", str(out)],
                          cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    data = json.loads(out.read_text())
    assert set(data["sizes"]) == {"1.0", "3.0"}
    assert all(len(row["warm"]) == 2 and len(row["frames"]) == 3 for row in data["sizes"].values())
    done = subprocess.run([sys.executable, script, "replay", str(out), "--fixed-size", "3", "--runs", "5"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "as recorded:" in done.stdout and "of runs reach 90%" in done.stdout
