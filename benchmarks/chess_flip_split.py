# SPDX-License-Identifier: GPL-3.0-or-later
"""Where HYBRID's Chess picture parts from FULL_BVH's, and whether it is noise or bias.

``python -m benchmarks.chess_flip_split [--detail 0.25] [--size 320x180] [--cube 256]
[--half 8] [--variants default,screen] [--json PATH]``

The bench's frame section (benchmarks/bench.py) compares one sample of each mode. With the
traced diffuse light (passes/diffuse_light/) one sample is noisy, and the two modes draw
different paths once a ray meets something else, so part of their difference is noise that
more samples average away; the rest is bias, which the paper's method (§3: the BVH near the
camera, the camera's cube map beyond it, §3.4) brings and samples do not remove. This
measures both, per variant of the settings (``VARIANTS``), in one process:

* ``2n`` samples of each mode (sample indices 0 .. 2n - 1, the viewport's accumulation, the
  same numbers in both modes), split into halves A (0 .. n - 1) and B (n .. 2n - 1);
* the noise floor: FLIP(A, B) of one mode against itself (``noise_h``, ``noise_f``);
* FLIP of the two modes on the same samples (``same``: 1 and ``2n`` samples), and on
  disjoint ones (``crossed``: HYBRID's A against FULL_BVH's B);
* ``bias_share``: of the per-pixel difference HYBRID - FULL_BVH (LDR luminance), the share
  that is the same in both halves (their covariance over the variance of one): 1 is pure
  bias, 0 pure noise;
* ``denoised_1``, ``denoised_all``: FLIP of the two modes' viewport pictures, the
  accumulated samples with the viewport's denoiser (``render(denoise=True)``), after one
  sample and after ``2n``;
* ``bias_share_diffuse``: the same share for the primary pixels' diffuse light alone
  (Diffuse Indirect times Diffuse Color, halves A and B);
* which light makes the difference: Cycles' light passes (passes/film/light_passes.py) of
  HYBRID with FULL_BVH's Diffuse Indirect put in (``flip_glossy_only``: what the
  reflections and refractions alone part), and FULL_BVH with HYBRID's Diffuse Indirect
  (``flip_diffuse_only``: what the primary pixels' diffuse light alone parts).

The scene is the bench's (benchmarks/scenes/chess.py) at frame 2 with the bench's settings
(near size 3.5, four bounces, the back layer, the hierarchical march). The variant
``no_footprints`` marches the cube map by one depth per texel, the paper's rule, for every
ray (passes/cube_map/cube_map.py ``CubeMapPass.footprints``); ``paper_mirrors`` for the
mirror and glass rays alone (passes/trace/tracer.py ``MIRROR_FOOTPRINTS``), the diffuse
paths following the surface footprints.

``--escapes SAMPLES`` counts instead, ray by ray, where the first gather rays of the two
modes disagree (``gather_escapes``): without bounces and reflections, both modes drawing the
same directions, the rays that escape to the sky in HYBRID where FULL_BVH's meet a surface
and those that stop where FULL_BVH's escape, by the surface they leave (its Diffuse Color),
with the footprints and without. docs/BENCHMARKS.md holds the figures.
"""
from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

from benchmarks.bench import flip_mean, parse_resolution, to_srgb_ldr
from benchmarks.scenes.chess import CHESS_CUBE_FAR, build_chess
from hybrid_engine.passes.cube_map.cube_map import CubeMapPass
from hybrid_engine.passes.trace import tracer

FRAME = 2
FOOTPRINTS = "footprints"  # a variant's key for CubeMapPass.footprints, not a setting
MIRROR_FOOTPRINTS = "mirror_footprints"  # a variant's key for tracer.MIRROR_FOOTPRINTS, not a setting
VARIANTS = {
    "default": {},
    "screen": {"world_light": "SCREEN"},  # the screen-space light of before the traced light
    "bounces0": {"diffuse_bounces": 0},
    "depth0": {"max_depth": 0},  # no reflections or refractions: the primary diffuse light alone
    "lit_cube": {"lit_cube": True},
    "cube_x2": {"cube_resolution": "x2"},
    "no_hidden_exit": {"cube_hidden_exit": False},
    "no_back_layer": {"cube_back_layer": False},
    "no_footprints": {FOOTPRINTS: False},
    "paper_mirrors": {MIRROR_FOOTPRINTS: False},  # the mirror and glass rays by the paper's rule
}
# Chess's diffuse colours as the light passes give them (the albedo less the reflected share).
SURFACES = {"floor": (0.45, 0.45, 0.45), "board frames": (0.35, 0.18, 0.08), "light squares": (0.68, 0.64, 0.56),
            "dark squares": (0.07, 0.06, 0.05), "white pieces": (0.19, 0.19, 0.18), "black pieces": (0.09, 0.09, 0.1)}
LIGHT_FLAGS = ("use_pass_diffuse_indirect", "use_pass_diffuse_color", "use_pass_glossy_indirect",
               "use_pass_glossy_color", "use_pass_transmission_indirect", "use_pass_transmission_color")


def base_settings(cube: int) -> dict:
    """The bench's frame-section settings (bench.frame_section) at cube faces of ``cube`` texels."""
    return dict(near_size=3.5, max_depth=4, cube_resolution=int(cube), cube_far=CHESS_CUBE_FAR,
                cube_march="HIERARCHICAL", cube_back_layer=True)


def render_samples(renderer, scene, camera, settings, count: int) -> tuple[np.ndarray, dict, dict]:
    """Samples 0 .. count - 1 of one view, each on its own ((count, H, W, 3) float64, recovered
    from the accumulated means), and the light passes' means over all of them and over the
    first half of them."""
    from hybrid_engine.frame.film import FrameOutputs
    from hybrid_engine.passes.film.light_passes import LightPassRequest

    outputs = FrameOutputs(light=LightPassRequest(flags=LIGHT_FLAGS))
    samples, previous, result, first_half = [], 0.0, None, {}
    for k in range(count):
        result = renderer.render(scene, camera, settings, sample=k, accumulate=True, reuse_world=k > 0,
                                 outputs=outputs, statistics=False)
        total = result.image[..., :3].astype(np.float64) * (k + 1)
        samples.append(total - previous)
        previous = total
        if k == count // 2 - 1:
            first_half = {name: a[..., :3].astype(np.float64) for name, a in result.data_passes.items()}
    passes = {name: a[..., :3].astype(np.float64) for name, a in result.data_passes.items()}
    return np.array(samples), passes, first_half


def denoised_pictures(renderer, scene, camera, settings, count: int) -> tuple[np.ndarray, np.ndarray]:
    """The viewport's denoised picture of one view after its first sample and after ``count``."""
    first = None
    for k in range(count):
        result = renderer.render(scene, camera, settings, sample=k, accumulate=True, reuse_world=k > 0,
                                 statistics=False, denoise=True)
        if k == 0:
            first = result.image[..., :3].copy()
    return first, result.image[..., :3].copy()


def bias_share(difference_a: np.ndarray, difference_b: np.ndarray) -> float:
    """The share of the per-pixel difference that two independent halves hold alike:
    cov(a, b) / var(a) over the pixels (about 1: bias; about 0: noise)."""
    a = difference_a - difference_a.mean()
    b = difference_b - difference_b.mean()
    variance = float(np.mean(a * a))
    return float(np.mean(a * b) / variance) if variance > 0.0 else 0.0


def ldr_luminance(image: np.ndarray) -> np.ndarray:
    """The LDR image FLIP sees (bench.to_srgb_ldr), averaged over its channels."""
    return to_srgb_ldr(image).mean(axis=-1)


def compare(hybrid: tuple[np.ndarray, dict], full: tuple[np.ndarray, dict]) -> dict:
    """The figures of the module docstring from both modes' samples and light passes."""
    h, hp, hp_a = hybrid
    f, fp, fp_a = full
    n = len(h) // 2
    ha, hb, fa, fb = h[:n].mean(0), h[n:].mean(0), f[:n].mean(0), f[n:].mean(0)
    h_all, f_all = h.mean(0), f.mean(0)
    diffuse = (hp["Diffuse Indirect"] - fp["Diffuse Indirect"]) * hp["Diffuse Color"]
    # The primary pixels' diffuse light of halves A and B (B's mean: twice the whole's less A's).
    diffuse_a = (hp_a["Diffuse Indirect"] - fp_a["Diffuse Indirect"]) * hp["Diffuse Color"]
    diffuse_b = 2.0 * diffuse - diffuse_a
    report = {
        "samples": len(h),
        "same_1": flip_mean(f[0], h[0]),
        "same_all": flip_mean(f_all, h_all),
        "noise_h_1": flip_mean(h[1], h[0]),
        "noise_h": flip_mean(hb, ha),
        "noise_f": flip_mean(fb, fa),
        "crossed": 0.5 * (flip_mean(fb, ha) + flip_mean(hb, fa)),
        "bias_share": bias_share(ldr_luminance(ha) - ldr_luminance(fa), ldr_luminance(hb) - ldr_luminance(fb)),
        "bias_share_diffuse": bias_share(diffuse_a.mean(axis=-1), diffuse_b.mean(axis=-1)),
        "flip_glossy_only": flip_mean(f_all, h_all - diffuse),
        "flip_diffuse_only": flip_mean(f_all, f_all + diffuse),
        "diffuse_indirect_mean": [float(hp["Diffuse Indirect"].mean()), float(fp["Diffuse Indirect"].mean())],
    }
    return {k: (round(v, 5) if isinstance(v, float) else v) for k, v in report.items()}


def run(detail: float, size: tuple[int, int], cube: int, half: int, variants: list[str]) -> dict:
    """Every variant's figures (``compare``), each mode with a Renderer of its own."""
    from hybrid_engine.frame.renderer import Renderer
    from hybrid_engine.gpu import gl_context
    from hybrid_engine.scene.settings import RenderSettings

    scene, camera = build_chess(detail, FRAME, *size)
    ctx = gl_context.get_context()
    renderers = {mode: Renderer(ctx) for mode in ("HYBRID", "FULL_BVH")}
    report: dict = {"detail": detail, "size": f"{size[0]}x{size[1]}", "cube": cube, "variants": {}}
    try:
        for name in variants:
            changes = {k: (2 * cube if v == "x2" else v) for k, v in VARIANTS[name].items()}
            CubeMapPass.footprints = changes.pop(FOOTPRINTS, True)
            tracer.MIRROR_FOOTPRINTS = changes.pop(MIRROR_FOOTPRINTS, True)
            start = time.perf_counter()
            modes = {mode: render_samples(r, scene, camera,
                                          RenderSettings(**{**base_settings(cube), **changes, "mode": mode}), 2 * half)
                     for mode, r in renderers.items()}
            denoised = {mode: denoised_pictures(r, scene, camera,
                                                RenderSettings(**{**base_settings(cube), **changes, "mode": mode}),
                                                2 * half)
                        for mode, r in renderers.items()}
            report["variants"][name] = {**compare(modes["HYBRID"], modes["FULL_BVH"]),
                                        "denoised_1": round(flip_mean(denoised["FULL_BVH"][0], denoised["HYBRID"][0]), 5),
                                        "denoised_all": round(flip_mean(denoised["FULL_BVH"][1], denoised["HYBRID"][1]), 5),
                                        "seconds": round(time.perf_counter() - start, 1)}
            print(name, json.dumps(report["variants"][name]), file=sys.stderr, flush=True)
    finally:
        CubeMapPass.footprints = True
        tracer.MIRROR_FOOTPRINTS = True
        for r in renderers.values():
            r.release()
    return report


def escapes_and_stops(hybrid: np.ndarray, full: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per ray (first gather rays' sky visibility, 1 or 0 each, same shape in both modes):
    where HYBRID's escapes and FULL_BVH's meets a surface, and the other way round."""
    return (hybrid > 0.5) & (full < 0.5), (hybrid < 0.5) & (full > 0.5)


def gather_escapes(detail: float, size: tuple[int, int], cube: int, samples: int) -> dict:
    """The first gather rays' disagreements (module docstring), with the footprints and
    without: counts per surface the rays leave, in all, and each mode's mean sky share."""
    from hybrid_engine.frame.film import FrameOutputs
    from hybrid_engine.frame.renderer import Renderer
    from hybrid_engine.gpu import gl_context
    from hybrid_engine.passes.film.light_passes import LightPassRequest
    from hybrid_engine.scene.settings import RenderSettings

    scene, camera = build_chess(detail, FRAME, *size)
    outputs = FrameOutputs(light=LightPassRequest(flags=("use_pass_ambient_occlusion", "use_pass_diffuse_color")))
    renderer = Renderer(gl_context.get_context())
    report: dict = {"detail": detail, "size": f"{size[0]}x{size[1]}", "cube": cube, "samples": samples}
    try:
        sky, colour = {}, None
        for footprints in (False, True):
            CubeMapPass.footprints = footprints
            for mode in ("HYBRID", "FULL_BVH"):
                if mode == "FULL_BVH" and mode in sky:
                    continue
                settings = RenderSettings(**{**base_settings(cube), "mode": mode, "diffuse_bounces": 0, "max_depth": 0})
                rays = []
                for k in range(samples):
                    result = renderer.render(scene, camera, settings, sample=k, reuse_world=k > 0, outputs=outputs)
                    rays.append(result.data_passes["Ambient Occlusion"][..., 0])
                    colour = result.data_passes["Diffuse Color"][..., :3]
                sky[mode if mode == "FULL_BVH" else footprints] = np.array(rays, np.float64)
        full = sky["FULL_BVH"]
        report["rays"] = int(full.size)
        report["sky_full_bvh"] = round(float(full.mean()), 4)
        for footprints in (False, True):
            escape, stop = escapes_and_stops(sky[footprints], full)
            by_surface = {name: [int(escape[:, mask].sum()), int(stop[:, mask].sum())]
                          for name, rgb in SURFACES.items()
                          for mask in [np.abs(colour - np.array(rgb)).max(axis=-1) < 0.006]}
            report["footprints" if footprints else "without"] = {
                "escapes": int(escape.sum()), "stops": int(stop.sum()), "sky_hybrid": round(float(sky[footprints].mean()), 4),
                "by_surface": by_surface}
    finally:
        CubeMapPass.footprints = True
        renderer.release()
    return report


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.chess_flip_split", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--detail", type=float, default=0.25)
    parser.add_argument("--size", type=parse_resolution, default=(320, 180))
    parser.add_argument("--cube", type=int, default=256, help="cube face texels (the bench: 0.8 of the width)")
    parser.add_argument("--half", type=int, default=8, help="samples per half (2x this per mode)")
    parser.add_argument("--variants", default="default,screen",
                        help=f"comma-separated, of {', '.join(VARIANTS)}")
    parser.add_argument("--escapes", type=int, metavar="SAMPLES",
                        help="count the first gather rays' disagreements over SAMPLES samples instead")
    parser.add_argument("--json", metavar="PATH")
    args = parser.parse_args(argv)
    if args.escapes:
        report = gather_escapes(args.detail, args.size, args.cube, args.escapes)
    else:
        variants = [v for v in args.variants.split(",") if v]
        unknown = [v for v in variants if v not in VARIANTS]
        if unknown:
            parser.error(f"unknown variants: {', '.join(unknown)}")
        report = run(args.detail, args.size, args.cube, max(1, args.half), variants)
    text = json.dumps(report, indent=2)
    print(text)
    if args.json:
        with open(args.json, "w", encoding="utf-8") as handle:
            handle.write(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
