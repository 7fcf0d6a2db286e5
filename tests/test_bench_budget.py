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
