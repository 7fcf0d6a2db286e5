# SPDX-License-Identifier: GPL-3.0-or-later
"""What the picture's features cost on the Chess benchmark frame: one sample of HYBRID with
the features on (the product) and switched off, side by side in one process.

``python -m benchmarks.picture_cost [--quick] [--rounds N] [--json PATH]``

"Off" is the shading before the World light, Principled specular and soft lamps: hard
shadows, no sun cascades, no World light (so no occlusion pass or rays either), no
dielectric coat, no lamp highlights, and the sky at once past the depth limit instead of
one more traced ray. Two settings (``ao_distance`` 0, ``shadow_cascades`` 0) and the
shaders' measurement switches (``OFF_DEFINES``, compiled through
``shader_loader.compiled_with``) make it; the rest of the frame is the same code. Each
variant has its own renderer, constructed and rendered inside its switches; the frames of
the Chess animation alternate between them as the frame section's modes do, the first
``bench.WARM_UP_FRAMES`` warming up. Figures: medians and means of the timed frames' totals,
per-pass medians, and the ratio on / off (the issue's bar: at most 1.25).

``--light`` compares the light indoors instead: "on" is the default diffuse light (traced
paths with the emitters, denoised as the viewport denoises), "off" the screen-space World
light within AO Distance without the denoiser, the default before it (bar: 1.35).
"""
from __future__ import annotations

import argparse
import statistics
import sys
from contextlib import nullcontext

import numpy as np

from benchmarks import bench
from benchmarks.scenes.chess import CHESS_CUBE_FAR, build_chess
from hybrid_engine.gpu import gl_context
from hybrid_engine.gpu import shader_loader
from hybrid_engine.scene.settings import RenderSettings

# The shaders' switches of the off variant (include/shading.glsl, include/lighting.glsl,
# trace/hybrid_trace.comp.glsl).
OFF_DEFINES = {"HARD_SHADOWS": 1, "NO_WORLD_LIGHT": 1, "NO_COAT": 1, "NO_LAMP_HIGHLIGHTS": 1,
               "NO_DEPTH_LIMIT_RAY": 1}
OFF_SETTINGS = {"ao_distance": 0.0, "shadow_cascades": 0, "world_light": "SCREEN"}
COST_BAR = 1.25
# --light: the screen-space World light, undenoised, against the defaults.
LIGHT_OFF_SETTINGS = {"world_light": "SCREEN"}
LIGHT_COST_BAR = 1.35


def measure(quick: bool = False, rounds: int = 3, frames: int = bench.ROUNDS, light: bool = False) -> dict:
    """Both variants over ``rounds`` passes of ``frames`` timed frames (plus the warm-up);
    ``light``: the light-indoors comparison (module docstring)."""
    from hybrid_engine.frame.renderer import Renderer

    params = bench.QUICK_FRAME if quick else bench.FULL_FRAME
    width, height = bench.default_frame_resolution(quick)
    scenes = [build_chess(params["detail"], bench.FRAME_NUMBER + k, width, height)
              for k in range(frames + bench.WARM_UP_FRAMES)]
    base = dict(mode="HYBRID", near_size=bench.FRAME_NEAR_SIZE, max_depth=bench.FRAME_MAX_DEPTH,
                cube_resolution=params["cube_resolution"], cube_far=CHESS_CUBE_FAR,
                cube_back_layer=bench.FRAME_BACK_LAYER)
    if light:
        variants = {"on": (RenderSettings(**base), {}), "off": (RenderSettings(**{**base, **LIGHT_OFF_SETTINGS}), {})}
    else:
        variants = {
            "on": (RenderSettings(**base), {}),
            "off": (RenderSettings(**{**base, **OFF_SETTINGS}), OFF_DEFINES),
        }
    denoise = {"on": light, "off": False}
    ctx = gl_context.get_context()

    def switches(name: str):
        defines = variants[name][1]
        return shader_loader.compiled_with(defines) if defines else nullcontext()

    renderers = {}
    for name in variants:
        with switches(name):
            renderers[name] = Renderer(ctx)
    results: dict[str, list] = {name: [] for name in variants}
    try:
        for _ in range(rounds):
            for index, (scene, camera) in enumerate(scenes):
                for name, (settings, _) in variants.items():
                    with switches(name):
                        result = renderers[name].render(scene, camera, settings, timing=True,
                                                        denoise=denoise[name])
                    if index >= bench.WARM_UP_FRAMES:
                        results[name].append(result)
    finally:
        for renderer in renderers.values():
            renderer.release()
    report: dict = {"scene": f"chess (procedural, detail {params['detail']:g})",
                    "resolution": f"{width}x{height}", "frames": len(results["on"]),
                    "comparison": "light" if light else "features",
                    "off_defines": [] if light else sorted(OFF_DEFINES),
                    "off_settings": LIGHT_OFF_SETTINGS if light else OFF_SETTINGS,
                    "bar": LIGHT_COST_BAR if light else COST_BAR}
    for name, runs in results.items():
        totals = [r.total_ms for r in runs]
        report[name] = {"median_ms": round(statistics.median(totals), 3),
                        "mean_ms": round(statistics.fmean(totals), 3),
                        "passes": bench.pass_medians(runs),
                        "mean_radiance": round(float(np.mean(runs[-1].image[..., :3])), 6)}
    report["ratio_median"] = round(report["on"]["median_ms"] / report["off"]["median_ms"], 4)
    report["ratio_mean"] = round(report["on"]["mean_ms"] / report["off"]["mean_ms"], 4)
    return report


def format_report(report: dict) -> str:
    lines = [f"{report['scene']}, {report['resolution']}, {report['frames']} timed frames per variant"]
    for name in ("on", "off"):
        figures = report[name]
        passes = ", ".join(f"{k} {v:.0f}" for k, v in figures["passes"].items())
        lines.append(f"  {report.get('comparison', 'features')} {name:3s}: median {figures['median_ms']:.0f} ms, mean {figures['mean_ms']:.0f} ms"
                     f" ({passes})")
    bar = report.get("bar", COST_BAR)
    met = max(report["ratio_median"], report["ratio_mean"]) <= bar
    lines.append(f"  on / off: {report['ratio_median']:.2f}x by median, {report['ratio_mean']:.2f}x by mean"
                 f" (bar {bar:g}: {'met' if met else 'NOT met'})")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="tiny sizes (seconds, for tests)")
    parser.add_argument("--rounds", type=int, default=3, help="passes over the frames (default 3)")
    parser.add_argument("--frames", type=int, default=bench.ROUNDS, help="timed frames per pass")
    parser.add_argument("--json", help="also write the report here")
    parser.add_argument("--light", action="store_true",
                        help="compare the default diffuse light and denoiser with the screen-space light")
    args = parser.parse_args(argv)
    report = measure(args.quick, args.rounds, args.frames, args.light)
    print(format_report(report))
    bench.write_json(report, args.json)
    return report


if __name__ == "__main__":
    main(sys.argv[1:])
