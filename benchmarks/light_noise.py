# SPDX-License-Identifier: GPL-3.0-or-later
"""How quickly the traced diffuse light becomes clean, still and moving, in the viewport's way.

``python -m benchmarks.light_noise [--size 160x120] [--reference 64] [--frames 10] [--json PATH]``

The scene is an interior lit only by bounced light: a closed room whose lamp stands behind a
partition, so that half of what the camera sees is lit by the walls alone (the room of
tests/test_diffuse_light.py, built here from the core's types). Two measurements, each
against the converged image of its own view (``--reference`` samples, averaged, undenoised):

* **still**: the viewport's accumulation (``render(accumulate=True)``, one sample per redraw,
  denoised as the viewport denoises) after 1, 2, 4, 8 and 16 samples: FLIP of the mean so far;
* **moving**: the camera slides steadily sideways; the viewport starts its mean over at every
  move, so each frame shows one sample, with the denoiser's history reprojected from the last
  frame: FLIP of every frame against its own view's converged image.

FLIP is the LDR one of docs/PICTURES.md (benchmarks/bench.py ``flip_mean``). Seeds are fixed: a
sample's numbers depend on its index and the pixel's surface point only.
"""
from __future__ import annotations

import argparse
import json
import sys

import numpy as np

from benchmarks import bench
from benchmarks.bench import flip_mean
from hybrid_engine.scene.camera import Camera, look_at
from hybrid_engine.scene.data import Lights, MaterialTable, SceneData, Sky
from hybrid_engine.scene.geometry import Geometry
from hybrid_engine.scene.settings import RenderSettings

ROOM_HALF = 3.0
STILL_SAMPLES = (1, 2, 4, 8, 16)
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


def camera_at(offset: float, width: int, height: int) -> Camera:
    eye = np.array([-2.0 + offset, -2.5, 0.5])
    return Camera(matrix_world=look_at(eye, eye + np.array([1.0, 3.0, -0.6])), width=width, height=height)


def converged(renderer, scene, camera, settings, samples: int) -> np.ndarray:
    total = None
    for i in range(samples):
        image = renderer.render(scene, camera, settings, sample=i).image[..., :3].astype(np.float64)
        total = image if total is None else total + image
    return (total / samples).astype(np.float32)


def measure(width: int, height: int, reference: int, frames: int) -> dict:
    from hybrid_engine.frame.renderer import Renderer

    scene = room()
    settings = RenderSettings(mode="HYBRID", near_size=2.0, shadow_resolution=512)
    plain, viewport = Renderer(), Renderer()
    try:
        still_camera = camera_at(0.0, width, height)
        truth = converged(plain, scene, still_camera, settings, reference)
        still, undenoised = {}, {}
        for i in range(max(STILL_SAMPLES)):
            image = viewport.render(scene, still_camera, settings, sample=i, accumulate=True, denoise=True).image
            raw = plain.render(scene, still_camera, settings, sample=i, accumulate=True).image
            if i + 1 in STILL_SAMPLES:
                still[i + 1] = round(flip_mean(truth, image[..., :3]), 4)
                undenoised[i + 1] = round(flip_mean(truth, raw[..., :3]), 4)
        moving = []
        for f in range(frames):
            camera = camera_at(f * SLIDE_PER_FRAME, width, height)
            image = viewport.render(scene, camera, settings, sample=0, accumulate=True, denoise=True).image
            moving.append(round(flip_mean(converged(plain, scene, camera, settings, reference), image[..., :3]), 4))
    finally:
        plain.release()
        viewport.release()
    return {"size": f"{width}x{height}", "reference_samples": reference, "still_denoised": still,
            "still_undenoised": undenoised, "moving_denoised": moving,
            "moving_after_five_max": max(moving[5:]) if len(moving) > 5 else None}


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", default="160x120")
    parser.add_argument("--reference", type=int, default=64)
    parser.add_argument("--frames", type=int, default=10)
    parser.add_argument("--json")
    args = parser.parse_args(argv)
    width, height = (int(v) for v in args.size.split("x"))
    report = measure(width, height, args.reference, args.frames)
    print(json.dumps(report, indent=2))
    bench.write_json(report, args.json)
    return report


if __name__ == "__main__":
    main(sys.argv[1:])
