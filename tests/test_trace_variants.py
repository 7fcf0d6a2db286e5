# SPDX-License-Identifier: GPL-3.0-or-later
"""The trace-variant benchmark (benchmarks/trace_variants.py) runs end to end on a small
Chess frame and reports both shapes of the trace with equal counters."""
from __future__ import annotations

import json

from benchmarks import trace_variants


def test_quick_run_times_the_megakernel_and_the_waves_side_by_side(gl, tmp_path):
    out = tmp_path / "trace.json"
    assert trace_variants.main(["--quick", "--rounds", "2", "--json", str(out)]) == 0
    trace = json.loads(out.read_text())["trace"]
    assert trace["megakernel_trace_ms"] > 0 and trace["waves_trace_ms"] > 0
    assert trace["counters_identical"] and trace["wave_bytes_per_pixel"] > 0
