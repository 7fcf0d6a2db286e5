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
FRAME_KEYS = {"scene", "triangles_total", "triangles_bvh", "resolution", "max_depth", "hybrid_ms",
              "full_bvh_ms", "speedup", "flip_mean", "passes_hybrid", "passes_full_bvh"}
# Passes each mode must report (renderer.MODE_STEPS): HYBRID's cube map, culling and near-cube
# LBVH, FULL_BVH's whole-scene LBVH, both modes' tracer.
HYBRID_PASSES = {"upload", "shadow_maps", "primary_raster", "cube_map_raster", "cull", "lbvh_build",
                 "shade", "trace", "readback"}
FULL_BVH_PASSES = HYBRID_PASSES - {"cube_map_raster", "cull"}


def test_quick_bench_writes_every_key(tmp_path):
    out = tmp_path / "bench.json"
    proc = subprocess.run(
        [sys.executable, "-m", "benchmarks.bench", "--quick", "--rounds", "2", "--json", str(out)],
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
    frame = report["frame"]
    assert FRAME_KEYS <= frame.keys()
    assert frame["resolution"] == "96x54" and frame["max_depth"] == 4
    assert 20_000 <= frame["triangles_total"] <= 50_000, "--quick uses a tiny chess scene"
    assert 0 < frame["triangles_bvh"] < frame["triangles_total"], "HYBRID culls to the near cube"
    assert frame["hybrid_ms"] > 0 and frame["full_bvh_ms"] > 0
    assert math.isclose(frame["speedup"], frame["full_bvh_ms"] / frame["hybrid_ms"], rel_tol=1e-3)
    assert 0.0 <= frame["flip_mean"] < 1.0
    assert set(frame["passes_hybrid"]) == HYBRID_PASSES
    assert set(frame["passes_full_bvh"]) == FULL_BVH_PASSES
    assert all(v >= 0 and math.isfinite(v) for v in frame["passes_hybrid"].values())
    assert "speedup" in proc.stdout and "FLIP" in proc.stdout, "the frame table is printed"


def test_bench_refuses_a_malformed_resolution():
    proc = subprocess.run(
        [sys.executable, "-m", "benchmarks.bench", "--quick", "--sections", "frame",
         "--resolution", "640by360"],
        cwd=REPO_ROOT, capture_output=True, text=True, timeout=60,
    )
    assert proc.returncode == 2 and "640x360" in proc.stderr


def test_bench_never_imports_blender(tmp_path):
    """The benchmark runs on a machine without Blender (a GPU machine with plain Python)."""
    code = ("import sys, benchmarks.bench as b; "
            "assert 'bpy' not in sys.modules and 'gpu' not in sys.modules")
    proc = subprocess.run([sys.executable, "-c", code], cwd=REPO_ROOT, capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
