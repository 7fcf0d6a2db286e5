# SPDX-License-Identifier: GPL-3.0-or-later
"""How clean a moving object stays in the viewport: an object slides across a still view.

``python -m benchmarks.moving_object_noise [--size 96x72] [--reference 128] [--frames 10]
[--settle 48] [--slide 0.04] [--deform] [--json PATH]``

The room of benchmarks/light_noise.py (a closed grey room, its lamp behind a partition) with
a grey pillar, an instance of its own mesh, sliding across the floor in front of the camera by
``SLIDE_PER_FRAME`` per redraw. The viewport starts its mean over whenever the scene changes,
so each frame shows one sample, filtered by the denoiser with its history reprojected. Each
frame is compared (LDR FLIP) with the converged image of its own scene (light_noise.py's
``Reference``: the viewport's passes, the denoiser's temporal step alone, ``--reference``
frames after the history settled), over the whole image and over the box's pixels, for the
frames after the first five. Twice in one process: the denoiser following the box's move
(passes/surface_motion/), and not (``FOLLOW_MOVES`` off: the reprojection by the camera
alone, where every pixel of the box starts over each frame). ``--deform`` slides the pillar
by deforming its mesh instead (its vertices moved, its matrix kept, as an armature or shape
keys move a mesh; scene_upload/previous_rows.py).
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

from benchmarks import bench
from benchmarks.bench import flip_error, flip_mean
from benchmarks.light_noise import ROOM_HALF, Reference, _box, _viewport_settings, camera_at, room
from hybrid_engine.passes.surface_motion import surface_motion
from hybrid_engine.scene.data import MaterialTable, SceneData
from hybrid_engine.scene.geometry import InstancedGeometry
from hybrid_engine.scene.meshes import Instances, ObjectMesh

SLIDE_PER_FRAME = 0.04  # scene units the box moves between redraws
BOX_START = (-1.6, 0.3)  # x, y of its centre at frame 0: a pillar on the floor, in view
BOX_HALF = 0.35
BOX_HEIGHT = 2.2
BOX_MATERIAL = 1  # the box's row: the same grey, another surface id (its pixels' mask)


def soup_mesh(triangles: np.ndarray) -> ObjectMesh:
    """A triangle list as a mesh, each corner its own vertex, normals flat by its winding."""
    triangles = np.asarray(triangles, np.float32)
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    corners = np.arange(3 * len(triangles), dtype=np.int32)
    return ObjectMesh(positions=triangles.reshape(-1, 3), corner_vertices=corners,
                      normals=np.repeat(normals, 3, axis=0), corner_normals=corners,
                      slots=np.zeros(len(triangles), np.int32), uvs=np.zeros((3 * len(triangles), 2), np.float32))


class SlidingPillar:
    """The room, its walls and partition one instance, the box another, frame by frame: the
    same meshes throughout (as a scene sync keeps them), the box placed by its matrix, or
    with ``deform`` by its vertices (each frame a new version of its mesh, the matrix the
    identity)."""

    def __init__(self, slide: float = SLIDE_PER_FRAME, deform: bool = False) -> None:
        self.base = room()
        self.walls = soup_mesh(self.base.geometry.triangles)
        self.block = soup_mesh(_box((-BOX_HALF, -BOX_HALF, 0.0), (BOX_HALF, BOX_HALF, BOX_HEIGHT))[:, ::-1])  # facing out
        self.slide, self.deform = slide, deform
        self._deformed = self.block

    def scene(self, frame: int) -> SceneData:
        offset = np.array([BOX_START[0] + frame * self.slide, BOX_START[1], -ROOM_HALF])
        place = np.eye(4)
        if self.deform:
            self._deformed = block = self._deformed.deformed(self.block.positions + offset, self.block.normals)
        else:
            place[:3, 3] = offset
            block = self.block
        instances = Instances(meshes=[self.walls, block], mesh=np.array([0, 1]), matrices=np.array([np.eye(4), place]),
                              slot_materials=[np.int32([0]), np.int32([BOX_MATERIAL])])
        materials = MaterialTable.from_rows([dict(base_color=(0.8, 0.8, 0.8), specular=0.0, roughness=1.0)] * 2)
        return SceneData(InstancedGeometry(instances), materials, self.base.lights, self.base.sky)


def measure(width: int, height: int, reference: int, frames: int, settle: int,
            slide: float = SLIDE_PER_FRAME, deform: bool = False) -> dict:
    from hybrid_engine.frame.renderer import Renderer

    settings = _viewport_settings()
    camera = camera_at(0.0, width, height)
    pillar = SlidingPillar(slide, deform)
    maker = Reference(pillar.scene(0), settings, settle)
    try:
        truths = []
        for f in range(frames):
            maker.scene = pillar.scene(f)
            truths.append(maker.image(camera, reference) if f >= 5 else None)
    finally:
        maker.release()
    report: dict = {"size": f"{width}x{height}", "reference_samples": reference, "settle_frames": settle,
                    "slide_per_frame": slide, "deform": deform}
    for follow in (True, False):
        surface_motion.FOLLOW_MOVES = follow
        viewport = Renderer()
        pillar = SlidingPillar(slide, deform)
        whole, on_box = [], []
        try:
            for f in range(frames):
                image = viewport.render(pillar.scene(f), camera, settings, sample=0, accumulate=True,
                                        denoise=True).image
                if f < 5:
                    continue
                ids = viewport.denoiser.history.read("length")[..., 1]
                box = ids == BOX_MATERIAL + 1
                whole.append(round(flip_mean(truths[f], image[..., :3]), 4))
                on_box.append(round(_masked_flip(truths[f], image[..., :3], box), 4))
        finally:
            surface_motion.FOLLOW_MOVES = True
            viewport.release()
        report["following" if follow else "camera_only"] = {"whole": whole, "box": on_box,
                                                             "whole_max": max(whole), "box_max": max(on_box)}
    return report


def _masked_flip(reference: np.ndarray, test: np.ndarray, mask: np.ndarray) -> float:
    """Mean FLIP over the pixels of ``mask`` (rows as the renderer's, bottom first), from the
    per-pixel map of bench.flip_mean's FLIP (top row first)."""
    error = flip_error(reference, test)[0]
    return float(error[mask[::-1]].mean()) if mask.any() else float("nan")


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", default="96x72")
    parser.add_argument("--reference", type=int, default=128)
    parser.add_argument("--frames", type=int, default=10)
    parser.add_argument("--settle", type=int, default=48)
    parser.add_argument("--slide", type=float, default=SLIDE_PER_FRAME, help="scene units per redraw")
    parser.add_argument("--deform", action="store_true", help="move the pillar by deforming its mesh")
    parser.add_argument("--json")
    args = parser.parse_args(argv)
    width, height = bench.parse_resolution(args.size)
    report = measure(width, height, args.reference, args.frames, args.settle, args.slide, args.deform)
    for key in ("following", "camera_only"):
        figures = report[key]
        print(f"{key:12s} whole image {figures['whole']} (max {figures['whole_max']}); "
              f"the box's pixels {figures['box']} (max {figures['box_max']})")
    bench.write_json(report, args.json)
    return report


if __name__ == "__main__":
    main(sys.argv[1:])
