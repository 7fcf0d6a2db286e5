# SPDX-License-Identifier: GPL-3.0-or-later
"""The frame's first two steps: the host copies the scene to the GPU, the GPU transforms it.

Timed apart, so that a frame's host milliseconds read as extract + ``upload`` everywhere,
and the instance transform, GPU work, has its own row (paper §3.3: the meshes live on the
GPU and are transformed there every frame).
"""
from __future__ import annotations

from ...scene.settings import RenderSettings
from ..frame_context import FrameContext, PassIO
from .scene_buffers import GPUScene


class SceneUploadPass:
    """The host's part: the geometry as instances, the object-space store and the instance
    table, materials and textures (scene_buffers.py); finds which instances changed."""

    name = "upload"

    def __init__(self, buffers: GPUScene) -> None:
        self.buffers = buffers

    def io(self, settings: RenderSettings) -> PassIO:
        return PassIO(reads=("scene_data",), writes=("scene", "scene_buffers", "delta"))

    def run(self, frame: FrameContext) -> None:
        scene, delta = self.buffers.upload(frame.read("scene_data"))
        stats = self.buffers.instance_transform.stats
        frame.counts.update(triangles_uploaded=int(delta.changed_triangles),
                            instances_written=stats.instances_written, meshes_uploaded=stats.meshes_uploaded,
                            triangles_transformed=stats.triangles_transformed)
        frame.write("scene", scene)
        frame.write("scene_buffers", self.buffers)
        frame.write("delta", delta)


class InstanceTransformPass:
    """The GPU's part: the world-space rows of the instances the upload found changed
    (instance_transform.py), which every later pass reads."""

    name = "instance_transform"

    def __init__(self, buffers: GPUScene) -> None:
        self.buffers = buffers

    def io(self, settings: RenderSettings) -> PassIO:
        return PassIO(reads=("scene_buffers",), writes=("world_triangles",))

    def run(self, frame: FrameContext) -> None:
        # Only a denoised frame follows a deformed surface back to last frame
        # (passes/surface_motion/): others need not copy its rows first.
        self.buffers.transform(keep_previous=frame.denoise)
        frame.write("world_triangles", frame.read("scene_buffers"))
