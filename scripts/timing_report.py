# SPDX-License-Identifier: GPL-3.0-or-later
"""Write a Hybrid RT timing report of a .blend file's animation, with bpy as a Python module.

Usage: python scripts/timing_report.py --blend FILE --prefix out/report [--start 1] [--end 200]
       [--mode HYBRID] [--compare-full-bvh] [--warmup 1]

Registers the add-on from this checkout (as scripts/demo.py does), opens the .blend, and runs
``bpy.ops.hybrid_rt.timing_report``: every frame of the range (default: the scene's frame
range) is rendered through the engine and PREFIX.json, PREFIX.csv and PREFIX.png are written.
The .blend file itself is never saved. Prints the summary; exits with 1 when the report
could not be made (the reason is printed).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from addon_loader import load_addon



def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--blend", required=True, help=".blend file to open")
    parser.add_argument("--prefix", required=True, help="output prefix: PREFIX.json, .csv, .png and .svg")
    parser.add_argument("--start", type=int, help="first frame (default: the scene's start frame)")
    parser.add_argument("--end", type=int, help="last frame (default: the scene's end frame)")
    parser.add_argument("--scene", help="scene name (default: the file's active scene)")
    parser.add_argument("--mode", help="render mode for this report (default: the scene's own)")
    parser.add_argument("--compare-full-bvh", action="store_true",
                        help="also render the range in FULL_BVH mode and write a comparison chart")
    parser.add_argument("--warmup", type=int, default=1, help="unrecorded renders of the first frame")
    args = parser.parse_args(argv)

    blend = Path(args.blend).resolve()
    if not blend.is_file():
        print(f"timing_report: no such .blend file: {blend}", file=sys.stderr)
        return 1

    import bpy

    addon = load_addon()
    addon.register()
    try:
        bpy.ops.wm.open_mainfile(filepath=str(blend), load_ui=False)
        # Opening a file keeps registered add-on classes; the scene now has scene.hybrid_rt.
        if args.scene is not None:
            if args.scene not in bpy.data.scenes:
                print(f"timing_report: {blend.name} has no scene {args.scene!r}", file=sys.stderr)
                return 1
            bpy.context.window.scene = bpy.data.scenes[args.scene]
        scene = bpy.context.scene
        scene.render.engine = "HYBRID_RT"
        if args.mode is not None:
            scene.hybrid_rt.mode = args.mode
        options = {"filepath": str(Path(args.prefix).resolve()), "compare_full_bvh": args.compare_full_bvh,
                   "warmup_frames": args.warmup}
        if args.start is not None:
            options["frame_start"] = args.start
        if args.end is not None:
            options["frame_end"] = args.end
        try:
            bpy.ops.hybrid_rt.timing_report(**options)
        except RuntimeError as exc:  # the operator's ERROR report
            print(f"timing_report: {exc}", file=sys.stderr)
            return 1
        report = json.loads(Path(options["filepath"] + ".json").read_text(encoding="utf-8"))
        summary = report["summary"]
        print(f"timing_report: {summary['frames']} frames of {report['scene']['name']!r} "
              f"({', '.join(report['rendered_modes'])}; {report['gl_renderer']}; {report['timing_source']})")
        frame_ms = summary["frame_ms"]
        print(f"  frame ms: mean {frame_ms['mean']:.2f}  median {frame_ms['median']:.2f}  "
              f"p95 {frame_ms['p95']:.2f}  max {frame_ms['max']:.2f}")
        for name, ms in summary["pass_mean_ms"].items():
            print(f"  {name:<18} {ms:9.3f} ms  {summary['pass_share'][name] * 100:5.1f} %")
        return 0
    finally:
        addon.unregister()


if __name__ == "__main__":
    sys.exit(main())
