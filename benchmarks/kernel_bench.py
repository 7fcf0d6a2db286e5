# SPDX-License-Identifier: GPL-3.0-or-later
"""The benchmark's kernel-variant and target sections (``python -m benchmarks.bench``).

``kernels``
    Each kernel that comes in two shapes in the code (gpu/variants.py: a module of the
    renderer calls ``variants.choose("<kernel>")``) measured in both families side by side,
    or only in the family chosen for this GL renderer (``--variants auto``). Each sample
    forces the kernel's family with ``variants.set_override("<kernel>=<family>")`` and builds
    fresh objects, so a kernel that picks its shape when its objects are made is measured as
    well as one that picks it per call; the families alternate sample by sample (a drifting
    machine hits both alike) and each figure is the median over the rounds. A kernel's
    probe (:data:`KERNEL_PROBES`) times the work its variants change: the cube-map and
    shadow faces for ``faces``, the LBVH build for ``sort`` and ``scan``, a Chess frame's
    trace pass for ``trace``, the primary G-buffer for ``vertices``, one 1080p image's trip to
    the host for ``readback``. A new kernel with two shapes is measured
    without changes here as soon as its module calls ``variants.choose``; one without a
    probe of its own is measured by whole frames.
``lbvh_target``, ``frame_target``
    The two figures the project holds a hardware GPU to (docs/BENCHMARKS.md, "GPU
    figures"): an LBVH build of 1M triangles (target <= 1 ms) and the median of several
    1280x720 Chess frames at four bounces in HYBRID (target >= 60 FPS). On llvmpipe both are
    far off; ``--quick`` shrinks them to test sizes.
"""
from __future__ import annotations

import re
import statistics
import time
from functools import lru_cache
from pathlib import Path
from typing import Callable

import numpy as np

from hybrid_engine.gpu import gl_context, variants

LBVH_TARGET_MS = 1.0
FRAME_TARGET_FPS = 60.0
TARGET_LBVH_TRIANGLES = {False: 1_000_000, True: 20_000}
TARGET_FRAME = {False: {"detail": 1.0, "resolution": (1280, 720), "cube_resolution": 512},
                True: {"detail": 0.02, "resolution": (96, 54), "cube_resolution": 128}}
TARGET_FRAMES = {False: 5, True: 2}  # timed frames (after the bench's warm-up frames)
# Inside one sample: one warm-up call, then this many timed calls (median).
PROBE_REPEATS = {False: 3, True: 1}
PACKAGE_ROOT = Path(__file__).resolve().parent.parent / "hybrid_engine"

Probe = Callable[[bool, int], dict[str, float]]


@lru_cache(maxsize=1)
def kernels_in_code() -> tuple[str, ...]:
    """The kernels of variants.KERNELS whose two shapes exist in the code: those some module
    of the renderer asks ``variants.choose`` about, directly or through a helper that is
    handed the kernel's name (read from the source, so that a kernel gains its section the
    day its variant lands)."""
    found: set[str] = set()
    pattern = re.compile(r"""(?:choose|resolve_family)\(\s*(?:\w+\s*,\s*)?["'](\w+)["']""")
    for path in PACKAGE_ROOT.rglob("*.py"):
        if path.name == "variants.py":
            continue
        found.update(pattern.findall(path.read_text(encoding="utf-8")))
    return tuple(kernel for kernel in variants.KERNELS if kernel in found)


def _timed(ctx, run: Callable[[], object], repeats: int) -> float:
    """Median wall milliseconds of ``run`` bracketed by ctx.finish(), after one warm-up call."""
    run()
    samples = []
    for _ in range(repeats):
        ctx.finish()
        start = time.perf_counter()
        run()
        ctx.finish()
        samples.append((time.perf_counter() - start) * 1e3)
    return statistics.median(samples)


@lru_cache(maxsize=2)
def _chess(quick: bool, frame: int = 3):
    from .bench import FULL_FRAME, QUICK_FRAME
    from .scenes.chess import build_chess

    params = QUICK_FRAME if quick else FULL_FRAME
    width, height = params["resolution"]
    return build_chess(params["detail"], frame, width, height), params


def faces_probe(quick: bool, repeats: int) -> dict[str, float]:
    """The cube map's faces (per-face culling included) and every shadow slot of a Chess
    frame, each drawn from scratch (fresh passes)."""
    from hybrid_engine.passes.cube_map.cube_map import CubeMapPass
    from hybrid_engine.passes.gbuffer.gbuffer import GBufferPass
    from hybrid_engine.passes.scene_upload.scene_buffers import GPUScene
    from hybrid_engine.passes.shadow_maps.shadow_depth import ShadowDepthPass
    from hybrid_engine.passes.view_cull.draw import SceneDrawer
    from hybrid_engine.scene.changes import GeometryDelta
    from hybrid_engine.scene.settings import RenderSettings

    from .bench import FRAME_BACK_LAYER, FRAME_NEAR_SIZE
    from .scenes.chess import CHESS_CUBE_FAR

    (scene, camera), params = _chess(quick)
    ctx = gl_context.get_context()
    settings = RenderSettings(mode="HYBRID", near_size=FRAME_NEAR_SIZE, cube_far=CHESS_CUBE_FAR,
                              cube_resolution=params["cube_resolution"], cube_back_layer=FRAME_BACK_LAYER,
                              shadow_resolution=256 if quick else 1024)
    gpu, drawer = GPUScene(ctx), SceneDrawer(ctx)
    raster = GBufferPass(ctx, drawer)
    cube, shadows = CubeMapPass(ctx, raster), ShadowDepthPass(ctx, drawer)
    center = np.asarray(camera.position, np.float64)
    try:
        gpu.upload(scene)
        gpu.transform()
        triangles = (gpu.positions.buffer, gpu.triangle_count)
        cube_ms = _timed(ctx, lambda: cube.render(gpu, scene, center, settings, triangles=triangles), repeats)
        every = GeometryDelta.everything(scene.geometry.triangle_count)
        shadow_ms = _timed(ctx, lambda: shadows.render(gpu, scene, camera, settings, shadows.atlas, every), repeats)
    finally:
        for part in (cube, shadows, raster, drawer, gpu):
            part.release()
    return {"cube_map_ms": cube_ms, "shadow_maps_ms": shadow_ms}


def primary_probe(quick: bool, repeats: int) -> dict[str, float]:
    """The primary G-buffer of a Chess frame (a fresh pass): drawn from the world-space rows
    or instanced and indexed, as the ``vertices`` kernel's variant says."""
    from hybrid_engine.passes.gbuffer.gbuffer import GBufferPass
    from hybrid_engine.passes.scene_upload.scene_buffers import GPUScene
    from hybrid_engine.scene.raster_view import RasterView

    (scene, camera), _ = _chess(quick)
    ctx = gl_context.get_context()
    gpu, raster = GPUScene(ctx), GBufferPass(ctx)
    try:
        uploaded, _ = gpu.upload(scene)
        gpu.transform()
        view = RasterView.from_camera(camera)
        primary_ms = _timed(ctx, lambda: raster.render_primary(gpu, uploaded, view), repeats)
    finally:
        raster.release()
        gpu.release()
    return {"primary_raster_ms": primary_ms}


def lbvh_probe(quick: bool, repeats: int) -> dict[str, float]:
    """An LBVH build (Morton codes, sort, hierarchy, refit) with a fresh builder."""
    size = 10_000 if quick else 1_000_000
    return {f"lbvh_build_{size // 1000}k_ms": _lbvh_build_ms(size, repeats)}


def _lbvh_build_ms(size: int, repeats: int) -> float:
    """The median build of a mesh-like scene of ``size`` triangles with a fresh builder."""
    from hybrid_engine.passes.lbvh import lbvh

    from .bench import SEED, mesh_like_scene

    ctx = gl_context.get_context()
    tris = mesh_like_scene(size, np.random.default_rng(SEED))
    builder = lbvh.LBVHBuilder(ctx)
    buffer = ctx.buffer(tris.tobytes())
    try:
        return _timed(ctx, lambda: builder.build(buffer, len(tris)), repeats)
    finally:
        buffer.release()
        builder.release()


def trace_probe(quick: bool, repeats: int) -> dict[str, float]:
    """The ``trace`` pass of a HYBRID Chess frame (the megakernel or the waves), timed by the
    renderer's pass timer, with a fresh renderer."""
    from hybrid_engine.frame.renderer import Renderer

    (scene, camera), params = _chess(quick)
    renderer = Renderer(gl_context.get_context())
    try:
        settings = _frame_settings(params)
        renderer.render(scene, camera, settings)  # uploads and compiles everything
        times = [renderer.render(scene, camera, settings, timing=True).passes["trace"] for _ in range(repeats)]
    finally:
        renderer.release()
    return {"trace_pass_ms": statistics.median(times)}


def gather_probe(quick: bool, repeats: int) -> dict[str, float]:
    """The ``shade`` pass of a denoised HYBRID Chess frame (the diffuse light's paths, per
    pixel or by persistent invocations), timed by the renderer's pass timer, with a fresh
    renderer; the frame's denoiser history is that of one still view."""
    from hybrid_engine.frame.renderer import Renderer

    (scene, camera), params = _chess(quick)
    renderer = Renderer(gl_context.get_context())
    try:
        settings = _frame_settings(params)
        renderer.render(scene, camera, settings, denoise=True)  # uploads and compiles everything
        times = [renderer.render(scene, camera, settings, timing=True, denoise=True, sample=k + 1).passes["shade"]
                 for k in range(repeats)]
    finally:
        renderer.release()
    return {"shade_pass_ms": statistics.median(times)}


def readback_probe(quick: bool, repeats: int) -> dict[str, float]:
    """One viewport image (RGBA32F, 1920x1080; 192x108 quick) brought to the host by a fresh
    reader: synchronous, or through a pixel buffer and a fence (waited for here)."""
    from hybrid_engine.frame.readback import ImageReadback

    width, height = (192, 108) if quick else (1920, 1080)
    ctx = gl_context.get_context()
    texture = ctx.texture((width, height), 4, dtype="f4")
    readback = ImageReadback(ctx)
    try:
        def read() -> None:
            readback.submit(texture)
            readback.collect(wait=True)

        read()
        ms = _timed(ctx, read, repeats)
    finally:
        readback.release()
        texture.release()
    return {f"readback_{height}p_ms": ms}


def _frame_settings(params: dict):
    from hybrid_engine.scene.settings import RenderSettings

    from .bench import FRAME_BACK_LAYER, FRAME_MAX_DEPTH, FRAME_NEAR_SIZE
    from .scenes.chess import CHESS_CUBE_FAR

    return RenderSettings(mode="HYBRID", near_size=FRAME_NEAR_SIZE, cube_far=CHESS_CUBE_FAR,
                          max_depth=FRAME_MAX_DEPTH, cube_resolution=params["cube_resolution"],
                          cube_back_layer=FRAME_BACK_LAYER)


def frame_probe(quick: bool, repeats: int) -> dict[str, float]:
    """Whole HYBRID Chess frames with a fresh renderer (what any kernel changes)."""
    from hybrid_engine.frame.renderer import Renderer

    (scene, camera), params = _chess(quick)
    settings = _frame_settings(params)
    renderer = Renderer(gl_context.get_context())
    try:
        renderer.render(scene, camera, settings)  # uploads everything
        frame_ms = _timed(renderer.ctx, lambda: renderer.render(scene, camera, settings), repeats)
    finally:
        renderer.release()
    return {"frame_ms": frame_ms}


# What each kernel's variants change (module doc); a kernel not named here: whole frames.
KERNEL_PROBES: dict[str, Probe] = {"faces": faces_probe, "sort": lbvh_probe, "scan": lbvh_probe,
                                   "trace": trace_probe, "readback": readback_probe, "vertices": primary_probe,
                                   "gather": gather_probe}


def kernel_section(mode: str, quick: bool, rounds: int) -> dict:
    """Every kernel with two shapes in the code, in both families (``mode`` "both") or in the
    chosen one ("auto"): {"chosen": ..., "kernels": {kernel: {family: {metric: median}}}}."""
    if mode not in ("both", "auto"):
        raise ValueError(f"variants mode must be 'both' or 'auto', got {mode!r}")
    chosen = variants.chosen()
    measured: dict[str, dict[str, dict[str, float]]] = {}
    repeats = PROBE_REPEATS[bool(quick)]
    for kernel in kernels_in_code():
        families = variants.FAMILIES if mode == "both" else (chosen[kernel],)
        probe = KERNEL_PROBES.get(kernel, frame_probe)
        samples: dict[str, list[dict[str, float]]] = {family: [] for family in families}
        try:
            for _ in range(rounds):
                for family in families:  # alternating, sample by sample
                    variants.set_override(f"{kernel}={family}")
                    samples[family].append(probe(quick, repeats))
        finally:
            variants.set_override(None)
        measured[kernel] = {family: {metric: round(statistics.median(s[metric] for s in runs), 4)
                                     for metric in runs[0]}
                            for family, runs in samples.items()}
    return {"mode": mode, "chosen": chosen, "in_code": list(kernels_in_code()), "kernels": measured}


def lbvh_target_section(quick: bool, rounds: int) -> dict:
    """The LBVH build of 1M triangles (20k with ``quick``), median of ``rounds`` builds."""
    size = TARGET_LBVH_TRIANGLES[bool(quick)]
    build_ms = _lbvh_build_ms(size, rounds)
    return {"triangles": int(size), "build_ms": round(build_ms, 3), "target_ms": LBVH_TARGET_MS,
            "met": bool(build_ms <= LBVH_TARGET_MS), "variants": variants.chosen()}


def frame_target_section(quick: bool, frames: int | None = None) -> dict:
    """HYBRID frames of the Chess animation at 1280x720 (96x54 with ``quick``), four
    bounces: the median of ``frames`` timed frames after the warm-up frames, as FPS."""
    from hybrid_engine.frame.renderer import Renderer
    from hybrid_engine.scene.settings import RenderSettings

    from .bench import FRAME_BACK_LAYER, FRAME_MAX_DEPTH, FRAME_NEAR_SIZE, FRAME_NUMBER, WARM_UP_FRAMES
    from .scenes.chess import CHESS_CUBE_FAR, build_chess

    params = TARGET_FRAME[bool(quick)]
    frames = TARGET_FRAMES[bool(quick)] if frames is None else int(frames)
    width, height = params["resolution"]
    settings = RenderSettings(mode="HYBRID", near_size=FRAME_NEAR_SIZE, cube_far=CHESS_CUBE_FAR,
                              max_depth=FRAME_MAX_DEPTH, cube_resolution=params["cube_resolution"],
                              cube_back_layer=FRAME_BACK_LAYER)
    renderer = Renderer(gl_context.get_context())
    times = []
    try:
        for k in range(WARM_UP_FRAMES + frames):
            scene, camera = build_chess(params["detail"], FRAME_NUMBER + k, width, height)
            result = renderer.render(scene, camera, settings)
            if k >= WARM_UP_FRAMES:
                times.append(result.total_ms)
    finally:
        renderer.release()
    frame_ms = statistics.median(times)
    fps = 1e3 / frame_ms
    return {"resolution": f"{width}x{height}", "detail": params["detail"], "max_depth": FRAME_MAX_DEPTH,
            "frames": frames, "frame_ms": round(frame_ms, 3), "fps": round(fps, 3),
            "target_fps": FRAME_TARGET_FPS, "met": bool(fps >= FRAME_TARGET_FPS), "variants": variants.chosen()}
