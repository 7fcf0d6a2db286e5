# SPDX-License-Identifier: GPL-3.0-or-later
"""The benchmark runs end to end (at tiny sizes) and writes every documented key."""
from __future__ import annotations

import json
import math
import subprocess
import sys

from conftest import REPO_ROOT

LBVH_KEYS = {"triangles", "build_ms", "embree_build_ms", "numpy_build_ms"}
TRACE_KEYS = {"rays", "kind", "mrays_per_s", "embree_mrays_per_s", "embree_threads",
              "hit_agreement"}


def test_quick_bench_writes_every_key(tmp_path):
    out = tmp_path / "bench.json"
    proc = subprocess.run(
        [sys.executable, "-m", "hybrid_engine.bench", "--quick", "--rounds", "2", "--json", str(out)],
        cwd=REPO_ROOT, capture_output=True, text=True, timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    assert "ctx.finish()" in proc.stdout, "the table must say how GPU time was measured"
    report = json.loads(out.read_text())
    assert [row["triangles"] for row in report["lbvh"]] == [2000, 10000]
    for row in report["lbvh"]:
        assert LBVH_KEYS <= row.keys()
        assert all(row[k] > 0 and math.isfinite(row[k]) for k in LBVH_KEYS)
    trace = report["trace"]
    assert TRACE_KEYS <= trace.keys()
    assert trace["kind"] == "reflection"
    assert trace["mrays_per_s"] > 0 and trace["embree_mrays_per_s"] > 0
    assert trace["embree_threads"] >= 1
    assert trace["hit_agreement"] >= 0.999


def test_bench_never_imports_blender(tmp_path):
    """The benchmark is part of the Blender-free core."""
    code = ("import sys, hybrid_engine.bench as b; "
            "assert 'bpy' not in sys.modules and 'gpu' not in sys.modules")
    proc = subprocess.run([sys.executable, "-c", code], cwd=REPO_ROOT, capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
