# SPDX-License-Identifier: GPL-3.0-or-later
"""How quickly the traced diffuse light becomes clean, still and moving, in the viewport's way.

``python -m benchmarks.light_noise [--size 96x72] [--reference 256] [--reference-rays 1]
[--frames 10] [--settle 48] [--check] [--realizations 1] [--cache PATH] [--json PATH]``

``--frames 0`` measures the still view alone (a reference of many frames, ``--reference 2048``,
then costs one view's frames only). ``--scene window_room`` measures a daylit interior instead
(``window_room``: the sun and the sky through a window, no lamp, no partition).

The scene is an interior lit only by bounced light: a closed room whose lamp stands behind a
partition, so that half of what the camera sees is lit by the walls alone (the room of
tests/test_diffuse_light.py, built here from the core's types). Two measurements, each
against the converged image of its own view:

* **still**: the viewport's accumulation (``render(accumulate=True)``, one sample per redraw,
  denoised as the viewport denoises) after 1, 2, 4, 8 and 16 samples: FLIP of the mean so far;
* **moving**: the camera slides steadily sideways; the viewport starts its mean over at every
  move, so each frame shows one sample, with the denoiser's history reprojected from the last
  frame: FLIP of every frame against its own view's converged image (the bar: the frames
  after the first five);
* **stopped**: the camera then stays at the last view, whose samples accumulate on the
  history the motion left: FLIP after 1, 2, 4, 8 and 16 samples (the still view as an artist
  meets it, where **still** starts from nothing).

**The converged image** of a view is the renderer's own, through the viewport's path: the
same passes, the denoiser on (with *Bounce Feedback* on, the paths past their last bounce
take the light the last frame saw, which a renderer without the denoiser lacks). The
denoiser's wavelet filter is off for it (``DenoisePass.levels`` 0): what is averaged is the
temporal step's blend, an unbiased estimate, where the spatial filter would blur the light's
true gradients into the reference. The view is first rendered ``--settle`` frames (not
counted: any fed-back light grows over frames and the temporal blend lags it), then
``--reference`` frames are averaged in float64 on the host. ``--check`` renders the still
view's reference at twice as many frames and reports the FLIP between the two and how much
each still figure moves with it: the reference is converged when that is below 0.005.
``--reference-rays N`` makes the references with *Diffuse Rays* N: N times the paths per
frame, the same converged image (the paths are the same estimate, averaged N at a time), so
that a reference of a few hundred frames holds thousands of paths per pixel. A 2048-frame
reference of one path per frame still carries grain of about 2 % per pixel, which alone
scores FLIP 0.015-0.02 against a perfect image.
``--realizations N`` averages the still figures over N sets of the diffuse gather's numbers
(the diffuse light pass's ``gather_seed``, 0 to N - 1; ``still_denoised_each`` lists each): one
set's figure after 8 samples strays by some 0.002 from another's, as much as many a change
to the light's sampling moves it.
``--cache`` keeps the references in an npz file (keyed by size, rays and sample counts), so
that two versions of the renderer are measured against the very same images.

Beside each denoised still and stopped figure, ``*_blocks`` reports the RMS of the relative
error of 4x4-pixel blocks' mean luminance (``block_error``): the reference's grain, which is
independent from pixel to pixel, is a quarter as large in a block's mean (a 4,096-path
reference still carries about 3 % a pixel), so the block figure shows what the view itself
keeps: its filter's bias and its blotches.

FLIP is the LDR one of docs/PICTURES.md (benchmarks/bench.py ``flip_mean``). Seeds are fixed: a
sample's numbers depend on its index and the pixel's surface point only.
"""
from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace

import numpy as np

from benchmarks import bench
from benchmarks.bench import flip_mean
from hybrid_engine.scene.camera import Camera, look_at
from hybrid_engine.scene.data import Lights, MaterialTable, SceneData, Sky
from hybrid_engine.scene.geometry import Geometry
from hybrid_engine.scene.settings import RenderSettings

ROOM_HALF = 3.0
STILL_SAMPLES = (1, 2, 4, 8, 16)
BLOCK = 4  # pixels across the blocks of block_error
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
SLIDE_PER_FRAME = 0.05  # scene units the camera moves between redraws


def _box(lo, hi) -> np.ndarray:
    """12 triangles of an axis-aligned box, facing in (a room)."""
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    c = np.array([[x, y, z] for z in (z0, z1) for y in (y0, y1) for x in (x0, x1)], np.float32)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    return np.array([tri for a, b, cc, d in quads for tri in ((c[a], c[b], c[cc]), (c[a], c[cc], c[d]))],
                    np.float32)


def room() -> SceneData:
    """A closed grey room (albedo 0.8), a partition two thirds high, a point lamp behind it."""
    walls = _box((-ROOM_HALF,) * 3, (ROOM_HALF,) * 3)
    p = np.array([[0.0, 0.0, -ROOM_HALF], [0.0, ROOM_HALF, -ROOM_HALF], [0.0, ROOM_HALF, 1.0],
                  [0.0, 0.0, 1.0]], np.float32)
    partition = np.array([[p[0], p[1], p[2]], [p[0], p[2], p[3]]], np.float32)
    lamp = dict(kind="POINT", position=(1.5, 1.5, 0.0), color=(200.0, 200.0, 200.0), radius=0.1)
    return SceneData(Geometry.from_objects([(walls, None, 0), (partition, None, 0)]),
                     MaterialTable.from_rows([dict(base_color=(0.8, 0.8, 0.8), specular=0.0, roughness=1.0)]),
                     Lights.from_rows([lamp]), Sky(color=(0.0, 0.0, 0.0)))


def _quad(a, b, c, d) -> np.ndarray:
    return np.array([(a, b, c), (a, c, d)], np.float32)


def window_room() -> SceneData:
    """The same room with a window in its left wall (x = -ROOM_HALF) instead of the lamp and
    the partition: a sun through it onto the floor, and a pale sky, as a daylit interior."""
    h = ROOM_HALF
    walls = _box((-h,) * 3, (h,) * 3)
    left_wall = np.all(np.isclose(walls[:, :, 0], -h), axis=1)
    y0, y1, z0, z1 = -1.0, 1.0, -0.5, 1.5  # the opening
    x = -h
    frame = [_quad((x, -h, -h), (x, -h, h), (x, y0, h), (x, y0, -h)),
             _quad((x, y1, -h), (x, y1, h), (x, h, h), (x, h, -h)),
             _quad((x, y0, -h), (x, y0, z0), (x, y1, z0), (x, y1, -h)),
             _quad((x, y0, z1), (x, y0, h), (x, y1, h), (x, y1, z1))]
    triangles = np.concatenate([walls[~left_wall], *frame])
    sun = dict(kind="SUN", direction=(0.6, 0.2, -0.8), color=(3.0, 2.9, 2.7), radius=0.01)
    return SceneData(Geometry.from_objects([(triangles, None, 0)]),
                     MaterialTable.from_rows([dict(base_color=(0.8, 0.8, 0.8), specular=0.0, roughness=1.0)]),
                     Lights.from_rows([sun]), Sky(color=(0.6, 0.75, 1.0)))


SCENES = {"room": room, "window_room": window_room}
# Each scene's view: the eye and the direction it looks in. The room's sees the partition and
# the walls beside it; the window room's the sunlit patch of floor and the window's wall.
VIEWS = {"room": ((-2.0, -2.5, 0.5), (1.0, 3.0, -0.6)), "window_room": ((2.5, -2.5, 1.0), (-1.2, 1.0, -1.0))}


def camera_at(offset: float, width: int, height: int, scene_name: str = "room") -> Camera:
    eye, direction = (np.array(v, np.float64) for v in VIEWS[scene_name])
    eye = eye + (offset, 0.0, 0.0)
    return Camera(matrix_world=look_at(eye, eye + direction), width=width, height=height)


def _viewport_settings() -> RenderSettings:
    return RenderSettings(mode="HYBRID", near_size=2.0, shadow_resolution=512)


class Reference:
    """Converged images of views of the room (module docstring), made by one renderer whose
    denoiser keeps only its temporal step; consecutive views carry its history on."""

    def __init__(self, scene: SceneData, settings: RenderSettings, settle: int) -> None:
        from hybrid_engine.frame.renderer import Renderer

        self.scene, self.settings, self.settle = scene, settings, settle
        self.renderer = Renderer()
        self.settled = False

    def image(self, camera: Camera, samples: int, settle: int | None = None, first: int = 0) -> np.ndarray:
        """The mean of ``samples`` frames of ``camera``'s view after ``settle`` frames (all of
        ``self.settle`` the first time, a quarter after: the history carries over), their
        sample numbers from ``first`` on (another reference of one view draws other numbers)."""
        settle = (self.settle if not self.settled else max(self.settle // 4, 1)) if settle is None else settle
        if self.renderer.denoiser is None:
            settle = max(settle, 1)  # the frame that makes the denoiser is filtered: not counted
        total = np.zeros((camera.height, camera.width, 3), np.float64)
        for i in range(settle + samples):
            result = self.renderer.render(self.scene, camera, self.settings, sample=first + i, reuse_world=i > 0,
                                          denoise=True)
            self.renderer.denoiser.levels = 0  # the filter of the frames that count: none
            history = self.renderer.denoiser.history
            if history.frames < first:
                # With the denoiser's history the gather draws its numbers by the history's
                # frames, not the sample (diffuse_gather.comp.glsl gather_index): a new
                # renderer would draw the numbers of the first reference again.
                history.frames = first
            if i >= settle:
                total += result.image[..., :3]
        self.settled = True
        return (total / samples).astype(np.float32)

    def release(self) -> None:
        self.renderer.release()


class ReferenceCache:
    """References kept in an npz file (``--cache``): two runs measure against one set."""

    def __init__(self, path: str | None) -> None:
        self.path = path
        self.images: dict[str, np.ndarray] = {}
        if path:
            try:
                with np.load(path) as data:
                    self.images = {key: data[key] for key in data.files}
            except FileNotFoundError:
                pass

    def get(self, key: str, make) -> np.ndarray:
        if key not in self.images:
            self.images[key] = make()
            if self.path:
                np.savez_compressed(self.path, **self.images)
        return self.images[key]


def block_error(truth: np.ndarray, image: np.ndarray, block: int = BLOCK) -> float:
    """The RMS over ``block`` x ``block`` pixel blocks of the relative error of the block's
    mean luminance against ``truth``'s (module docstring): an error the references' grain,
    independent from pixel to pixel, reaches only by its sixteenth, where FLIP, per pixel,
    takes it whole."""
    height, width = (truth.shape[0] // block) * block, (truth.shape[1] // block) * block

    def means(a: np.ndarray) -> np.ndarray:
        lum = a[:height, :width, :3].astype(np.float64) @ LUMINANCE
        return lum.reshape(height // block, block, width // block, block).mean(axis=(1, 3))

    expected = means(truth)
    return float(np.sqrt(np.mean(((means(image) - expected) / np.maximum(expected, 1e-3)) ** 2)))


def still_figures(width: int, height: int, truth: np.ndarray, scene: SceneData,
                  settings: RenderSettings, scene_name: str = "room", seed: int = 0) -> tuple[dict, dict, dict, "object"]:
    """FLIP of the still view's viewport mean (denoised, and not) at STILL_SAMPLES, and the
    denoised mean's block_error; returns the denoised viewport's renderer, its history warm,
    for the moving run. ``seed``: the diffuse gather's numbers (the diffuse light pass's
    ``gather_seed``; 0 the product's)."""
    from hybrid_engine.frame.renderer import Renderer

    camera = camera_at(0.0, width, height, scene_name)
    still, undenoised, blocks = {}, {}, {}
    viewport, plain = Renderer(gather_seed=seed), Renderer(gather_seed=seed)
    try:
        for i in range(max(STILL_SAMPLES)):
            image = viewport.render(scene, camera, settings, sample=i, reuse_world=i > 0, accumulate=True,
                                    denoise=True).image
            raw = plain.render(scene, camera, settings, sample=i, reuse_world=i > 0, accumulate=True).image
            if i + 1 in STILL_SAMPLES:
                still[i + 1] = round(flip_mean(truth, image[..., :3]), 4)
                undenoised[i + 1] = round(flip_mean(truth, raw[..., :3]), 4)
                blocks[i + 1] = round(block_error(truth, image), 4)
    finally:
        plain.release()
    return still, undenoised, blocks, viewport


def mean_figures(runs: list[dict]) -> dict:
    """Each sample count's figure averaged over ``runs`` (one dict per realization)."""
    return {key: round(float(np.mean([run[key] for run in runs])), 4) for key in runs[0]}


def measure(width: int, height: int, reference: int, frames: int, settle: int = 48, check: bool = False,
            cache: str | None = None, scene_name: str = "room", reference_rays: int = 1,
            realizations: int = 1) -> dict:
    """Every figure of the module docstring; ``frames`` 0 measures the still view alone;
    ``reference_rays``: the references' Diffuse Rays; ``realizations``: the still figures'
    mean over that many sets of the gather's numbers (module docstring)."""
    scene = SCENES[scene_name]()
    settings = _viewport_settings()
    references = ReferenceCache(cache)
    reference_rays = int(reference_rays)
    maker = Reference(scene, replace(settings, diffuse_rays=reference_rays), settle)
    # The room's references keep their keys of before the scenes had names, and of before
    # they had rays.
    size = (f"{width}x{height}" + ("" if scene_name == "room" else f"_{scene_name}")
            + ("" if reference_rays == 1 else f"_rays{reference_rays}"))
    try:
        still_camera = camera_at(0.0, width, height, scene_name)
        truth = references.get(f"still_{size}_{reference}_{settle}",
                               lambda: maker.image(still_camera, reference, settle))
        doubled = None
        if check:
            doubled = references.get(f"still_{size}_{2 * reference}_{settle}",
                                     lambda: maker.image(still_camera, 2 * reference, settle, first=settle + reference))
        moving_truth = [references.get(f"moving{f}_{size}_{reference}_{settle}",
                                       lambda f=f: maker.image(camera_at(f * SLIDE_PER_FRAME, width, height, scene_name),
                                                               reference))
                        for f in range(min(5, frames), frames)] if frames > 0 else []
    finally:
        maker.release()
    still, undenoised, blocks, viewport = still_figures(width, height, truth, scene, settings, scene_name)
    report = {"scene": scene_name, "size": f"{width}x{height}", "reference_samples": reference,
              "reference_rays": reference_rays, "settle_frames": settle,
              "still_denoised": still, "still_undenoised": undenoised, "still_denoised_blocks": blocks}
    if realizations > 1:
        runs = [(still, undenoised, blocks)]
        for seed in range(1, int(realizations)):
            *figures, other = still_figures(width, height, truth, scene, settings, scene_name, seed)
            other.release()
            runs.append(tuple(figures))
        report["realizations"] = int(realizations)
        report["still_denoised_each"] = [run[0] for run in runs]
        for i, key in enumerate(("still_denoised", "still_undenoised", "still_denoised_blocks")):
            report[key] = mean_figures([run[i] for run in runs])
    try:
        if doubled is not None:
            report["reference_check"] = {"flip_reference_to_doubled": round(flip_mean(doubled, truth), 4)}
            again, _, _, other = still_figures(width, height, doubled, scene, settings, scene_name)
            other.release()
            report["reference_check"]["still_denoised_against_doubled"] = again
        moving: list[float] = []
        for f in range(frames):
            camera = camera_at(f * SLIDE_PER_FRAME, width, height, scene_name)
            image = viewport.render(scene, camera, settings, sample=0, accumulate=True, denoise=True).image
            if f >= 5:
                moving.append(round(flip_mean(moving_truth[f - 5], image[..., :3]), 4))
        stopped, stopped_blocks = {}, {}
        if moving:  # the camera stops at the last view: its samples accumulate on a warm history
            for i in range(max(STILL_SAMPLES)):
                image = viewport.render(scene, camera, settings, sample=i, reuse_world=i > 0, accumulate=True,
                                        denoise=True).image
                if i + 1 in STILL_SAMPLES:
                    stopped[i + 1] = round(flip_mean(moving_truth[-1], image[..., :3]), 4)
                    stopped_blocks[i + 1] = round(block_error(moving_truth[-1], image), 4)
    finally:
        viewport.release()
    report["moving_denoised_after_five"] = moving
    report["moving_after_five_max"] = max(moving) if moving else None
    report["stopped_denoised"] = stopped
    report["stopped_denoised_blocks"] = stopped_blocks
    return report


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", default="96x72")
    parser.add_argument("--reference", type=int, default=256)
    parser.add_argument("--reference-rays", type=int, default=1)
    parser.add_argument("--frames", type=int, default=10)
    parser.add_argument("--settle", type=int, default=48)
    parser.add_argument("--check", action="store_true")
    parser.add_argument("--cache")
    parser.add_argument("--json")
    parser.add_argument("--scene", choices=sorted(SCENES), default="room")
    parser.add_argument("--realizations", type=int, default=1)
    args = parser.parse_args(argv)
    if args.realizations < 1:
        parser.error("--realizations must be at least 1")
    width, height = (int(v) for v in args.size.split("x"))
    report = measure(width, height, args.reference, args.frames, args.settle, args.check, args.cache, args.scene,
                     args.reference_rays, args.realizations)
    print(json.dumps(report, indent=2))
    bench.write_json(report, args.json)
    return report


if __name__ == "__main__":
    main(sys.argv[1:])
