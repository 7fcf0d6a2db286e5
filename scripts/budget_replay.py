#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Frame Budget controllers compared offline, on frame times recorded at fixed near sizes.

A real run of ``bench_budget.py`` on Sponza takes a quarter of an hour and tells one noisy
outcome; choosing the controller's band, window and urgent ratio needs many. So:

``python scripts/budget_replay.py record --scene sponza --sizes 1.6,2,2.5,3.2,4,5 --frames 30 --out F.json``
    renders the scene's camera path in Fixed mode once per size, as ``bench_budget.py`` does
    (the same warm-up frames, which the controller also sees), and writes each frame's time;

``python scripts/budget_replay.py replay F.json --fixed-size 4 [--tolerance .1 --window 2 --urgent 1.15]``
    replays ``NearCubeBudget`` over those times, without bpy: a frame at a size between two
    recorded ones takes the log-log interpolation of that frame's two times. The budget is
    ``--budget-factor`` times Fixed mode's median at ``--fixed-size`` (``bench_budget.py``'s
    rule). It prints the share of frames within 15 % of the budget for the recording as it is,
    and the mean share and the chance of reaching 90 % over ``--runs`` replays with seeded
    log-normal noise of ``--noise`` added to every frame (a real run's frame-to-frame wander).
"""
from __future__ import annotations

import argparse
import json
import math
import random
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from addon_loader import REPO_ROOT  # noqa: E402,F401 - puts the repository root on sys.path

import bench_budget  # noqa: E402
from hybrid_engine.frame.near_budget import NearCubeBudget  # noqa: E402

BAR = 0.9


class Recording:
    """Frame times of one camera path at several fixed sizes: ``warm`` (the frames a run
    renders before measuring) and ``frames`` per size."""

    def __init__(self, data: dict) -> None:
        self.sizes = sorted(float(size) for size in data["sizes"])
        by_size = {float(size): rows for size, rows in data["sizes"].items()}
        self.warm = {size: by_size[size]["warm"] for size in self.sizes}
        self.frames = {size: by_size[size]["frames"] for size in self.sizes}
        self.count = min(len(times) for times in self.frames.values())

    def time(self, series: dict, index: int, size: float) -> float:
        """Frame ``index`` of ``series`` at ``size``, interpolated in log time over log size."""
        size = min(max(size, self.sizes[0]), self.sizes[-1])
        for low, high in zip(self.sizes, self.sizes[1:]):
            if low <= size <= high:
                w = math.log(size / low) / math.log(high / low)
                return math.exp((1 - w) * math.log(series[low][index]) + w * math.log(series[high][index]))
        return series[self.sizes[0]][index]


def replay(recording: Recording, controller: NearCubeBudget, noise: float, rng: random.Random) -> float:
    """The share of measured frames within bench_budget's band around the controller's budget."""
    def frame(series: dict, index: int) -> float:
        size = controller.size
        ms = recording.time(series, index, size) * math.exp(rng.gauss(0.0, noise) if noise else 0.0)
        controller.observe(ms, size)
        return ms

    for index in range(len(next(iter(recording.warm.values())))):
        frame(recording.warm, index)
    times = [frame(recording.frames, index) for index in range(recording.count)]
    return bench_budget.within_share(times, controller.budget_ms)


def record(args) -> int:
    from addon_loader import load_addon

    addon = load_addon()
    addon.register()
    try:
        from benchmarks import scene_library

        width, height = (int(v) for v in args.resolution.lower().split("x"))
        scene = scene_library.build_scene(args.scene, detail=args.detail, resolution=(width, height))
        frames = range(len(bench_budget.WARM_UP), len(bench_budget.WARM_UP) + args.frames)
        out = {"scene": args.scene, "sizes": {}}
        for size in (float(v) for v in args.sizes.split(",")):
            scene.hybrid_rt.near_size = size
            # The warm-up frames are measured too: a run's controller sees them.
            run = bench_budget.follow(scene, range(0, frames.stop), "HYBRID", "FIXED", 33.3, warm_up=range(0))
            times = [round(float(ms), 2) for ms, _, _ in run]
            out["sizes"][str(size)] = {"warm": times[:frames.start], "frames": times[frames.start:]}
            print(f"{args.scene} near {size}: median {statistics.median(times[frames.start:]):.0f} ms", flush=True)
            Path(args.out).write_text(json.dumps(out, indent=1) + "\n", encoding="utf-8")
    finally:
        addon.unregister()
    return 0


def replay_command(args) -> int:
    recording = Recording(json.loads(Path(args.recording).read_text(encoding="utf-8")))
    if args.fixed_size not in recording.sizes:
        raise SystemExit(f"--fixed-size {args.fixed_size} was not recorded (sizes: {recording.sizes})")
    budget = args.budget_factor * statistics.median(recording.frames[args.fixed_size][:recording.count])

    def controller() -> NearCubeBudget:
        kw = {name: value for name, value in (("tolerance", args.tolerance), ("window", args.window),
                                               ("urgent_ratio", args.urgent)) if value is not None}
        return NearCubeBudget(budget, args.near_min, args.near_max, args.fixed_size, **kw)

    fixed = recording.frames[args.fixed_size][:recording.count]
    print(f"budget {budget:.0f} ms; Fixed at {args.fixed_size}: "
          f"{bench_budget.within_share(fixed, budget):.2f} of frames within")
    print(f"as recorded: {replay(recording, controller(), 0.0, random.Random(0)):.2f} of frames within")
    rng = random.Random(args.seed)
    shares = [replay(recording, controller(), args.noise, rng) for _ in range(args.runs)]
    print(f"with {args.noise:.0%} noise, {args.runs} runs: mean {statistics.fmean(shares):.2f}, "
          f"{sum(share >= BAR - 1e-9 for share in shares) / len(shares):.2f} of runs reach {BAR:.0%}")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python scripts/budget_replay.py", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    commands = parser.add_subparsers(dest="command", required=True)
    rec = commands.add_parser("record")
    rec.add_argument("--scene", default="chess")
    rec.add_argument("--sizes", required=True, help="comma-separated near sizes")
    rec.add_argument("--frames", type=int, default=40)
    rec.add_argument("--detail", type=float, default=1.0)
    rec.add_argument("--resolution", default="640x360")
    rec.add_argument("--out", required=True)
    rep = commands.add_parser("replay")
    rep.add_argument("recording")
    rep.add_argument("--fixed-size", type=float, required=True)
    rep.add_argument("--budget-factor", type=float, default=0.9)
    rep.add_argument("--near-min", type=float, default=0.5)
    rep.add_argument("--near-max", type=float, default=10.0)
    rep.add_argument("--tolerance", type=float)
    rep.add_argument("--window", type=int)
    rep.add_argument("--urgent", type=float)
    rep.add_argument("--noise", type=float, default=0.04)
    rep.add_argument("--runs", type=int, default=300)
    rep.add_argument("--seed", type=int, default=7)
    args = parser.parse_args(argv)
    return record(args) if args.command == "record" else replay_command(args)


if __name__ == "__main__":
    sys.exit(main())
