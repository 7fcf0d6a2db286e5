# SPDX-License-Identifier: GPL-3.0-or-later
"""The benchmark runs end to end (at tiny sizes) and writes every documented key."""
from __future__ import annotations

import json
import math
import subprocess
import sys

from conftest import REPO_ROOT
from hybrid_engine import RenderSettings
from hybrid_engine.gpu import variants

LBVH_KEYS = {"triangles", "build_ms", "embree_build_ms", "numpy_build_ms"}
TRACE_KEYS = {"rays", "kind", "mrays_per_s", "embree_mrays_per_s", "embree_threads",
              "hit_agreement"}
FRAME_KEYS = {"scene", "triangles_total", "triangles_bvh", "triangles_transformed", "resolution", "max_depth",
              "hybrid_ms", "full_bvh_ms", "speedup", "flip_mean", "passes_hybrid", "passes_full_bvh"}
# Passes each mode must report (renderer.MODE_STEPS): HYBRID's cube map, culling and near-cube
# LBVH, FULL_BVH's whole-scene LBVH, both modes' tracer.
HYBRID_PASSES = {"upload", "instance_transform", "shadow_maps", "lighting", "primary_raster", "cube_map_raster",
                 "cull", "lbvh_build", "shade", "trace", "readback"}
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
    chosen = variants.chosen()
    for row in report["lbvh"]:
        assert LBVH_KEYS <= row.keys()
        assert all(row[k] > 0 and math.isfinite(row[k]) for k in LBVH_KEYS)
        assert row["kernels"] == {"sort": chosen["sort"], "scan": chosen["scan"]}
    assert f"sort={chosen['sort']}, scan={chosen['scan']}" in proc.stdout, "the table names the kernels' shapes"
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
    # The exporter's path: instances of shared meshes, of which a frame transforms the moved.
    assert 0 < frame["triangles_transformed"] < frame["triangles_total"]
    assert frame["hybrid_ms"] > 0 and frame["full_bvh_ms"] > 0
    assert math.isclose(frame["speedup"], frame["full_bvh_ms"] / frame["hybrid_ms"], rel_tol=1e-3)
    assert 0.0 <= frame["flip_mean"] < 1.0
    assert set(frame["passes_hybrid"]) == HYBRID_PASSES
    assert set(frame["passes_full_bvh"]) == FULL_BVH_PASSES
    assert all(v >= 0 and math.isfinite(v) for v in frame["passes_hybrid"].values())
    assert "speedup" in proc.stdout and "FLIP" in proc.stdout, "the frame table is printed"


def test_the_benchmark_scene_is_built_as_the_exporter_builds_a_scene():
    """Shared object-space meshes placed by instances, one mesh per piece type: the bench
    times the path every Blender frame takes, and the next frame of the animation re-sends
    no mesh and transforms only the pieces and spheres that moved."""
    from hybrid_engine.frame.renderer import Renderer
    from hybrid_engine.scene.geometry import InstancedGeometry
    from benchmarks.scenes.chess import build_chess

    first, camera = build_chess(0.02, 10, 32, 18)
    second, _ = build_chess(0.02, 11, 32, 18)
    geometry = first.geometry
    assert isinstance(geometry, InstancedGeometry)
    assert len(geometry.instances.meshes) < len(geometry.instances) / 10
    assert [m.mesh_id for m in geometry.instances.meshes] == [m.mesh_id for m in second.geometry.instances.meshes]
    renderer = Renderer()
    try:
        renderer.render(first, camera, RenderSettings(mode="RASTER"))
        moved = renderer.render(second, camera, RenderSettings(mode="RASTER")).counts
    finally:
        renderer.release()
    assert moved["meshes_uploaded"] == 0
    assert 0 < moved["instances_written"] < len(geometry.instances) // 4
    assert moved["triangles_transformed"] == moved["triangles_uploaded"] < geometry.triangle_count // 2


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
