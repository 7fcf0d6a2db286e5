# SPDX-License-Identifier: GPL-3.0-or-later
"""The kernel-variant benchmark (benchmarks/kernel_variants.py) runs end to end at tiny sizes
and reports both shapes of every row with their ratio."""
from __future__ import annotations

import json
import math

from benchmarks import kernel_variants


def test_quick_run_times_both_shapes_of_every_kernel(gl, tmp_path, capsys):
    out = tmp_path / "kernels.json"
    assert kernel_variants.main(["--quick", "--rounds", "2", "--json", str(out)]) == 0
    report = json.loads(out.read_text())
    names = [row["name"] for row in report["rows"]]
    assert [name.split()[0] for name in names] == ["sort", "scan", "scan", "LBVH"]
    for row in report["rows"]:
        assert row["cpu_ms"] > 0 and row["gpu_ms"] > 0 and math.isfinite(row["gpu_over_cpu"])
        assert math.isclose(row["gpu_over_cpu"], row["gpu_ms"] / row["cpu_ms"], rel_tol=5e-2)
    printed = capsys.readouterr().out
    assert "ctx.finish()" in printed and "alternating" in printed and report["commit"] in printed
    assert all(name in printed for name in names)
