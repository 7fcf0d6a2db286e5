# SPDX-License-Identifier: GPL-3.0-or-later
"""The radiance cache's cost benchmark (benchmarks/radiance_cache_cost.py) times the shade
step with the cache on and off, on a view where the cache is in use."""
from __future__ import annotations

from benchmarks import radiance_cache_cost


def test_the_benchmark_times_the_shade_step_both_ways_with_the_cells_in_use(gl):
    report = radiance_cache_cost.measure(detail=0.02, size=(96, 54), frames=1, cube_resolution=128)
    assert report["cells_filled"]
    for name in ("on", "off"):
        assert report[name]["shade_ms"] > 0.0 and report[name]["shade_host_ms"] > 0.0, name
    assert report["ratio"] > 0.0
    assert "on / off" in radiance_cache_cost.format_report(report)
