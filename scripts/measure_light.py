# SPDX-License-Identifier: GPL-3.0-or-later
"""Measure light indoors: Hybrid RT, EEVEE and Cycles side by side on the interior scenes.

Usage: python scripts/measure_light.py [--scenes closed_room,...] [--width 320 --height 180]
                                       [--cycles-samples 256] [--eevee-samples 32]
                                       [--variant NAME:setting=value,...] [--json FILE]

Each scene of benchmarks/interior_scenes.py (and ``room``/``sponza`` of the library, by name)
is built in a fresh session and rendered through Blender's render path by Cycles (denoised:
the reference), EEVEE (the peer) and Hybrid RT, once per ``--variant`` (a name and Hybrid RT
settings to change; by default one variant, ``hybrid``, with the scene's own settings). For
each image the script prints and writes:

* the mean Rec. 709 luminance of the linear image, and its ratio to Cycles';
* FLIP against Cycles (LDR: clamped, sRGB-encoded, as docs/PICTURES.md);
* for ``wall_floor``, the mean luminance of the cube's top face and of its vertical faces,
  the pixels chosen by casting each pixel's ray into the scene (``Scene.ray_cast``), so the
  regions are the geometry's, not the renderer's.

The renders go through make_pictures.py's functions (EXR at 32 bits, no view transform).
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from addon_loader import REPO_ROOT, load_addon
from make_pictures import (DEFAULT_ASSETS, flip_map, render_cycles, render_eevee, render_hybrid,
                           temporarily)

DEFAULT_SCENES = ("closed_room", "closed_room_lamp", "window_room", "wall_floor", "cornell")
DEFAULT_SIZE = (320, 180)
CYCLES_SAMPLES = 256
EEVEE_SAMPLES = 32


def parse_variant(text: str) -> tuple[str, dict[str, object]]:
    """``NAME:key=value,key=value`` -> (name, settings); values are parsed as Python literals
    where they can be (numbers, True/False), else kept as strings (enum names)."""
    import ast

    name, _, rest = text.partition(":")
    if not name:
        raise ValueError(f"a variant needs a name: {text!r}")
    settings: dict[str, object] = {}
    for pair in filter(None, rest.split(",")):
        key, eq, value = pair.partition("=")
        if not eq:
            raise ValueError(f"expected key=value in {text!r}, got {pair!r}")
        try:
            settings[key.strip()] = ast.literal_eval(value.strip())
        except (ValueError, SyntaxError):
            settings[key.strip()] = value.strip()
    return name, settings


def luminance(image: np.ndarray) -> np.ndarray:
    return image[..., 0] * 0.2126 + image[..., 1] * 0.7152 + image[..., 2] * 0.0722


def face_regions(scene) -> dict[str, np.ndarray]:
    """Masks (H, W), row 0 at the bottom, of the pixels that see the object called "Cube" on a
    face pointing up ("top") or sideways ("side"), by one ray per pixel centre."""
    import bpy
    from mathutils import Vector

    depsgraph = bpy.context.evaluated_depsgraph_get()
    camera = scene.camera
    width, height = scene.render.resolution_x, scene.render.resolution_y
    frame = camera.data.view_frame(scene=scene)  # the four corners at distance 1, camera space
    xs = [c.x for c in frame]
    ys = [c.y for c in frame]
    z = frame[0].z
    matrix = camera.matrix_world
    origin = matrix.translation
    top = np.zeros((height, width), bool)
    side = np.zeros((height, width), bool)
    for row in range(height):
        y = min(ys) + (row + 0.5) / height * (max(ys) - min(ys))
        for col in range(width):
            x = min(xs) + (col + 0.5) / width * (max(xs) - min(xs))
            direction = (matrix.to_3x3() @ Vector((x, y, z))).normalized()
            hit, _, normal, _, obj, _ = scene.ray_cast(depsgraph, origin, direction)
            if not hit or obj is None or obj.name != "Cube":
                continue
            if normal.z > 0.9:
                top[row, col] = True
            elif abs(normal.z) < 0.1:
                side[row, col] = True
    return {"top": top, "side": side}


def measure(image: np.ndarray, regions: dict[str, np.ndarray]) -> dict[str, float]:
    lum = luminance(image)
    numbers = {"mean_luminance": float(lum.mean())}
    for name, mask in regions.items():
        if mask.any():
            numbers[f"{name}_luminance"] = float(lum[mask].mean())
    return numbers


def cached(folder: str | None, key: str, render) -> tuple[np.ndarray, float]:
    """``render()``'s (image, seconds), kept in ``folder`` (``--references``) under ``key``:
    Cycles and EEVEE do not change while Hybrid RT does, and Cycles takes minutes."""
    if folder is None:
        return render()
    path = Path(folder) / f"{key}.npz"
    if path.is_file():
        stored = np.load(path)
        return stored["image"], float(stored["seconds"])
    image, seconds = render()
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, image=image, seconds=seconds)
    return image, seconds


def cached_eevee(folder: str | None, key: str, render) -> tuple[np.ndarray | None, float, dict]:
    """EEVEE through ``cached``; a failed EEVEE render is not kept."""
    failure: dict = {}

    def attempt():
        image, seconds, info = render()
        if image is None:
            failure.update(info)
            raise LookupError
        return image, seconds

    try:
        image, seconds = cached(folder, key, attempt)
    except LookupError:
        return None, 0.0, failure
    return image, seconds, {}


def measure_scene(name: str, args, variants: list[tuple[str, dict]]) -> dict:
    import bpy
    from benchmarks import scene_library

    scene = scene_library.build_scene(name, args.assets, resolution=(args.width, args.height))
    regions = face_regions(scene) if name == "wall_floor" else {}
    results: dict[str, dict] = {}
    with tempfile.TemporaryDirectory(prefix="hybrid_rt_light_") as temporary:
        folder = Path(temporary)
        cycles, cycles_s = cached(args.references, f"{name}_{args.width}x{args.height}_cycles{args.cycles_samples}",
                                  lambda: render_cycles(scene, args.cycles_samples, folder)[:2])
        results["cycles"] = {**measure(cycles, regions), "seconds": round(cycles_s, 2),
                             "samples": args.cycles_samples}
        eevee, eevee_s, info = cached_eevee(args.references,
                                            f"{name}_{args.width}x{args.height}_eevee{args.eevee_samples}",
                                            lambda: render_eevee(scene, args.eevee_samples, folder))
        if eevee is not None:
            results["eevee"] = {**measure(eevee, regions), "seconds": round(eevee_s, 2),
                                "flip_vs_cycles": flip_map(cycles, eevee)[1]}
        else:
            results["eevee"] = {"unavailable": info.get("reason", "")}
        for variant, settings in variants:
            changes = [(scene.hybrid_rt, key, value) for key, value in settings.items()]
            with temporarily(*changes):
                image, frame, seconds = render_hybrid(scene, "HYBRID", folder)
            results[variant] = {**measure(image, regions), "seconds": round(seconds, 2),
                                "frame_ms": round(frame.total_ms, 1), "settings": settings,
                                "flip_vs_cycles": flip_map(cycles, image)[1]}
    reference = results["cycles"]
    for key, numbers in results.items():
        for field in [f for f in list(numbers) if f.endswith("_luminance")]:
            if key != "cycles" and reference.get(field, 0.0) > 1e-3:  # a black reference has no ratio
                numbers[field.replace("_luminance", "_ratio")] = numbers[field] / reference[field]
    bpy.data.scenes.remove(scene)
    return results


def table(results: dict[str, dict]) -> str:
    lines = ["| scene | renderer | mean luminance | x Cycles | FLIP to Cycles | regions |",
             "|---|---|---:|---:|---:|---|"]
    for scene, renders in results.items():
        for renderer, n in renders.items():
            if "mean_luminance" not in n:
                lines.append(f"| {scene} | {renderer} | n/a | | | {n.get('unavailable', '')} |")
                continue
            ratio = n.get("mean_ratio")
            flip = n.get("flip_vs_cycles")
            regions = ", ".join(f"{k[:-10]} {n[k]:.3f}" + (f" ({n[k[:-10] + '_ratio']:.2f}x)"
                                                           if k[:-10] + "_ratio" in n else "")
                                for k in n if k.endswith("_luminance") and k != "mean_luminance")
            lines.append(f"| {scene} | {renderer} | {n['mean_luminance']:.4f} | "
                         f"{'' if ratio is None else f'{ratio:.2f}'} | {'' if flip is None else f'{flip:.3f}'} | "
                         f"{regions} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", default=",".join(DEFAULT_SCENES))
    parser.add_argument("--assets", default=str(DEFAULT_ASSETS))
    parser.add_argument("--width", type=int, default=DEFAULT_SIZE[0])
    parser.add_argument("--height", type=int, default=DEFAULT_SIZE[1])
    parser.add_argument("--cycles-samples", type=int, default=CYCLES_SAMPLES)
    parser.add_argument("--eevee-samples", type=int, default=EEVEE_SAMPLES)
    parser.add_argument("--variant", action="append", default=[],
                        help="NAME:setting=value,... Hybrid RT settings of one more render (repeatable)")
    parser.add_argument("--json", default=None, help="write every number to this file")
    parser.add_argument("--references", default=None,
                        help="keep the Cycles and EEVEE images in this folder and reuse them")
    args = parser.parse_args(argv)
    try:
        variants = [parse_variant(text) for text in args.variant] or [("hybrid", {})]
    except ValueError as error:
        parser.error(str(error))
    import bpy

    addon = load_addon()
    results = {}
    start = time.perf_counter()
    for name in filter(None, args.scenes.split(",")):
        bpy.ops.wm.read_factory_settings(use_empty=True)
        addon.register()
        try:
            results[name] = measure_scene(name, args, variants)
        finally:
            addon.unregister()
        print(f"light: {name} done ({time.perf_counter() - start:.0f} s)", flush=True)
    print(table(results))
    if args.json:
        Path(args.json).write_text(json.dumps({"source": str(REPO_ROOT), "results": results}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
