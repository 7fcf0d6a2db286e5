#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Near Cube: Frame Budget against Fixed on a library scene's camera path.

``python scripts/bench_budget.py --scene chess --frames 40 [--budget-ms B | --budget-factor F]
[--json PATH]``

Follows the animation as a timing report does (``scene_cache.TrackedScene``, one sample per
frame, the engine's own ``render_depsgraph``): in Fixed mode at the scene's near size, in
Frame Budget mode, in Fixed mode again at the median size Budget mode chose (the fixed size
of about the same mean frame time, for comparing FLIP at equal cost), and in FULL_BVH for
reference. The budget defaults to Fixed mode's median frame times ``--budget-factor`` (1: a
budget Fixed mode misses on the frames whose load differs from the median's). Reports, per
mode, the share of frames within 15 % of the budget, the mean frame time, the mean FLIP
against FULL_BVH, and the near sizes.
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from addon_loader import load_addon  # noqa: E402 - also puts the repository root on sys.path

TOLERANCE = 0.15


def within_share(times, budget_ms: float) -> float:
    """The share of ``times`` within TOLERANCE of ``budget_ms``: the issue's measure."""
    times = list(times)
    return sum(abs(ms - budget_ms) <= TOLERANCE * budget_ms for ms in times) / len(times)


WARM_UP = range(0, 2)  # frames rendered before each run's measured ones, as a timing report's warm-up


def follow(scene, frames: range, mode: str, near_cube_mode: str, budget_ms: float,
           warm_up: range = WARM_UP) -> list[tuple]:
    """(total_ms, near_size, image) of each frame rendered in ``mode``, after the frames of
    ``warm_up`` in the same session (its first full sync and, in Budget mode, the controller's
    first frames are not measured, as in a timing report with warm-up frames)."""
    import bpy
    from hybrid_rt.blender_adapter import engine, scene_cache
    from hybrid_rt.hybrid_engine.frame.near_budget import NearCubeSizer

    scene.hybrid_rt.mode = mode
    scene.hybrid_rt.near_cube_mode = near_cube_mode
    scene.hybrid_rt.frame_budget_ms = budget_ms
    tracked, sizer = scene_cache.TrackedScene(), NearCubeSizer()
    out = []
    try:
        tracked.listen()
        for frame in [*warm_up, *frames]:
            scene.frame_set(frame)
            result = engine.render_depsgraph(bpy.context.evaluated_depsgraph_get(), source=tracked, sizer=sizer,
                                             timing=True)  # as the timing report renders
            if frame in frames:
                out.append((result.total_ms, result.near_size, result.image))
    finally:
        tracked.close()
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python scripts/bench_budget.py", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scene", default="chess")
    parser.add_argument("--frames", type=int, default=40, help="frames of the camera path, from frame 2")
    parser.add_argument("--detail", type=float, default=1.0)
    parser.add_argument("--resolution", default="640x360")
    parser.add_argument("--budget-ms", type=float, default=None)
    parser.add_argument("--budget-factor", type=float, default=1.0,
                        help="the budget as a multiple of Fixed mode's median frame (without --budget-ms)")
    parser.add_argument("--near-min", type=float, default=0.5)
    parser.add_argument("--near-max", type=float, default=10.0)
    parser.add_argument("--json", metavar="PATH")
    args = parser.parse_args(argv)
    width, height = (int(v) for v in args.resolution.lower().split("x"))

    addon = load_addon()
    addon.register()
    try:
        from benchmarks import bench, scene_library

        scene = scene_library.build_scene(args.scene, detail=args.detail, resolution=(width, height))
        scene.hybrid_rt.near_min, scene.hybrid_rt.near_max = args.near_min, args.near_max
        frames = range(2, 2 + args.frames)
        fixed = follow(scene, frames, "HYBRID", "FIXED", 33.3)
        budget_ms = args.budget_ms or args.budget_factor * statistics.median(ms for ms, _, _ in fixed)
        budget = follow(scene, frames, "HYBRID", "BUDGET", budget_ms)
        fixed_size = scene.hybrid_rt.near_size
        scene.hybrid_rt.near_size = statistics.median(size for _, size, _ in budget)
        same_cost = follow(scene, frames, "HYBRID", "FIXED", budget_ms)
        scene.hybrid_rt.near_size = fixed_size
        full = follow(scene, frames, "FULL_BVH", "FIXED", budget_ms)

        def summary(run: list[tuple]) -> dict:
            times = [ms for ms, _, _ in run]
            return {
                "within_share": within_share(times, budget_ms),
                "mean_ms": statistics.fmean(times),
                "flip_vs_full_bvh": statistics.fmean(
                    bench.flip_mean(f[2], r[2]) for r, f in zip(run, full)),
                "near_sizes": [round(float(size), 4) for _, size, _ in run],
                "frame_ms": [round(float(ms), 2) for ms, _, _ in run],
            }

        report = {"scene": args.scene, "frames": args.frames, "budget_ms": budget_ms,
                  "fixed_near_size": fixed[0][1], "fixed": summary(fixed), "budget": summary(budget),
                  "fixed_at_budget_median_size": summary(same_cost),
                  "full_bvh_mean_ms": statistics.fmean(ms for ms, _, _ in full)}
    finally:
        addon.unregister()
    for mode in ("fixed", "budget", "fixed_at_budget_median_size"):
        row = report[mode]
        print(f"{args.scene} {mode}: {100 * row['within_share']:.0f} % of frames within 15 % of "
              f"{budget_ms:.0f} ms, mean {row['mean_ms']:.0f} ms, FLIP vs FULL_BVH {row['flip_vs_full_bvh']:.4f}, "
              f"near {min(row['near_sizes']):.2f}-{max(row['near_sizes']):.2f}")
    print(f"{args.scene} FULL_BVH mean {report['full_bvh_mean_ms']:.0f} ms")
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
