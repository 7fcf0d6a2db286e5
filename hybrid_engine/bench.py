# SPDX-License-Identifier: GPL-3.0-or-later
"""Benchmarks of the renderer core against its peers: ``python -m hybrid_engine.bench``.

Usage::

    python -m hybrid_engine.bench [--quick] [--json PATH]

Sections (one function each; :func:`main` assembles them, so later sections such as a whole
``frame`` slot in beside these):

``lbvh``
    Per-frame LBVH build on the GPU versus Embree's BVH build (the first ``scene.run()`` after
    the mesh is attached commits the scene, i.e. builds it; attaching the mesh is not timed)
    and versus the numpy reference build (:mod:`hybrid_engine.lbvh_reference`).
``trace``
    Closest-hit traversal of reflection rays (rays leaving random surface points of a
    mesh-like scene in mirrored directions, as the hybrid tracer's secondary rays do) on the
    GPU versus Embree, with the fraction of rays on which both agree.

Method: all contenders run side by side in one process on the same data, warmed up first
(shader compilation, buffer growth, page faults), then in interleaved rounds so that load
from other processes hits all of them alike; the reported figure is the median of the rounds.
GPU time is wall time bracketed by ``ctx.finish()``: GL timer queries return meaningless
values on llvmpipe (the software rasteriser this project is tested on).
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from typing import Callable

import numpy as np

from . import gl_context, lbvh, lbvh_reference

FULL_BUILD_SIZES = (100_000, 300_000, 1_000_000)
QUICK_BUILD_SIZES = (2_000, 10_000)
FULL_TRACE = {"triangles": 300_000, "rays": 200_000}
QUICK_TRACE = {"triangles": 5_000, "rays": 2_000}
ROUNDS = 5
# A hit agrees when both report the same triangle and t within this relative tolerance
# (float32 arithmetic in different orders; 1e-3 is far above it and far below a wrong hit).
AGREEMENT_T_RELATIVE = 1e-3
SEED = 20140101


# -- scenes ---------------------------------------------------------------------------------

def uv_sphere(center: np.ndarray, radius: float, rings: int, segments: int) -> np.ndarray:
    """A tessellated sphere, triangles in row order (as a modelling tool would store them)."""
    theta = np.linspace(0.0, np.pi, rings + 1)
    phi = np.linspace(0.0, 2.0 * np.pi, segments + 1)
    st, ct = np.sin(theta), np.cos(theta)
    verts = np.stack([
        st[:, None] * np.cos(phi)[None, :],
        st[:, None] * np.sin(phi)[None, :],
        np.broadcast_to(ct[:, None], (rings + 1, segments + 1)),
    ], axis=-1) * radius + center
    a, b = verts[:-1, :-1], verts[1:, :-1]
    c, d = verts[1:, 1:], verts[:-1, 1:]
    first = np.stack([a, b, c], axis=-2).reshape(-1, 3, 3)
    second = np.stack([a, c, d], axis=-2).reshape(-1, 3, 3)
    return np.stack([first, second], axis=1).reshape(-1, 3, 3)


def mesh_like_scene(triangles: int, rng: np.random.Generator,
                    triangles_per_object: int = 20_000) -> np.ndarray:
    """Spheres of ~``triangles_per_object`` triangles scattered in a 20-unit box.

    Closed, tessellated surfaces with the triangle order of real meshes (neighbours stored
    together), unlike a random soup whose every memory access is a cache miss.
    """
    parts, total = [], 0
    while total < triangles:
        want = min(triangles_per_object, triangles - total)
        rings = max(2, int(np.sqrt(want / 4)))
        segments = max(3, -(-want // (2 * rings)))
        sphere = uv_sphere(rng.uniform(-10, 10, 3), rng.uniform(0.5, 2.0), rings, segments)
        parts.append(sphere[:want])
        total += want
    if not parts:
        return np.empty((0, 3, 3), np.float32)
    return np.concatenate(parts).astype(np.float32)


def reflection_rays(tris: np.ndarray, count: int, rng: np.random.Generator,
                    eye: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Rays from random surface points, mirrored about the surface normal as seen from ``eye``.

    The origin is offset along the normal by a tiny fraction of the scene size, as a tracer
    does to avoid re-hitting the surface it leaves.
    """
    eye = np.array([0.0, 0.0, 30.0]) if eye is None else np.asarray(eye, np.float64)
    pick = rng.integers(0, len(tris), count)
    t = tris[pick].astype(np.float64)
    u, v = rng.random(count), rng.random(count)
    flip = u + v > 1.0
    u, v = np.where(flip, 1 - u, u), np.where(flip, 1 - v, v)
    points = t[:, 0] + u[:, None] * (t[:, 1] - t[:, 0]) + v[:, None] * (t[:, 2] - t[:, 0])
    normal = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-30)
    incoming = points - eye
    incoming /= np.linalg.norm(incoming, axis=1, keepdims=True)
    facing = np.sign(np.einsum("ij,ij->i", incoming, normal))[:, None]
    normal = -facing * normal  # normal on the eye's side
    reflected = incoming - 2.0 * np.einsum("ij,ij->i", incoming, normal)[:, None] * normal
    extent = float(np.ptp(tris.reshape(-1, 3), axis=0).max()) if len(tris) else 1.0
    origins = points + normal * (1e-5 * extent)
    return origins.astype(np.float32), reflected.astype(np.float32)


# -- contenders -----------------------------------------------------------------------------

def _embree_modules():
    from embreex import rtcore_scene
    from embreex.mesh_construction import TriangleMesh

    return rtcore_scene, TriangleMesh


def embree_build_ms(tris: np.ndarray) -> float:
    """Embree build time: the first run() after attaching the mesh commits (builds) the scene."""
    rtcs, TriangleMesh = _embree_modules()
    scene = rtcs.EmbreeScene()
    TriangleMesh(scene, tris)
    probe_origin = np.zeros((1, 3), np.float32)
    probe_dir = np.array([[0.0, 0.0, 1.0]], np.float32)
    start = time.perf_counter()
    scene.run(probe_origin, probe_dir, output=1)
    return (time.perf_counter() - start) * 1e3


def gpu_build_ms(builder: lbvh.LBVHBuilder, buffer, count: int) -> float:
    ctx = builder.ctx
    ctx.finish()
    start = time.perf_counter()
    builder.build(buffer, count)
    ctx.finish()
    return (time.perf_counter() - start) * 1e3


def numpy_build_ms(tris: np.ndarray) -> float:
    start = time.perf_counter()
    lbvh_reference.build(tris)
    return (time.perf_counter() - start) * 1e3


def _interleaved(contenders: dict[str, Callable[[], float]], rounds: int) -> dict[str, float]:
    """Warm each contender up once, then run them in turn ``rounds`` times; medians."""
    for run in contenders.values():
        run()
    samples: dict[str, list[float]] = {name: [] for name in contenders}
    for _ in range(rounds):
        for name, run in contenders.items():
            samples[name].append(run())
    return {name: statistics.median(values) for name, values in samples.items()}


# -- sections -------------------------------------------------------------------------------

def lbvh_section(sizes=FULL_BUILD_SIZES, rounds: int = ROUNDS) -> list[dict]:
    """GPU LBVH build vs Embree build vs numpy reference build, per scene size."""
    ctx = gl_context.get_context()
    builder = lbvh.LBVHBuilder(ctx)
    rng = np.random.default_rng(SEED)
    rows = []
    try:
        for size in sizes:
            tris = mesh_like_scene(size, rng)
            buffer = ctx.buffer(tris.tobytes())
            try:
                medians = _interleaved({
                    "build_ms": lambda: gpu_build_ms(builder, buffer, len(tris)),
                    "embree_build_ms": lambda: embree_build_ms(tris),
                    "numpy_build_ms": lambda: numpy_build_ms(tris),
                }, rounds)
            finally:
                buffer.release()
            rows.append({"triangles": int(size), **{k: round(v, 3) for k, v in medians.items()}})
    finally:
        builder.release()
    return rows


def trace_section(triangles: int = FULL_TRACE["triangles"], rays: int = FULL_TRACE["rays"],
                  rounds: int = ROUNDS) -> dict:
    """Closest-hit reflection rays: GPU traversal vs Embree, rays/s and agreement."""
    ctx = gl_context.get_context()
    rng = np.random.default_rng(SEED + 1)
    tris = mesh_like_scene(triangles, rng)
    origins, dirs = reflection_rays(tris, rays, rng)
    builder = lbvh.LBVHBuilder(ctx)
    rtcs, TriangleMesh = _embree_modules()
    scene = rtcs.EmbreeScene()
    TriangleMesh(scene, tris)
    scene.run(origins[:1], dirs[:1], output=1)  # commit (build) outside the timing
    results: dict[str, tuple] = {}
    cpu_ratio: list[float] = []
    try:
        builder.build_from_array(tris)
        org_buf = ctx.buffer(origins.tobytes())
        dir_buf = ctx.buffer(dirs.tobytes())
        t_buf = ctx.buffer(reserve=rays * 4)
        tri_buf = ctx.buffer(reserve=rays * 4)

        def gpu() -> float:
            ctx.finish()
            start = time.perf_counter()
            builder.trace_buffers(org_buf, dir_buf, t_buf, tri_buf, rays)
            ctx.finish()
            elapsed = time.perf_counter() - start
            results["gpu"] = (np.frombuffer(t_buf.read(), np.float32),
                              np.frombuffer(tri_buf.read(), np.int32))
            return elapsed

        def embree() -> float:
            wall, cpu = time.perf_counter(), time.process_time()
            res = scene.run(origins, dirs, output=1)
            elapsed = time.perf_counter() - wall
            cpu_ratio.append((time.process_time() - cpu) / max(elapsed, 1e-9))
            results["embree"] = (np.asarray(res["tfar"], np.float32),
                                 np.asarray(res["primID"], np.int32))
            return elapsed

        medians = _interleaved({"gpu": gpu, "embree": embree}, rounds)
        for buf in (org_buf, dir_buf, t_buf, tri_buf):
            buf.release()
    finally:
        builder.release()
    t_gpu, tri_gpu = results["gpu"]
    t_emb, tri_emb = results["embree"]
    return {
        "rays": int(rays),
        "triangles": int(len(tris)),
        "kind": "reflection",
        "mrays_per_s": round(rays / medians["gpu"] / 1e6, 4),
        "embree_mrays_per_s": round(rays / medians["embree"] / 1e6, 4),
        "embree_threads": max(1, round(statistics.median(cpu_ratio))),
        "hit_agreement": round(hit_agreement(t_gpu, tri_gpu, t_emb, tri_emb), 6),
        "hit_fraction": round(float(np.mean(tri_emb >= 0)), 4),
    }


def hit_agreement(t_a: np.ndarray, tri_a: np.ndarray, t_b: np.ndarray, tri_b: np.ndarray) -> float:
    """Fraction of rays with the same triangle (or both missing) and t within tolerance."""
    same_tri = tri_a == tri_b
    both_hit = same_tri & (tri_a >= 0)
    close = np.ones_like(same_tri)
    with np.errstate(invalid="ignore"):
        close[both_hit] = np.abs(t_a[both_hit] - t_b[both_hit]) <= AGREEMENT_T_RELATIVE * np.maximum(
            np.abs(t_b[both_hit]), 1e-6)
    return float(np.mean(same_tri & close)) if len(tri_a) else 1.0


# -- report ---------------------------------------------------------------------------------

def machine_info() -> dict:
    return {
        "cpu_count": os.cpu_count(),
        "machine": platform.machine(),
        "python": platform.python_version(),
        "gl_renderer": gl_context.renderer_name(),
        "gpu_timing": "wall clock bracketed by ctx.finish()"
        + ("; GL timer queries are meaningless on this software renderer"
           if gl_context.is_software_renderer() else ""),
    }


def format_tables(report: dict) -> str:
    lines = [f"renderer: {report['machine']['gl_renderer']}, {report['machine']['cpu_count']} CPUs",
             f"GPU times: {report['machine']['gpu_timing']}", ""]
    lines.append(f"{'triangles':>10} {'GPU ms':>9} {'Embree ms':>10} {'numpy ms':>10} "
                 f"{'GPU/Embree':>11} {'numpy/GPU':>10}")
    for row in report.get("lbvh", []):
        lines.append(
            f"{row['triangles']:>10} {row['build_ms']:>9.1f} {row['embree_build_ms']:>10.1f} "
            f"{row['numpy_build_ms']:>10.1f} {row['build_ms'] / row['embree_build_ms']:>11.2f} "
            f"{row['numpy_build_ms'] / row['build_ms']:>10.1f}")
    trace = report.get("trace")
    if trace:
        lines.append("")
        lines.append(
            f"trace ({trace['kind']}, {trace['rays']} rays, {trace['triangles']} triangles): "
            f"GPU {trace['mrays_per_s']:.3f} Mrays/s, Embree {trace['embree_mrays_per_s']:.3f} "
            f"Mrays/s ({trace['embree_threads']} thread(s)), ratio "
            f"{trace['mrays_per_s'] / trace['embree_mrays_per_s']:.2f}, agreement "
            f"{100 * trace['hit_agreement']:.3f}%")
    return "\n".join(lines)


SECTIONS = ("lbvh", "trace")


def run(quick: bool = False, sections=SECTIONS, rounds: int = ROUNDS) -> dict:
    """Run the requested sections and return the report dictionary."""
    report: dict = {"machine": machine_info(), "quick": bool(quick), "rounds": rounds}
    if "lbvh" in sections:
        report["lbvh"] = lbvh_section(QUICK_BUILD_SIZES if quick else FULL_BUILD_SIZES, rounds)
    if "trace" in sections:
        params = QUICK_TRACE if quick else FULL_TRACE
        report["trace"] = trace_section(params["triangles"], params["rays"], rounds)
    return report


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m hybrid_engine.bench", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="tiny sizes (seconds, for tests)")
    parser.add_argument("--json", metavar="PATH", help="write the report as JSON to PATH")
    parser.add_argument("--rounds", type=int, default=ROUNDS, help="interleaved timed rounds")
    parser.add_argument("--sections", default=",".join(SECTIONS),
                        help=f"comma-separated subset of {', '.join(SECTIONS)}")
    args = parser.parse_args(argv)
    sections = [s.strip() for s in args.sections.split(",") if s.strip()]
    unknown = sorted(set(sections) - set(SECTIONS))
    if unknown:
        parser.error(f"unknown sections: {', '.join(unknown)}")
    if args.rounds < 1:
        parser.error("--rounds must be >= 1")
    report = run(args.quick, sections, args.rounds)
    print(format_tables(report))
    if args.json:
        with open(args.json, "w", encoding="utf-8") as handle:
            json.dump(report, handle, indent=2)
            handle.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
