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


# Run as a GPU machine's Python may be: no Blender, no Embree, no FLIP (imports of them fail).
WITHOUT_BPY_EMBREE_FLIP = (
    "import sys, runpy\n"
    "for name in ('bpy', 'embreex', 'flip_evaluator'):\n"
    "    sys.modules[name] = None  # import raises ImportError, find_spec raises ValueError\n"
    "import importlib.util\n"
    "_find_spec = importlib.util.find_spec\n"
    "def find_spec(name, *args):\n"
    "    return None if name in ('bpy', 'embreex', 'flip_evaluator') else _find_spec(name, *args)\n"
    "importlib.util.find_spec = find_spec\n"
    "sys.argv = ['bench'] + sys.argv[1:]\n"
    "runpy.run_module('benchmarks.bench', run_name='__main__')\n"
)


def test_quick_bench_without_blender_embree_or_flip_writes_a_device_report(tmp_path):
    """The command a GPU machine runs: every kernel with two shapes in both families side by
    side, the two target sections, and a Markdown device report with the GL strings,
    limits, chosen variants and a table of the measured sections; the Embree contenders and
    FLIP are reported as absent rather than failing the run."""
    from benchmarks.kernel_bench import kernels_in_code
    from hybrid_engine.gpu import gl_context, variants

    report_path, json_path = tmp_path / "device.md", tmp_path / "bench.json"
    proc = subprocess.run(
        [sys.executable, "-c", WITHOUT_BPY_EMBREE_FLIP, "--quick", "--rounds", "1", "--variants", "both",
         "--sections", "lbvh,trace,frame,host,kernels,lbvh_target,frame_target",
         "--device-report", str(report_path), "--json", str(json_path)],
        cwd=REPO_ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    report = json.loads(json_path.read_text())
    assert report["host"]["skipped"].startswith("needs bpy")
    assert report["lbvh"][0]["embree_build_ms"] is None and report["trace"]["embree_mrays_per_s"] is None
    assert report["frame"]["flip_mean"] is None
    # Both families of each kernel whose two shapes exist, each with the same measurements.
    assert "faces" in kernels_in_code()
    kernels = report["kernels"]["kernels"]
    assert set(kernels) == set(kernels_in_code())
    for per_family in kernels.values():
        assert set(per_family) == set(variants.FAMILIES)
        assert per_family["gpu"].keys() == per_family["cpu"].keys()
        assert all(v > 0 for family in per_family.values() for v in family.values())
    assert report["lbvh_target"]["triangles"] == 20_000 and report["lbvh_target"]["build_ms"] > 0
    assert report["frame_target"]["resolution"] == "96x54" and report["frame_target"]["max_depth"] == 4
    # Each section's printed table says which variants it ran.
    assert proc.stdout.count("variants: sort=") >= 5
    page = report_path.read_text()
    assert page.startswith(f"### {gl_context.renderer_name()}")
    for text in ("| vendor |", "| version |", "max SSBO block size", "max compute workgroup count",
                 "max compute workgroup size", "max texture size", "--device-report"):
        assert text in page
    for kernel, family in variants.chosen().items():
        assert f"| {kernel} | {family} |" in page
    assert "| lbvh_target | LBVH build, 20,000 triangles (ms) |" in page
    assert "<= 1 ms" in page and ">= 60 FPS" in page
    faces = kernels["faces"]
    assert (f"| faces | cube_map_ms | {faces['cpu']['cube_map_ms']:,.3f} | {faces['gpu']['cube_map_ms']:,.3f} |"
            in page)
    for line in page.splitlines():  # every table row has as many cells as its header
        if line.startswith("|"):
            assert line.endswith("|")


def test_the_auto_variant_mode_measures_only_the_chosen_family(tmp_path):
    from benchmarks import kernel_bench
    from hybrid_engine.gpu import variants

    section = kernel_bench.kernel_section("auto", quick=True, rounds=1)
    chosen = variants.chosen()
    assert section["kernels"] and all(list(per_family) == [chosen[kernel]]
                                      for kernel, per_family in section["kernels"].items())
