# SPDX-License-Identifier: GPL-3.0-or-later
"""The row passes' cost benchmark (benchmarks/row_passes_cost.py) times the three passes it
names, each of which ran, and leaves the surface-motion switch as it found it."""
from __future__ import annotations

from benchmarks import row_passes_cost
from hybrid_engine.passes.surface_motion import surface_motion


def test_the_benchmark_times_each_pass_it_names_and_restores_the_switch(gl):
    report = row_passes_cost.measure(detail=0.02, size=(96, 54), frames=1, cube_resolution=128)
    assert surface_motion.FOLLOW_MOVES
    assert report["triangles"] > 1000
    for name in ("cryptomatte", "vector"):
        assert report[name]["ms"] > 0.0 and report[name]["host_ms"] > 0.0, name
    assert "surface_motion" in report and "ms" in report["surface_motion"]
    assert "vector" in row_passes_cost.format_report(report)
