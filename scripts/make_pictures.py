# SPDX-License-Identifier: GPL-3.0-or-later
"""Render the comparison pictures of docs/PICTURES.md: the paper's Figure 4 for every scene.

Usage: python scripts/make_pictures.py [--scenes chess,chess_real,sponza,large] [--assets DIR]
                                       [--out docs/pictures] [--width 640 --height 360]
                                       [--frame F] [--detail D | --detail scene=D,...]
                                       [--cycles-samples N] [--eevee-samples N] [--tiles]
                                       [--skip-missing]

For each scene of the scene library (benchmarks/scene_library.py) the same frame is
rendered through Blender's render path (``bpy.ops.render.render``) six ways: Hybrid RT in
HYBRID, FULL_BVH and PROVENANCE mode, then Cycles and EEVEE, and the FLIP error map of HYBRID
against FULL_BVH is computed (the paper's Figure 4 shows exactly these: the hybrid image, the
full-BVH ground truth, where each reflection started, and the FLIP difference). One sheet per
scene, ``<out>/<scene>.png``, holds the six tiles in two rows (HYBRID, FULL_BVH, PROVENANCE /
FLIP, EEVEE, Cycles) at full size, and the numbers (triangles, per-pass frame times, FLIP
mean, Cycles and EEVEE seconds, settings) go to ``<scene>.json``. ``--tiles`` also writes
each tile alone (``<scene>_hybrid.png`` ...); off by default, because the sheets already hold
them pixel for pixel and they are kept in git. Labels and titles are drawn by Blender's font
engine and the PNGs written by Blender's OpenImageIO at the highest compression
(``blender_adapter/chart_images.py``).

Every tile is the renderer's linear Render Result (read back from a 32-bit EXR) clamped to
[0, 1] and sRGB-encoded, the encoding FLIP is given (benchmarks/bench.py ``to_srgb_ldr``):
Blender's default view transform (AgX) is not applied, so the six tiles and the FLIP map
compare like for like. Scenes other than ``chess`` load files from the assets folder
(``--assets``, else ``$HYBRID_RT_SCENES``, else ``../shared/scenes`` beside this checkout);
every requested scene's files are checked before anything is rendered, and a missing file
stops the run with the library's message naming it (``--skip-missing`` leaves such scenes out
instead).
"""
from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator

import numpy as np

from addon_loader import load_addon

REPO_ROOT = Path(__file__).resolve().parent.parent
DEFAULT_OUT = REPO_ROOT / "docs" / "pictures"
DEFAULT_ASSETS = REPO_ROOT.parent / "shared" / "scenes"
ASSETS_ENV = "HYBRID_RT_SCENES"  # as benchmarks.scene_library.ASSETS_ENV (not importable before bpy)
SCENE_NAMES = ("chess", "chess_real", "sponza", "large", "room", "closed_room", "closed_room_lamp", "window_room",
               "wall_floor", "cornell")
DEFAULT_RESOLUTION = (640, 360)  # the software renderer's size in the demo and benchmarks
DEFAULT_FRAME = 0  # every scene's first frame: the demo's chess view, the atrium seen from its +x end
FRAME_COUNT = 200  # the library's animations (the paper's 200-frame sequences)
# Per-scene detail (1 = the paper's triangle count) chosen so that all four scenes finish
# in about a quarter of an hour on two CPU cores with llvmpipe; docs/PICTURES.md lists the
# triangle counts they give. ``large`` keeps 10 of its 40 Sponzas (2.9 M triangles): on
# llvmpipe, FULL_BVH (the FLIP reference) over 8 M triangles or more needs more storage
# blocks than the driver has, and EEVEE's time grows with every copy.
DEFAULT_DETAIL = {"chess": 1.0, "chess_real": 1.0, "sponza": 1.0, "large": 0.25, "room": 1.0,
                  # the interiors (benchmarks/interior_scenes.py) have one size
                  "closed_room": 1.0, "closed_room_lamp": 1.0, "window_room": 1.0, "wall_floor": 1.0, "cornell": 1.0}
MODES = ("HYBRID", "FULL_BVH", "PROVENANCE")
# Cycles, denoised, is the reference for the look: HYBRID and EEVEE are both measured against it.
CYCLES_SAMPLES = 256
EEVEE_SAMPLES = 32
CYCLES_DENOISER = "OPENIMAGEDENOISE"
EEVEE_ENGINE = "BLENDER_EEVEE"  # EEVEE's engine id in Blender 5
# Sheet layout: two rows of three equal tiles under a title bar.
TILE_ORDER = (("hybrid", "full_bvh", "provenance"), ("flip", "eevee", "cycles"))
GAP_PX = 4
SHEET_BACKGROUND = (255, 255, 255)
LABEL_BACKGROUND = (0, 0, 0)
LABEL_TEXT = (255, 255, 255)
PLACEHOLDER_BACKGROUND = (60, 60, 60)
LABEL_SIZE = 14  # font size of labels and title in pixels
SMALL_LABEL_SIZE = 10  # on tiles narrower than LABEL_SIZE_MIN_TILE_WIDTH
LABEL_SIZE_MIN_TILE_WIDTH = 320
SHEET_COMPRESSION = 9  # zlib level: the sheets are kept in git
EXIT_MISSING_ASSETS = 2


class PictureError(RuntimeError):
    """A render did not produce an image (the message says which and why)."""


@dataclass
class SceneRequest:
    """What to render for one scene."""

    name: str
    detail: float
    frame: int
    width: int
    height: int
    cycles_samples: int
    eevee_samples: int


@dataclass
class SceneResult:
    """The tiles (uint8 sRGB, row 0 at the top) and numbers of one scene."""

    tiles: dict[str, np.ndarray] = field(default_factory=dict)
    labels: dict[str, str] = field(default_factory=dict)
    numbers: dict = field(default_factory=dict)


# ---------------------------------------------------------------------------------------------
# Arguments and assets
# ---------------------------------------------------------------------------------------------
def parse_details(text: str | None, scenes: list[str]) -> dict[str, float]:
    """``--detail``: one number for every scene, or ``scene=value`` pairs over the defaults."""
    details = {name: DEFAULT_DETAIL[name] for name in scenes}
    if not text:
        return details
    try:
        value = float(text)
    except ValueError:
        value = None
    if value is not None:
        return {name: value for name in scenes}
    for item in text.split(","):
        name, sep, number = item.partition("=")
        name = name.strip()
        if not sep or name not in SCENE_NAMES:
            raise ValueError(f"--detail takes a number or scene=value pairs ({', '.join(SCENE_NAMES)}), "
                             f"got {item!r}")
        details[name] = float(number)
    return {name: details[name] for name in scenes}


def parse_scenes(text: str) -> list[str]:
    scenes = [name.strip() for name in text.split(",") if name.strip()]
    unknown = [name for name in scenes if name not in SCENE_NAMES]
    if unknown or not scenes:
        raise ValueError(f"--scenes takes names from {', '.join(SCENE_NAMES)}, got {text!r}")
    return list(dict.fromkeys(scenes))


def assets_folder(argument: str | None) -> Path:
    """``--assets``, else ``$HYBRID_RT_SCENES``, else the shared folder beside the checkout."""
    chosen = argument or os.environ.get(ASSETS_ENV) or DEFAULT_ASSETS
    return Path(chosen).expanduser().resolve()


def check_scene_assets(scenes: list[str], assets: Path, skip_missing: bool) -> tuple[list[str], list[str]]:
    """(scenes to render, messages of scenes left out); raises SceneAssetError for the first
    scene whose files are missing unless ``skip_missing``. Runs before anything renders, so
    a missing file costs seconds, not the scenes rendered before it."""
    from benchmarks import scene_library

    kept, skipped = [], []
    for name in scenes:
        try:
            scene_library.check_assets(name, assets)
        except scene_library.SceneAssetError as error:
            if not skip_missing:
                raise
            skipped.append(str(error))
            continue
        kept.append(name)
    return kept, skipped


# ---------------------------------------------------------------------------------------------
# Images
# ---------------------------------------------------------------------------------------------
def display_bytes(linear: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8 sRGB, row 0 at the top, from a linear (H, W, 3|4) image with row 0 at
    the bottom (Blender's order): the encoding FLIP compares (bench.to_srgb_ldr)."""
    from benchmarks.bench import to_srgb_ldr

    return np.ascontiguousarray((to_srgb_ldr(linear)[::-1] * 255.0 + 0.5).astype(np.uint8))


def flip_map(reference_linear: np.ndarray, test_linear: np.ndarray) -> tuple[np.ndarray, float]:
    """(magma-coloured FLIP map as (H, W, 3) uint8 with row 0 at the top, mean FLIP).

    The inputs and the call are bench.flip_mean's (LDR: clamped, sRGB-encoded, top row first,
    reference = FULL_BVH), with flip_evaluator's own magma colour map switched on, so the mean
    equals the benchmark's figure for the same pair of images.
    """
    from benchmarks.bench import flip_error

    error_map, mean = flip_error(reference_linear, test_linear, magma=True)
    colours = np.clip(np.asarray(error_map, np.float64)[..., :3], 0.0, 1.0)
    return (colours * 255.0 + 0.5).astype(np.uint8), mean


def label_size(width: int) -> int:
    """The font size in pixels of a tile's labels and the sheet's title: smaller on narrow tiles."""
    return LABEL_SIZE if width >= LABEL_SIZE_MIN_TILE_WIDTH else SMALL_LABEL_SIZE


def label_band(size: int) -> tuple[int, int]:
    """(height of a label's band, its padding) for text of ``size`` pixels: one line of text
    (descenders included) between two paddings."""
    from hybrid_rt.hybrid_engine.reports.chart_raster import LINE_EM

    pad = max(size // 4, 2)
    return math.ceil(LINE_EM * size) + 2 * pad, pad


def labelled(tile: np.ndarray, text: str) -> np.ndarray:
    """A copy of ``tile`` with ``text`` in white on a black band along its top edge, drawn
    by Blender's font engine and clipped to the tile."""
    from hybrid_rt.blender_adapter import chart_images
    from hybrid_rt.hybrid_engine.reports.chart_raster import Label

    out = tile.copy()
    size = label_size(tile.shape[1])
    band, pad = label_band(size)
    out[:band, :math.ceil(chart_images.text_width(text, size)) + 2 * pad] = LABEL_BACKGROUND
    return chart_images.draw_labels(out, [Label(text, pad, band / 2, size, LABEL_TEXT)])


def placeholder(width: int, height: int, text: str) -> np.ndarray:
    """A grey tile saying why there is no image (never a stand-in picture)."""
    from hybrid_rt.blender_adapter import chart_images
    from hybrid_rt.hybrid_engine.reports.chart_raster import LINE_EM, Label

    tile = np.empty((height, width, 3), np.uint8)
    tile[:] = PLACEHOLDER_BACKGROUND
    size = label_size(width)
    lines, line = [], ""
    for word in text.split():  # wrap to the tile's width
        joined = f"{line} {word}".strip()
        if line and chart_images.text_width(joined, size) > width - 8:
            lines.append(line)
            line = word
        else:
            line = joined
    lines.append(line)
    row_height = LINE_EM * size
    top = height / 2 - (len(lines) - 1) * row_height / 2
    return chart_images.draw_labels(tile, [Label(text_line, width / 2, top + k * row_height, size, LABEL_TEXT,
                                                 "center") for k, text_line in enumerate(lines)])


def compose_sheet(tiles: dict[str, np.ndarray], labels: dict[str, str], title: str) -> np.ndarray:
    """The six labelled tiles in TILE_ORDER's two rows under a title bar, GAP_PX apart."""
    from hybrid_rt.blender_adapter import chart_images
    from hybrid_rt.hybrid_engine.reports.chart_raster import TEXT, Label

    height, width = tiles[TILE_ORDER[0][0]].shape[:2]
    size = label_size(width)
    title_height, _pad = label_band(size)  # as tall as a tile's label band
    columns = len(TILE_ORDER[0])
    sheet = np.empty((title_height + len(TILE_ORDER) * (height + GAP_PX), columns * width + (columns + 1) * GAP_PX, 3),
                     np.uint8)
    sheet[:] = SHEET_BACKGROUND
    for r, row in enumerate(TILE_ORDER):
        for c, key in enumerate(row):
            tile = tiles[key]
            if tile.shape[:2] != (height, width):
                raise ValueError(f"tile {key} is {tile.shape[1]}x{tile.shape[0]}, expected {width}x{height}")
            y = title_height + r * (height + GAP_PX)
            x = GAP_PX + c * (width + GAP_PX)
            sheet[y:y + height, x:x + width] = labelled(tile, labels[key])
    return chart_images.draw_labels(sheet, [Label(title, GAP_PX, title_height / 2, size, TEXT)])


def write_png(path: Path, pixels: np.ndarray) -> int:
    """Write ``pixels`` (row 0 at the top) as PNG at the highest compression (the sheets are
    kept in git); returns the file's size in bytes."""
    from hybrid_rt.blender_adapter import chart_images

    chart_images.write_png(path, pixels, compression=SHEET_COMPRESSION)
    return path.stat().st_size


# ---------------------------------------------------------------------------------------------
# Rendering through Blender
# ---------------------------------------------------------------------------------------------
@contextlib.contextmanager
def temporarily(*changes: tuple[object, str, object]) -> Iterator[None]:
    """Set ``(owner, attribute, value)`` triples, restoring the previous values afterwards,
    so the scene keeps its engine, mode and output settings whatever the render did.
    Values are restored in the order they were set: the file format before the colour depth,
    which the EXR format's choices would otherwise refuse."""
    previous = [(owner, name, getattr(owner, name)) for owner, name, _ in changes]
    try:
        for owner, name, value in changes:
            setattr(owner, name, value)
        yield
    finally:
        for owner, name, value in previous:
            setattr(owner, name, value)


def render_linear(scene, exr_path: Path) -> tuple[np.ndarray, float]:
    """Render the scene's current frame with its current engine; returns the linear Render
    Result as (H, W, 4) float32, row 0 at the bottom, and the render call's wall seconds.

    The result goes through a 32-bit EXR: EXR keeps Blender's scene-linear values (no view
    transform), the same for every engine, and ``bpy.data.images`` reads it back exactly.
    """
    import bpy

    settings = scene.render.image_settings
    exr_path.unlink(missing_ok=True)
    with temporarily((scene.render, "filepath", str(exr_path)), (settings, "file_format", "OPEN_EXR"),
                     (settings, "color_depth", "32")):
        start = time.perf_counter()
        bpy.ops.render.render(write_still=True, scene=scene.name)
        seconds = time.perf_counter() - start
    if not exr_path.is_file():
        raise PictureError(f"{scene.render.engine} wrote no image ({exr_path.name} is missing)")
    image = bpy.data.images.load(str(exr_path))
    try:
        width, height = image.size
        pixels = np.empty(width * height * 4, np.float32)
        image.pixels.foreach_get(pixels)
    finally:
        bpy.data.images.remove(image)
    return pixels.reshape(height, width, 4), seconds


def render_hybrid(scene, mode: str, folder: Path):
    """One Hybrid RT render in ``mode``: (linear image, the engine's FrameResult, seconds)."""
    from hybrid_rt.blender_adapter import engine

    before = engine.last_frame
    # Per-pass times are recorded: F12 times its passes only when asked.
    with temporarily((scene.render, "engine", "HYBRID_RT"), (scene.hybrid_rt, "mode", mode),
                     (engine, "time_final_renders", True)):
        image, seconds = render_linear(scene, folder / f"{mode.lower()}.exr")
    frame = engine.last_frame
    if frame is None or frame is before:
        raise PictureError(f"Hybrid RT rendered no {mode} frame; see the messages above")
    if frame.mode != mode:
        raise PictureError(f"Hybrid RT rendered {frame.mode} instead of {mode}")
    return image, frame, seconds


def render_cycles(scene, samples: int, folder: Path) -> tuple[np.ndarray, float, dict]:
    """Cycles on the CPU with ``samples`` samples, denoised with OpenImageDenoise when this
    build has it (a modest count then looks converged enough to compare)."""
    import _cycles

    denoise = bool(getattr(_cycles, "with_openimagedenoise", False))
    cycles = scene.cycles
    changes = [(scene.render, "engine", "CYCLES"), (cycles, "device", "CPU"), (cycles, "samples", samples),
               (cycles, "use_denoising", denoise)]
    if denoise:
        changes.append((cycles, "denoiser", CYCLES_DENOISER))
    with temporarily(*changes):
        image, seconds = render_linear(scene, folder / "cycles.exr")
        settings = {"device": "CPU", "samples": samples, "denoiser": CYCLES_DENOISER if denoise else None,
                    "max_bounces": cycles.max_bounces, "adaptive_sampling": cycles.use_adaptive_sampling}
    return image, seconds, settings


def render_eevee(scene, samples: int, folder: Path) -> tuple[np.ndarray | None, float, dict]:
    """EEVEE with ``samples`` anti-aliasing samples and screen-space ray tracing (its
    reflections). EEVEE needs Blender's own GPU backend, which a background ``bpy`` may not
    get: a failure is returned as ``(None, seconds, {"reason": ...})``, never as an image."""
    eevee = scene.eevee
    start = time.perf_counter()
    try:
        with temporarily((scene.render, "engine", EEVEE_ENGINE), (eevee, "taa_render_samples", samples),
                         (eevee, "use_raytracing", True)):
            image, seconds = render_linear(scene, folder / "eevee.exr")
    except (RuntimeError, PictureError) as error:  # bpy reports a failed render as RuntimeError
        reason = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
        return None, time.perf_counter() - start, {"available": False, "reason": reason, "samples": samples}
    if not np.isfinite(image).all() or not image[..., :3].any():
        return None, seconds, {"available": False, "samples": samples,
                               "reason": "EEVEE returned an empty (all-black) image"}
    return image, seconds, {"available": True, "samples": samples, "raytracing": "screen space"}


def render_scene(request: SceneRequest, assets: Path) -> SceneResult:
    """Build one scene and render its frame six ways (see the module docstring)."""
    import bpy
    from benchmarks import scene_library

    result = SceneResult()
    numbers = result.numbers
    start = time.perf_counter()
    scene = scene_library.build_scene(request.name, assets, detail=request.detail, frame_count=FRAME_COUNT,
                                      resolution=(request.width, request.height))
    numbers["build_s"] = round(time.perf_counter() - start, 2)
    scene.frame_set(request.frame)
    width, height = request.width, request.height
    with tempfile.TemporaryDirectory(prefix="hybrid_rt_pictures_") as temporary:
        folder = Path(temporary)
        linear, frames = {}, {}
        for mode in MODES:
            # The first frame of a mode uploads the scene, renders the shadow maps and has
            # llvmpipe compile the mode's kernels (seconds); the second is the one shown and timed.
            _, cold, _ = render_hybrid(scene, mode, folder)
            linear[mode], frames[mode], seconds = render_hybrid(scene, mode, folder)
            numbers.setdefault("hybrid_rt", {})[mode] = {
                "total_ms": round(frames[mode].total_ms, 1), "first_frame_ms": round(cold.total_ms, 1),
                "render_call_s": round(seconds, 2),
                "passes_ms": {k: round(v, 2) for k, v in frames[mode].passes.items()},
                "counts": dict(frames[mode].counts), "timing_source": frames[mode].timing_source}
            result.tiles[mode.lower()] = display_bytes(linear[mode])
            result.labels[mode.lower()] = f"{mode} {frames[mode].total_ms:,.0f} ms"
            print(f"pictures: {request.name} {mode:<10} {frames[mode].total_ms:9.1f} ms "
                  f"(render call {seconds:.1f} s)", flush=True)
        flip_tile, flip_mean = flip_map(linear["FULL_BVH"], linear["HYBRID"])
        result.tiles["flip"] = flip_tile
        result.labels["flip"] = f"FLIP HYBRID vs FULL_BVH, mean {flip_mean:.4f}"
        numbers["flip_mean"] = round(flip_mean, 5)
        print(f"pictures: {request.name} FLIP mean {flip_mean:.4f} (HYBRID against FULL_BVH)", flush=True)

        cycles_image, cycles_s, cycles_settings = render_cycles(scene, request.cycles_samples, folder)
        result.tiles["cycles"] = display_bytes(cycles_image)
        denoised = ", denoised" if cycles_settings["denoiser"] else ""
        result.labels["cycles"] = f"Cycles {request.cycles_samples} spp{denoised}, {cycles_s:.0f} s"
        numbers["cycles"] = {"seconds": round(cycles_s, 1), **cycles_settings}
        print(f"pictures: {request.name} Cycles {cycles_s:.1f} s", flush=True)

        eevee_image, eevee_s, eevee_info = render_eevee(scene, request.eevee_samples, folder)
        if eevee_image is None:
            result.tiles["eevee"] = placeholder(width, height, f"EEVEE unavailable: {eevee_info['reason']}")
            result.labels["eevee"] = "EEVEE"
            print(f"pictures: {request.name} EEVEE unavailable: {eevee_info['reason']}", flush=True)
        else:
            result.tiles["eevee"] = display_bytes(eevee_image)
            result.labels["eevee"] = f"EEVEE {request.eevee_samples} samples, {eevee_s:.0f} s"
            print(f"pictures: {request.name} EEVEE {eevee_s:.1f} s", flush=True)
        numbers["eevee"] = {"seconds": round(eevee_s, 1), **eevee_info}

        # The look: HYBRID and its peer EEVEE against Cycles, FLIP on the same LDR encoding.
        _, hybrid_vs_cycles = flip_map(cycles_image, linear["HYBRID"])
        numbers["flip_vs_cycles"] = {"HYBRID": round(hybrid_vs_cycles, 5)}
        result.labels["hybrid"] += f", FLIP vs Cycles {hybrid_vs_cycles:.4f}"
        if eevee_image is not None:
            _, eevee_vs_cycles = flip_map(cycles_image, eevee_image)
            numbers["flip_vs_cycles"]["EEVEE"] = round(eevee_vs_cycles, 5)
            result.labels["eevee"] += f", FLIP vs Cycles {eevee_vs_cycles:.4f}"
        print(f"pictures: {request.name} FLIP against Cycles: {numbers['flip_vs_cycles']}", flush=True)

    hybrid = frames["HYBRID"]
    numbers.update(
        scene=request.name, label=str(scene.get("hybrid_rt_label", request.name)),
        credits=scene_library.CREDITS[request.name], frame=request.frame, resolution=[width, height],
        detail=request.detail, triangles_total=int(hybrid.counts.get("triangles_total", 0)),
        triangles_bvh=int(hybrid.counts.get("triangles_bvh", 0)),
        near_size=round(float(scene.hybrid_rt.near_size), 3), cube_far=round(float(scene.hybrid_rt.cube_far), 3),
        max_depth=int(scene.hybrid_rt.max_depth), flip_reference="FULL_BVH", flip_test="HYBRID",
        flip_range="LDR: clamped to [0, 1], sRGB-encoded (benchmarks/bench.py to_srgb_ldr)",
        blender=bpy.app.version_string)
    return result


def source_revision() -> str:
    """The checkout's commit, with ``+modified`` when tracked files differ from it, so a
    picture can be traced to the code that drew it ("unknown" outside a git checkout)."""
    def git(*args: str) -> str:
        return subprocess.run(["git", "-C", str(REPO_ROOT), *args], capture_output=True, text=True,
                              check=True, timeout=30).stdout.strip()

    try:
        commit = git("rev-parse", "--short", "HEAD")
        modified = git("status", "--porcelain", "--untracked-files=no")
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return f"{commit}+modified" if modified else commit


def scene_title(numbers: dict) -> str:
    return (f"{numbers['scene']}, frame {numbers['frame']}, {numbers['resolution'][0]}x{numbers['resolution'][1]}, "
            f"detail {numbers['detail']:g}: {numbers['triangles_total']:,} triangles, "
            f"{numbers['triangles_bvh']:,} in the near-cube BVH")


def write_outputs(name: str, result: SceneResult, out: Path, tiles: bool) -> dict[str, int]:
    """The sheet, the JSON and (``tiles``) the single tiles of one scene; returns PNG sizes
    in bytes."""
    sizes = {}
    sheet = compose_sheet(result.tiles, result.labels, scene_title(result.numbers))
    sizes[f"{name}.png"] = write_png(out / f"{name}.png", sheet)
    for key, tile in result.tiles.items() if tiles else ():
        sizes[f"{name}_{key}.png"] = write_png(out / f"{name}_{key}.png", tile)
    (out / f"{name}.json").write_text(json.dumps(result.numbers, indent=2) + "\n")
    return sizes


def summary_table(results: dict[str, dict]) -> str:
    """The markdown table of docs/PICTURES.md, from the numbers of this run."""
    lines = ["| scene | detail | triangles | in BVH | HYBRID ms | FULL_BVH ms | PROVENANCE ms | FLIP mean "
             "| Cycles s | EEVEE s | scene s |",
             "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for name, n in results.items():
        modes = n["hybrid_rt"]
        eevee = f"{n['eevee']['seconds']:.0f}" if n["eevee"]["available"] else "unavailable"
        lines.append(
            f"| {name} | {n['detail']:g} | {n['triangles_total']:,} | {n['triangles_bvh']:,} | "
            f"{modes['HYBRID']['total_ms']:,.0f} | {modes['FULL_BVH']['total_ms']:,.0f} | "
            f"{modes['PROVENANCE']['total_ms']:,.0f} | {n['flip_mean']:.4f} | {n['cycles']['seconds']:.0f} | "
            f"{eevee} | {n['scene_s']:.0f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", default=",".join(SCENE_NAMES), help="comma-separated scene names")
    parser.add_argument("--assets", default=None,
                        help=f"folder of the third-party scenes (default ${ASSETS_ENV}, else {DEFAULT_ASSETS})")
    parser.add_argument("--out", default=str(DEFAULT_OUT), help="folder for the sheets, tiles and JSON")
    parser.add_argument("--width", type=int, default=DEFAULT_RESOLUTION[0])
    parser.add_argument("--height", type=int, default=DEFAULT_RESOLUTION[1])
    parser.add_argument("--frame", type=int, default=DEFAULT_FRAME, help=f"frame in 0..{FRAME_COUNT - 1}")
    parser.add_argument("--detail", default=None,
                        help="a number for every scene, or scene=value pairs (defaults: "
                        + ", ".join(f"{k}={v:g}" for k, v in DEFAULT_DETAIL.items()) + ")")
    parser.add_argument("--cycles-samples", type=int, default=CYCLES_SAMPLES)
    parser.add_argument("--eevee-samples", type=int, default=EEVEE_SAMPLES)
    parser.add_argument("--tiles", action="store_true",
                        help="also write every tile alone as <scene>_<tile>.png")
    parser.add_argument("--skip-missing", action="store_true",
                        help="leave out scenes whose files are missing instead of stopping")
    args = parser.parse_args(argv)
    try:
        scenes = parse_scenes(args.scenes)
        details = parse_details(args.detail, scenes)
    except ValueError as error:
        parser.error(str(error))
    if args.width < 16 or args.height < 16:
        parser.error("--width and --height must be at least 16")
    if not 0 <= args.frame < FRAME_COUNT:
        parser.error(f"--frame must lie in 0..{FRAME_COUNT - 1}")
    if args.cycles_samples < 1 or args.eevee_samples < 1:
        parser.error("--cycles-samples and --eevee-samples must be at least 1")
    bad = {k: v for k, v in details.items() if not (math.isfinite(v) and 0.0 < v <= 1.0)}
    if bad:
        parser.error(f"detail must lie in (0, 1], got {bad}")
    assets = assets_folder(args.assets)
    out = Path(args.out).expanduser().resolve()

    import bpy

    addon = load_addon()
    addon.register()
    try:
        from benchmarks import scene_library
        from benchmarks import bench

        try:
            scenes, skipped = check_scene_assets(scenes, assets, args.skip_missing)
        except scene_library.SceneAssetError as error:
            print(f"pictures: {error}", file=sys.stderr)
            print("pictures: nothing rendered (pass --assets DIR, set $HYBRID_RT_SCENES, or --skip-missing)",
                  file=sys.stderr)
            return EXIT_MISSING_ASSETS
        for message in skipped:
            print(f"pictures: skipped: {message}", file=sys.stderr)
        out.mkdir(parents=True, exist_ok=True)
        machine = {**bench.machine_info(), "source": source_revision()}
        print(f"pictures: {machine['gl_renderer']}, {machine['cpu_count']} CPU cores; writing to {out}", flush=True)
        results = {}
        command_start = time.perf_counter()
        for name in scenes:
            scene_start = time.perf_counter()
            request = SceneRequest(name, details[name], args.frame, args.width, args.height, args.cycles_samples,
                                   args.eevee_samples)
            # A fresh session per scene: the previous scene's data and GPU buffers are freed.
            addon.unregister()
            bpy.ops.wm.read_factory_settings(use_empty=True)
            addon.register()
            result = render_scene(request, assets)
            result.numbers["scene_s"] = round(time.perf_counter() - scene_start, 1)
            result.numbers["machine"] = machine
            sizes = write_outputs(name, result, out, args.tiles)
            results[name] = result.numbers
            print(f"pictures: {name} done in {result.numbers['scene_s']:.0f} s: {out / (name + '.png')} "
                  f"({sizes[name + '.png'] / 1e6:.2f} MB)", flush=True)
        print(f"pictures: {len(results)} scene(s) in {time.perf_counter() - command_start:.0f} s")
        print(summary_table(results))
        return 0
    finally:
        addon.unregister()


if __name__ == "__main__":
    sys.exit(main())
