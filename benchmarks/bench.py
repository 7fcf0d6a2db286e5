# SPDX-License-Identifier: GPL-3.0-or-later
"""Benchmarks of the renderer core against its peers: ``python -m benchmarks.bench``.

Usage::

    python -m benchmarks.bench [--quick] [--json PATH] [--rounds N] [--resolution WxH]
                                  [--sections lbvh,trace,frame,host,kernels,lbvh_target,frame_target]
                                  [--variants both|auto] [--device-report PATH]

Sections (one function each; :func:`main` assembles them):

``lbvh``
    Per-frame LBVH build on the GPU versus Embree's BVH build (the first ``scene.run()`` after
    the mesh is attached commits the scene, i.e. builds it; attaching the mesh is not timed)
    and versus the numpy reference build (:mod:`benchmarks.lbvh_reference`).
``trace``
    Closest-hit traversal of reflection rays (rays leaving random surface points of a
    mesh-like scene in mirrored directions, as the hybrid tracer's secondary rays do) on the
    GPU versus Embree, with the fraction of rays on which both agree. The GPU time is that of
    ``LBVHBuilder.trace_buffers``, which first sorts the rays by their origins' Morton codes
    (counted in the time); the same trace without the sort is reported too.
``frame``
    Whole frames of the procedural Chess scene (:mod:`benchmarks.scenes.chess`, the
    paper's pathological case, §4 and Figure 6) in HYBRID and in FULL_BVH, the paper's
    ground truth: median frame and per-pass times, the speedup, and the mean FLIP error of
    HYBRID against FULL_BVH (both tone-mapped by clamping to [0, 1] and the sRGB OETF, as
    FLIP's LDR mode expects). The comparison itself (:func:`compare_modes`) takes any
    sequence of frames; ``scripts/bench_scene.py`` feeds it the scene library's Blender
    scenes (Sponza ...), extracted frame by frame as the render engine does.
``host``
    What a frame costs the CPU before the GPU passes (``scripts/bench_host.py``): the scene
    sync and the upload per frame of a static scene with a moving camera, Chess, a deformed
    100k-vertex mesh and 10,000 instances, followed through Blender's change sets. Needs bpy;
    skipped, with the reason in the report, where it is absent (a GPU machine's Python).
``kernels``, ``lbvh_target``, ``frame_target``
    :mod:`benchmarks.kernel_bench`: every kernel with two shapes in the code in both
    families side by side (``--variants both``) or in the chosen one (``--variants auto``),
    and the two figures a hardware GPU is held to (LBVH build of 1M triangles <= 1 ms, a
    1280x720 Chess frame at four bounces >= 60 FPS).

Each section's table says which kernel variants it ran (gpu/variants.py). Without embreex
(a GPU machine's Python may lack it) the Embree contenders are left out and reported as
such; without flip_evaluator the frame section reports no FLIP. ``--device-report PATH``
writes :mod:`benchmarks.device_report`'s Markdown page (GL strings, limits, variants, the
measured sections) for docs/BENCHMARKS.md's "GPU figures".

Method: all contenders run side by side in one process on the same data, warmed up first
(shader compilation, buffer growth, page faults), then in interleaved rounds so that load
from other processes hits all of them alike; the reported figure is the median of the rounds.
GPU time is wall time bracketed by ``ctx.finish()``: GL timer queries return meaningless
values on llvmpipe (the software rasteriser this project is tested on).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import statistics
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from typing import Callable, Iterable

import numpy as np

from hybrid_engine.gpu import gl_context, variants
from hybrid_engine.passes.lbvh import lbvh
from hybrid_engine.scene.camera import Camera
from hybrid_engine.scene.data import SceneData
from hybrid_engine.scene.settings import CUBE_MARCHES, RenderSettings

from . import device_report, kernel_bench, lbvh_reference
from .scenes.chess import CHESS_CUBE_FAR, build_chess

FULL_BUILD_SIZES = (100_000, 300_000, 1_000_000)
QUICK_BUILD_SIZES = (2_000, 10_000)
FULL_TRACE = {"triangles": 300_000, "rays": 200_000}
QUICK_TRACE = {"triangles": 5_000, "rays": 2_000}
ROUNDS = 5
# The frame section: the paper's Chess scene at full size (detail 1.0: 2,155,124 triangles
# against the paper's 2,149,944). Per-triangle arrays past the driver's storage-block limit
# (128 MiB on llvmpipe: FULL_BVH's nodes and triangles) are bound as several
# blocks.
FULL_FRAME = {"detail": 1.0, "resolution": (640, 360), "cube_resolution": 512}
HARDWARE_FRAME_RESOLUTION = (1280, 720)  # the paper's 720p, when a hardware GPU is present
QUICK_FRAME = {"detail": 0.02, "resolution": (96, 54), "cube_resolution": 128}
# Frame 0 of the animation: the camera stands 3 units above the boards, 8.25 units from the
# grid's centre, between the corners of four boards; a near cube of half-size 3.5 around it
# reaches half a unit below the board tops and holds the closest corners of those boards
# with about 20 pieces (29 objects inside or straddling, reported as objects_near) while the
# other ~290 objects -- all spheres, most pieces and boards, the floor's far reaches -- lie
# beyond it, in the cube map. (3.5 rather than 3.0 keeps the -Z face's near plane off the
# board tops, which lie exactly 3 units below the camera in this frame.)
FRAME_NUMBER = 0
WARM_UP_FRAMES = 2  # the first frame uploads everything; the second teaches the shadow cache what moves
FRAME_NEAR_SIZE = 3.5
FRAME_MAX_DEPTH = 4  # the paper's "maximum of four ray recursions" (Figure 5)
# HYBRID's cube map holds the back layer: with the hidden-exit rule (cube_march.glsl) it
# brings HYBRID closer to FULL_BVH for some raster time (docs/BENCHMARKS.md);
# --no-back-layer measures the paper's single layer.
FRAME_BACK_LAYER = True
# The bars the frame section reports (never enforced here).
FRAME_SPEEDUP_BAR = 2.0
FRAME_FLIP_BAR = 0.05
# A hit agrees when both report the same triangle and t within this relative tolerance
# (float32 arithmetic in different orders; 1e-3 is far above it and far below a wrong hit).
AGREEMENT_T_RELATIVE = 1e-3
SEED = 20140101
# The kernels (variants.KERNELS) whose shape an LBVH build's time depends on: its radix sort
# and the near-cube cull's scan before it in a frame (the sort's histogram scan in its GPU shape).
LBVH_KERNELS = ("sort", "scan")


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

def embree_available() -> bool:
    """Whether embreex imports (the Embree contenders run only then)."""
    try:
        _embree_modules()
    except ImportError:
        return False
    return True


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
    """GPU LBVH build vs Embree build vs numpy reference build, per scene size; each row
    records the shapes of the sort and scan kernels (``kernels``, :mod:`variants`)."""
    ctx = gl_context.get_context()
    builder = lbvh.LBVHBuilder(ctx)
    kernels = {kernel: family for kernel, family in variants.chosen().items() if kernel in LBVH_KERNELS}
    assert builder.sorter.family == kernels["sort"]
    rng = np.random.default_rng(SEED)
    rows = []
    embree = embree_available()
    try:
        for size in sizes:
            tris = mesh_like_scene(size, rng)
            buffer = ctx.buffer(tris.tobytes())
            contenders = {"build_ms": lambda: gpu_build_ms(builder, buffer, len(tris)),
                          "embree_build_ms": lambda: embree_build_ms(tris),
                          "numpy_build_ms": lambda: numpy_build_ms(tris)}
            if not embree:
                del contenders["embree_build_ms"]
            try:
                medians = _interleaved(contenders, rounds)
            finally:
                buffer.release()
            rows.append({"triangles": int(size), "embree_build_ms": None,
                         **{k: round(v, 3) for k, v in medians.items()}, "kernels": kernels})
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
    embree = embree_available()
    if embree:
        rtcs, TriangleMesh = _embree_modules()
        scene = rtcs.EmbreeScene()
        TriangleMesh(scene, tris)
        scene.run(origins[:1], dirs[:1], output=1)  # commit (build) outside the timing
    results: dict[str, tuple] = {}
    cpu_ratio: list[float] = []
    embree_threads = max(1, os.cpu_count() or 1)
    pool = ThreadPoolExecutor(max_workers=embree_threads)
    try:
        builder.build_from_array(tris)
        org_buf = ctx.buffer(origins.tobytes())
        dir_buf = ctx.buffer(dirs.tobytes())
        t_buf = ctx.buffer(reserve=rays * 4)
        tri_buf = ctx.buffer(reserve=rays * 4)

        def gpu_trace(name: str, sort_rays: bool | None) -> Callable[[], float]:
            def run() -> float:
                ctx.finish()
                start = time.perf_counter()
                builder.trace_buffers(org_buf, dir_buf, t_buf, tri_buf, rays, sort_rays=sort_rays)
                ctx.finish()
                elapsed = time.perf_counter() - start
                results[name] = (np.frombuffer(t_buf.read(), np.float32),
                                 np.frombuffer(tri_buf.read(), np.int32))
                return elapsed
            return run

        # embreex's run() traces on the calling thread and releases the GIL, so Embree gets
        # one thread per core, each tracing a contiguous share of the rays.
        chunks = np.array_split(np.arange(rays), embree_threads)

        def embree_chunk(index: np.ndarray):
            return scene.run(origins[index[0]:index[-1] + 1], dirs[index[0]:index[-1] + 1], output=1)

        def embree_run() -> float:
            wall, cpu = time.perf_counter(), time.process_time()
            parts = list(pool.map(embree_chunk, chunks))
            elapsed = time.perf_counter() - wall
            cpu_ratio.append((time.process_time() - cpu) / max(elapsed, 1e-9))
            results["embree"] = (np.concatenate([np.asarray(p["tfar"], np.float32) for p in parts]),
                                 np.concatenate([np.asarray(p["primID"], np.int32) for p in parts]))
            return elapsed

        contenders = {"gpu": gpu_trace("gpu", None), "gpu_unsorted": gpu_trace("gpu_unsorted", False),
                      "embree": embree_run}
        if not embree:
            del contenders["embree"]
        medians = _interleaved(contenders, rounds)
        for buf in (org_buf, dir_buf, t_buf, tri_buf):
            buf.release()
    finally:
        builder.release()
        pool.shutdown()
    t_gpu, tri_gpu = results["gpu"]
    if not embree:
        return {"rays": int(rays), "triangles": int(len(tris)), "kind": "reflection",
                "mrays_per_s": round(rays / medians["gpu"] / 1e6, 4),
                "gpu_ray_sort": rays >= lbvh.RAY_SORT_MIN_RAYS,
                "mrays_per_s_unsorted": round(rays / medians["gpu_unsorted"] / 1e6, 4),
                "embree_mrays_per_s": None, "embree_threads": 0, "hit_agreement": None,
                "embree": "not installed (embreex): GPU figures only"}
    t_emb, tri_emb = results["embree"]
    return {
        "rays": int(rays),
        "triangles": int(len(tris)),
        "kind": "reflection",
        "mrays_per_s": round(rays / medians["gpu"] / 1e6, 4),
        "gpu_ray_sort": rays >= lbvh.RAY_SORT_MIN_RAYS,
        "mrays_per_s_unsorted": round(rays / medians["gpu_unsorted"] / 1e6, 4),
        "embree_mrays_per_s": round(rays / medians["embree"] / 1e6, 4),
        "embree_threads": embree_threads,
        "embree_cpu_utilisation": round(statistics.median(cpu_ratio), 2),
        "hit_agreement": round(hit_agreement(t_gpu, tri_gpu, t_emb, tri_emb), 6),
        "hit_agreement_unsorted": round(hit_agreement(*results["gpu_unsorted"], t_emb, tri_emb), 6),
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


def to_srgb_ldr(linear: np.ndarray) -> np.ndarray:
    """Linear radiance clamped to [0, 1] and encoded with the sRGB OETF (FLIP's LDR input)."""
    c = np.clip(np.nan_to_num(np.asarray(linear, np.float64)[..., :3], nan=0.0), 0.0, 1.0)
    srgb = np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1.0 / 2.4) - 0.055)
    return srgb.astype(np.float32)


def flip_error(reference_linear: np.ndarray, test_linear: np.ndarray,
               magma: bool = False) -> tuple[np.ndarray, float]:
    """LDR FLIP (flip_evaluator) between two linear (H, W, 3|4) images, row 0 at the bottom
    as the renderer returns them (FLIP wants the top row first): the error map (top row
    first; magma-coloured RGB when ``magma``) and its mean."""
    import flip_evaluator

    reference = np.ascontiguousarray(to_srgb_ldr(reference_linear)[::-1])
    test = np.ascontiguousarray(to_srgb_ldr(test_linear)[::-1])
    error_map, mean, _ = flip_evaluator.evaluate(reference, test, "LDR", applyMagma=magma)
    return np.asarray(error_map), float(mean)


def chess_cost_main(description: str, measure, format_report, default_size: str,
                    argv: list[str] | None = None) -> int:
    """The command line of a per-pass cost benchmark on Chess (row_passes_cost,
    radiance_cache_cost): ``--quick`` (QUICK_FRAME's sizes, one timed frame), ``--detail``,
    ``--size``, ``--frames``, ``--json``; ``measure(detail=, size=, frames=[, cube_resolution=])``
    makes the report, ``format_report`` prints it."""
    import argparse

    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--quick", action="store_true", help="tiny sizes (seconds, for tests)")
    parser.add_argument("--detail", type=float, default=1.0)
    parser.add_argument("--size", default=default_size)
    parser.add_argument("--frames", type=int, default=8)
    parser.add_argument("--json", help="also write the report here")
    args = parser.parse_args(argv)
    if args.quick:
        report = measure(detail=QUICK_FRAME["detail"], size=QUICK_FRAME["resolution"], frames=1,
                         cube_resolution=QUICK_FRAME["cube_resolution"])
    else:
        report = measure(detail=args.detail, size=tuple(int(v) for v in args.size.split("x")), frames=args.frames)
    print(format_report(report))
    write_json(report, args.json)
    return 0


def write_json(report: dict, path: str | None) -> None:
    """Write a benchmark's report as indented JSON to ``path`` (nothing without one)."""
    if path:
        with open(path, "w", encoding="utf-8") as handle:
            json.dump(report, handle, indent=2)
            handle.write("\n")


def flip_mean(reference_linear: np.ndarray, test_linear: np.ndarray) -> float:
    """Mean LDR FLIP of :func:`flip_error`."""
    return flip_error(reference_linear, test_linear)[1]


def default_frame_resolution(quick: bool) -> tuple[int, int]:
    """96x54 for --quick; 640x360 on a software renderer; the paper's 1280x720 on a GPU."""
    if quick:
        return QUICK_FRAME["resolution"]
    return FULL_FRAME["resolution"] if gl_context.is_software_renderer() else HARDWARE_FRAME_RESOLUTION


def frame_section(detail: float = FULL_FRAME["detail"],
                  resolution: tuple[int, int] = FULL_FRAME["resolution"],
                  rounds: int = ROUNDS, cube_resolution: int = FULL_FRAME["cube_resolution"],
                  near_size: float = FRAME_NEAR_SIZE, max_depth: int = FRAME_MAX_DEPTH,
                  frame: int = FRAME_NUMBER, cube_march: str = "HIERARCHICAL",
                  cube_back_layer: bool = FRAME_BACK_LAYER) -> dict:
    """HYBRID vs FULL_BVH on consecutive frames of the procedural Chess animation, side by
    side in one process (:func:`compare_modes`): frames ``frame`` and ``frame + 1`` warm the
    renderers up, frames ``frame + 2 .. frame + rounds + 1`` are timed."""
    width, height = (int(v) for v in resolution)
    start = time.perf_counter()
    frames = [build_chess(detail, frame + k, width, height) for k in range(rounds + WARM_UP_FRAMES)]
    build_ms = (time.perf_counter() - start) * 1e3 / len(frames)
    base = dict(near_size=float(near_size), max_depth=int(max_depth),
                cube_resolution=int(cube_resolution), cube_far=CHESS_CUBE_FAR, cube_march=cube_march,
                cube_back_layer=bool(cube_back_layer))
    label = (f"chess (procedural, detail {detail:g}, frames {frame + WARM_UP_FRAMES}-"
             f"{frame + WARM_UP_FRAMES + rounds - 1})")
    report = compare_modes(frames, base, label, context={"detail": float(detail)})
    report["scene_build_ms"] = round(build_ms, 3)
    return report


def compare_modes(frames: Iterable[tuple[SceneData, Camera]], base_settings: dict, label: str,
                  context: dict | None = None) -> dict:
    """HYBRID vs FULL_BVH on consecutive frames of one animation, side by side in one process.

    ``frames``: (scene, camera) pairs in playback order, the first :data:`WARM_UP_FRAMES` of
    them warm-up, the rest timed; any iterable, so a caller extracting frames from a large
    scene can produce each one only when it is rendered. ``base_settings``: RenderSettings
    keyword values shared by both modes (``mode`` is set here). ``label`` names the scene in
    the report; ``context`` (e.g. the scene's detail) is reported among the settings.

    Each mode has its own Renderer, as an application playing the animation would: the
    warm-up frames pay for shader compilation, buffer growth, the first full upload and the
    shadow layers learning what moves; the timed frames are rendered with the modes
    alternating frame by frame, each re-uploading what moved and re-rendering the dynamic
    shadow layer exactly as playback would. Frame and per-pass figures are medians over the
    timed frames; ``flip_mean`` is the mean FLIP over them.
    """
    from hybrid_engine.frame.renderer import Renderer

    settings = {mode: RenderSettings(**{**base_settings, "mode": mode}) for mode in ("HYBRID", "FULL_BVH")}
    ctx = gl_context.get_context()
    renderers = {mode: Renderer(ctx) for mode in settings}
    results: dict[str, list] = {mode: [] for mode in settings}
    first: tuple[SceneData, Camera] | None = None
    try:
        for index, (frame_scene, camera) in enumerate(frames):
            if first is None:
                first = (frame_scene, camera)
            for mode, mode_settings in settings.items():
                result = renderers[mode].render(frame_scene, camera, mode_settings, timing=True)
                if index >= WARM_UP_FRAMES:
                    results[mode].append(result)
    finally:
        for renderer in renderers.values():
            renderer.release()
    if not results["HYBRID"]:
        raise ValueError(f"compare_modes needs more than {WARM_UP_FRAMES} frames (the first are warm-up)")
    return _comparison_report(first, settings["HYBRID"], results, label, context or {})


def _comparison_report(first: tuple[SceneData, Camera], hybrid_settings: RenderSettings,
                       results: dict[str, list], label: str, context: dict) -> dict:
    """The figures of :func:`compare_modes` from the timed frames' results of both modes."""
    scene, camera = first
    hybrid = results["HYBRID"][-1]
    full = results["FULL_BVH"][-1]
    import importlib.util

    flips = ([flip_mean(f.image, h.image) for h, f in zip(results["HYBRID"], results["FULL_BVH"])]
             if importlib.util.find_spec("flip_evaluator") is not None else [])  # None: no FLIP here
    hybrid_ms = statistics.median(r.total_ms for r in results["HYBRID"])
    full_ms = statistics.median(r.total_ms for r in results["FULL_BVH"])
    medians = {mode: pass_medians(mode_results) for mode, mode_results in results.items()}
    hybrid_no_upload = hybrid_ms - medians["HYBRID"].get("upload", 0.0)
    full_no_upload = full_ms - medians["FULL_BVH"].get("upload", 0.0)
    return {
        "scene": label,
        "triangles_total": int(scene.geometry.triangle_count),
        "triangles_bvh": int(hybrid.counts.get("triangles_bvh", 0)),
        # The scene reaches the GPU as the exporter hands it over: meshes placed by instances,
        # a frame transforming on the GPU only the instances that moved.
        "triangles_transformed": int(hybrid.counts.get("triangles_transformed", 0)),
        "resolution": f"{camera.width}x{camera.height}",
        "max_depth": int(hybrid_settings.max_depth),
        "hybrid_ms": round(hybrid_ms, 3),
        "full_bvh_ms": round(full_ms, 3),
        "speedup": round(full_ms / hybrid_ms, 4),
        "flip_mean": round(float(np.mean(flips)), 5) if flips else None,
        "passes_hybrid": medians["HYBRID"],
        "passes_full_bvh": medians["FULL_BVH"],
        "host_passes_hybrid": pass_medians(results["HYBRID"], "host_passes"),
        "gpu_passes_hybrid": pass_medians(results["HYBRID"], "gpu_passes"),
        # Context for reading the figures above.
        **context,
        "near_size": float(hybrid_settings.near_size),
        "cube_resolution": int(hybrid_settings.cube_resolution),
        "cube_far": float(hybrid_settings.cube_far),
        "cube_march": hybrid_settings.cube_march,
        "cube_back_layer": bool(hybrid_settings.cube_back_layer),
        "rounds": len(results["HYBRID"]),
        "flip_per_frame": [round(float(v), 5) for v in flips],
        "triangles_uploaded_median": int(statistics.median(
            r.counts.get("triangles_uploaded", 0) for r in results["HYBRID"])),
        "objects_near": int(hybrid.counts.get("objects_near_inside", 0)
                            + hybrid.counts.get("objects_near_straddling", 0)),
        "objects_total": int(len(scene.geometry.object_ranges)),
        "rays_hybrid": int(hybrid.counts.get("rays_traced", 0)),
        "rays_cube_map": int(hybrid.counts.get("rays_cube_map", 0)),
        "rays_full_bvh": int(full.counts.get("rays_traced", 0)),
        "speedup_without_upload": round(full_no_upload / max(hybrid_no_upload, 1e-9), 4),
    }


def pass_medians(results: list, kind: str = "passes") -> dict[str, float]:
    """Median milliseconds of every pass over the frames, in the order the passes ran:
    wall time (``kind`` "passes"), the main thread's CPU time ("host_passes") or the GPU's
    timer queries ("gpu_passes", hardware renderers only)."""
    passes: dict[str, list[float]] = {}
    for result in results:
        for name, ms in getattr(result, kind, {}).items():
            passes.setdefault(name, []).append(ms)
    return {name: round(statistics.median(values), 3) for name, values in passes.items()}


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


def variants_line(report: dict, section: str) -> str:
    """Which family each kernel ran in ``section`` (gpu/variants.py)."""
    chosen = report.get("section_variants", {}).get(section, report.get("variants", {}))
    return "variants: " + ", ".join(f"{kernel}={family}" for kernel, family in chosen.items())


def format_tables(report: dict) -> str:
    lines = [f"renderer: {report['machine']['gl_renderer']}, {report['machine']['cpu_count']} CPUs",
             f"GPU times: {report['machine']['gpu_timing']}", ""]
    if report.get("lbvh"):
        lines.append(f"lbvh ({variants_line(report, 'lbvh')})")
        lines.append(f"{'triangles':>10} {'GPU ms':>9} {'Embree ms':>10} {'numpy ms':>10} "
                     f"{'GPU/Embree':>11} {'numpy/GPU':>10}")
    for row in report.get("lbvh", []):
        embree = row.get("embree_build_ms")
        lines.append(
            f"{row['triangles']:>10} {row['build_ms']:>9.1f} "
            + (f"{embree:>10.1f} " if embree else f"{'-':>10} ")
            + f"{row['numpy_build_ms']:>10.1f} "
            + (f"{row['build_ms'] / embree:>11.2f} " if embree else f"{'-':>11} ")
            + f"{row['numpy_build_ms'] / row['build_ms']:>10.1f}")
    trace = report.get("trace")
    if trace and trace.get("embree_mrays_per_s") is None:
        lines += ["", f"trace ({variants_line(report, 'trace')})",
                  f"trace ({trace['kind']}, {trace['rays']} rays, {trace['triangles']} triangles): "
                  f"GPU {trace['mrays_per_s']:.3f} Mrays/s, without the ray sort "
                  f"{trace['mrays_per_s_unsorted']:.3f} Mrays/s; {trace['embree']}"]
    elif trace:
        lines.append("")
        lines.append(f"trace ({variants_line(report, 'trace')})")
        lines.append(
            f"trace ({trace['kind']}, {trace['rays']} rays, {trace['triangles']} triangles): "
            f"GPU {trace['mrays_per_s']:.3f} Mrays/s, Embree {trace['embree_mrays_per_s']:.3f} "
            f"Mrays/s ({trace['embree_threads']} thread(s)), ratio "
            f"{trace['mrays_per_s'] / trace['embree_mrays_per_s']:.2f}, agreement "
            f"{100 * trace['hit_agreement']:.3f}%; GPU without the ray sort "
            f"{trace['mrays_per_s_unsorted']:.3f} Mrays/s")
    frame = report.get("frame")
    if frame:
        lines.extend(["", f"frame ({variants_line(report, 'frame')})", format_frame_table(frame)])
    kernels = report.get("kernels")
    if kernels:
        lines.extend(["", f"kernels ({kernels['mode']}; chosen: "
                      + ", ".join(f"{k}={f}" for k, f in kernels["chosen"].items()) + ")"])
        lines.extend(device_report.kernel_rows(kernels))
    for name in ("lbvh_target", "frame_target"):
        if report.get(name):
            lines.extend(["", f"{name} ({variants_line(report, name)})"])
            lines.extend(f"  {what}: {value} (target {target})"
                         for section, what, value, target in device_report.section_rows({name: report[name]}))
    host = report.get("host")
    if host:
        lines.append("")
        if "skipped" in host:
            lines.append(f"host: skipped ({host['skipped']})")
        else:
            lines.append("host: per frame after the first (ms, mean): scene sync + upload")
            for name, row in host.items():
                lines.append(f"  {name:<10} {row['triangles']:>10,} triangles  extract {row['extract_ms']:8.2f}  "
                             f"upload {row['upload_ms']:7.2f}  host {row['host_ms']:8.2f}")
    return "\n".join(lines)


def format_frame_table(frame: dict) -> str:
    """The frame section: per-pass medians of both modes side by side, then the summary."""
    lines = [
        f"frame: {frame['scene']}, {frame['triangles_total']} triangles "
        f"({frame['triangles_bvh']} in the near-cube BVH, {frame['objects_near']} of "
        f"{frame['objects_total']} objects near), {frame['resolution']}, max depth "
        f"{frame['max_depth']}, cube faces {frame['cube_resolution']}, near size {frame['near_size']:g}",
        f"{'pass':<18} {'HYBRID ms':>10} {'FULL_BVH ms':>12} {'HYBRID host':>12} {'HYBRID GPU':>11}",
    ]
    hybrid, full = frame["passes_hybrid"], frame["passes_full_bvh"]
    host, gpu = frame.get("host_passes_hybrid", {}), frame.get("gpu_passes_hybrid", {})
    names = list(hybrid) + [name for name in full if name not in hybrid]
    for name in names:
        h = f"{hybrid[name]:>10.1f}" if name in hybrid else f"{'-':>10}"
        f = f"{full[name]:>12.1f}" if name in full else f"{'-':>12}"
        c = f"{host[name]:>12.1f}" if name in host else f"{'-':>12}"
        g = f"{gpu[name]:>11.2f}" if name in gpu else f"{'-':>11}"
        lines.append(f"{name:<18} {h} {f} {c} {g}")
    lines.append(f"{'frame (median)':<18} {frame['hybrid_ms']:>10.1f} {frame['full_bvh_ms']:>12.1f}")
    flip = frame["flip_mean"]
    lines.append(
        f"speedup {frame['speedup']:.2f} (bar {FRAME_SPEEDUP_BAR:g}: "
        f"{'met' if frame['speedup'] >= FRAME_SPEEDUP_BAR else 'NOT met'}; without upload "
        f"{frame['speedup_without_upload']:.2f}), "
        + (f"FLIP {flip:.4f} (bar {FRAME_FLIP_BAR:g}: {'met' if flip <= FRAME_FLIP_BAR else 'NOT met'})"
           if flip is not None else "FLIP not measured (no flip_evaluator)"))
    return "\n".join(lines)


SECTIONS = ("lbvh", "trace", "frame", "host", "kernels", "lbvh_target", "frame_target")
VARIANT_MODES = ("both", "auto")
# The host section follows Blender scenes (scripts/bench_host.py): it runs where bpy does, in a
# process of its own that imports this checkout as the add-on.
HOST_SCRIPT = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "scripts", "bench_host.py")


def host_section(quick: bool) -> dict:
    """Per-frame host milliseconds (scene sync + upload) of five Blender scenes, or why not."""
    import importlib.util
    import subprocess
    import tempfile

    if importlib.util.find_spec("bpy") is None:
        return {"skipped": "needs bpy (Blender as a Python module), which this Python lacks"}
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "host.json")
        command = [sys.executable, HOST_SCRIPT, "--json", path] + (["--quick"] if quick else [])
        subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
        with open(path, encoding="utf-8") as handle:
            return json.load(handle)


def run(quick: bool = False, sections=SECTIONS, rounds: int = ROUNDS,
        resolution: tuple[int, int] | None = None, near_size: float = FRAME_NEAR_SIZE,
        detail: float | None = None, cube_march: str = "HIERARCHICAL",
        cube_back_layer: bool = FRAME_BACK_LAYER, variant_mode: str = "both") -> dict:
    """Run the requested sections and return the report dictionary (``resolution``: the
    frame section's image size, default :func:`default_frame_resolution`; ``near_size``: its
    near-cube half-size; ``detail``: the Chess scene's detail, default 1.0 (0.02 quick);
    ``cube_march``: how HYBRID marches the cube map; ``cube_back_layer``: whether its cube map
    keeps the back layer; ``variant_mode``: the kernels section's "both" or "auto")."""
    report: dict = {"machine": machine_info(), "quick": bool(quick), "rounds": rounds,
                    "device": device_report.gl_description(), "variants": variants.chosen(),
                    "section_variants": {name: variants.chosen() for name in sections}}
    if "lbvh" in sections:
        report["lbvh"] = lbvh_section(QUICK_BUILD_SIZES if quick else FULL_BUILD_SIZES, rounds)
    if "trace" in sections:
        params = QUICK_TRACE if quick else FULL_TRACE
        report["trace"] = trace_section(params["triangles"], params["rays"], rounds)
    if "frame" in sections:
        params = QUICK_FRAME if quick else FULL_FRAME
        report["frame"] = frame_section(
            detail=params["detail"] if detail is None else detail,
            resolution=resolution or default_frame_resolution(quick),
            rounds=rounds, cube_resolution=params["cube_resolution"], near_size=near_size,
            cube_march=cube_march, cube_back_layer=cube_back_layer)
    if "host" in sections:
        report["host"] = host_section(quick)
    if "kernels" in sections:
        report["kernels"] = kernel_bench.kernel_section(variant_mode, quick, rounds)
    if "lbvh_target" in sections:
        report["lbvh_target"] = kernel_bench.lbvh_target_section(quick, rounds)
    if "frame_target" in sections:
        report["frame_target"] = kernel_bench.frame_target_section(quick)
    return report


def choice_list(choices: tuple[str, ...]) -> Callable[[str], list[str]]:
    """An argparse type: a comma-separated subset of ``choices``."""
    def parse(text: str) -> list[str]:
        names = [name.strip() for name in text.split(",") if name.strip()]
        unknown = sorted(set(names) - set(choices))
        if unknown:
            raise argparse.ArgumentTypeError(f"unknown: {', '.join(unknown)} (choose from {', '.join(choices)})")
        return names
    return parse


def parse_resolution(text: str) -> tuple[int, int]:
    """'640x360' -> (640, 360); argparse reports the ValueError's message."""
    parts = text.lower().split("x")
    try:
        width, height = (int(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"resolution must look like 640x360, got {text!r}") from None
    if not (1 <= width <= 16384 and 1 <= height <= 16384):
        raise argparse.ArgumentTypeError(f"resolution must be 1..16384 per side, got {text!r}")
    return width, height


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="tiny sizes (seconds, for tests)")
    parser.add_argument("--json", metavar="PATH", help="write the report as JSON to PATH")
    parser.add_argument("--rounds", type=int, default=ROUNDS, help="interleaved timed rounds")
    parser.add_argument("--resolution", metavar="WxH", type=parse_resolution, default=None,
                        help="image size of the frame section (default 640x360 on a software "
                        "renderer, 1280x720 on a GPU, 96x54 with --quick)")
    parser.add_argument("--near-size", type=float, default=FRAME_NEAR_SIZE,
                        help=f"near-cube half-size of the frame section (default {FRAME_NEAR_SIZE:g})")
    parser.add_argument("--detail", type=float, default=None,
                        help="Chess scene detail of the frame section (default 1.0, 0.02 with --quick)")
    parser.add_argument("--cube-march", choices=CUBE_MARCHES, default="HIERARCHICAL",
                        help="how HYBRID marches the cube map in the frame section")
    parser.add_argument("--back-layer", action=argparse.BooleanOptionalAction, default=FRAME_BACK_LAYER,
                        help="HYBRID's cube map with the back layer (settings.cube_back_layer; "
                        "default on: --no-back-layer for the paper's single layer)")
    parser.add_argument("--sections", type=choice_list(SECTIONS), default=list(SECTIONS),
                        help=f"comma-separated subset of {', '.join(SECTIONS)}")
    parser.add_argument("--variants", choices=VARIANT_MODES, default="both",
                        help="kernels section: both families of every kernel with two shapes side by "
                        "side (default), or only the family chosen for this GL renderer (auto)")
    parser.add_argument("--device-report", metavar="PATH",
                        help="write a Markdown page (GL strings, limits, chosen variants, the measured "
                        "sections) for docs/BENCHMARKS.md's GPU figures to PATH")
    args = parser.parse_args(argv)
    sections = args.sections
    if args.rounds < 1:
        parser.error("--rounds must be >= 1")
    if not (math.isfinite(args.near_size) and 0 < args.near_size < CHESS_CUBE_FAR):
        parser.error(f"--near-size must lie in (0, {CHESS_CUBE_FAR:g}) (the cube map's far plane)")
    if args.detail is not None and not 0 < args.detail <= 1:
        parser.error("--detail must lie in (0, 1]")
    report = run(args.quick, sections, args.rounds, args.resolution, args.near_size,
                 args.detail, args.cube_march, args.back_layer, args.variants)
    print(format_tables(report))
    if args.device_report:
        command = "python -m benchmarks.bench " + " ".join(sys.argv[1:] if argv is None else argv)
        with open(args.device_report, "w", encoding="utf-8") as handle:
            handle.write(device_report.device_report(report, command.strip()))
    write_json(report, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
