# SPDX-License-Identifier: GPL-3.0-or-later
"""Depth of field and motion blur: what each accumulated sample sees.

Both effects are integrals that Cycles and EEVEE take over their samples, and so does
Hybrid RT: every sample of a view (a final render's ``render_samples``, the viewport's
redraws) is a whole frame of the paper's method from one aperture point (the thin lens,
scene/thin_lens.py) at one time in the shutter (scene/motion.py), and the film's running
mean (passes/film/) integrates them.

**Depth of field.** A sample's camera is the pinhole camera moved to its aperture point
``(ax, ay)`` in camera space, with the projection sheared so that the focus plane (view
depth ``-d``) is seen exactly where the pinhole camera sees it: a point ``(x', y', z)`` of
the moved camera's view space is projected as the pinhole projects ``(x' - ax z / d, y' -
ay z / d, z)``. The shear leaves the eye at the origin and moves the focus plane by the
aperture offset, so a ray through a pixel starts at the aperture point and meets the focus
plane where the pinhole ray does: Cycles' thin lens, per sample instead of per pixel. The
same shear holds for an orthographic camera (parallel rays tilted to converge on the focus
plane, as Cycles' ``camera_sample_orthographic``).

The G-buffer, the shading and the tracer take the moved eye (view vectors, reflections
start where this sample's eye sees them); the cube map, the near-cube cull and the BVH are
those of the lens centre (``LensView.center``), built once and kept for every sample
(``Renderer.render(reuse_world=True)``): no recompile, no upload, a primary raster, the
shading and the trace per sample, as for anti-aliasing. The error of that reuse is bounded
by the aperture against the near cube (paper §3.2-3.3): the eye lies within the aperture
radius ``r`` of the cube's centre, so the near cube of half-size ``h`` still holds a cube of
half-size ``h - r`` around the eye (the BVH side keeps its guarantee for rays up to ``h - r``
from the eye instead of ``h``), and what the cube map shows beyond it is seen from a point
at most ``r`` away: a parallax of at most ``r / h`` radians, the angle the paper already
accepts between a reflection's origin and the cube's centre. For a 50 mm lens at f/2.8
(``r`` = 9 mm) and a near size of 1 m that is under 1 %.

**Motion blur.** A sample at time ``t`` takes the instance table's matrices and the
camera's at ``t`` (``MotionSteps``): a new instance table whose rows differ only for what
moves, so the upload re-sends those rows and transforms their instances (the meshes stay on
the GPU), and the cube map and BVH of that time are built for it. A mesh that deforms gets
its positions and normals of ``t`` (same topology), which the upload re-sends in place.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from ..scene.camera import Camera, view_from_world
from ..scene.data import SceneData
from ..scene.geometry import InstancedGeometry
from ..scene.meshes import Instances
from ..scene.motion import MotionSteps, shutter_time
from ..scene.thin_lens import ThinLens
from .views import ViewportView

# Roberts' R2 sequence (the plastic number's powers): a progressive 2D set that stays even
# for any count of samples and does not follow the Halton points of the pixel offsets.
_R2 = (0.7548776662466927, 0.5698402909980532)
# Versions of a sample's deformed meshes: negative and never repeated, so that the upload
# (which re-sends a mesh whose version differs from the one it holds) sends each sample's
# shape and, after the render, the scene's own version again.
_SAMPLE_VERSIONS = itertools.count(-1, -1)


def aperture_uv(index: int) -> tuple[float, float]:
    """The uniform numbers of sample ``index``'s aperture point (R2 sequence)."""
    return (0.5 + index * _R2[0]) % 1.0, (0.5 + index * _R2[1]) % 1.0


@dataclass(frozen=True)
class LensView(ViewportView):
    """A sample of a thin lens: the view from one aperture point, its projection sheared
    onto the focus plane (module docstring); ``lens_center`` is the pinhole's eye, where the
    frame centres its near cube and cube map."""

    lens_center: np.ndarray = field(default_factory=lambda: np.zeros(3))

    @property
    def center(self) -> np.ndarray:
        return np.asarray(self.lens_center, np.float64).copy()


def lens_camera(camera: Camera, lens: ThinLens, point: tuple[float, float]) -> Camera:
    """``camera`` seen from the aperture point ``point`` (camera-space x, y in scene units),
    focused at ``lens.focus_distance`` (module docstring)."""
    ax, ay = float(point[0]), float(point[1])
    if ax == 0.0 and ay == 0.0:
        return camera
    move = np.eye(4)
    move[0, 3], move[1, 3] = -ax, -ay  # view space of the moved eye
    shear = np.eye(4)
    shear[0, 2], shear[1, 2] = -ax / lens.focus_distance, -ay / lens.focus_distance
    view = move @ camera.view_matrix()
    window = camera.projection_matrix() @ shear
    return LensView(world_to_view=view, window=window, width=int(camera.width), height=int(camera.height),
                    pixel_origin=camera.pixel_origin, lens_center=np.asarray(camera.center, np.float64))


def moved_camera(camera: Camera, matrix_world: np.ndarray) -> Camera:
    """``camera`` with its eye and axes at ``matrix_world`` (its projection, crop included,
    kept): the camera at another time of the shutter."""
    current = np.asarray(camera.view_matrix(), np.float64)
    view = view_from_world(matrix_world)
    if np.array_equal(view, current):
        return camera
    return ViewportView.from_matrices(view, camera.projection_matrix(), camera.width, camera.height,
                                      camera.pixel_origin)


@dataclass(frozen=True)
class CameraEffects:
    """What varies from sample to sample besides the pixel offset: the thin lens (None: a
    pinhole) and the motion over the shutter (None: the frame's time only), with the
    shutter's ``opening`` and ``closing`` in frames relative to the frame."""

    lens: ThinLens | None = None
    motion: MotionSteps | None = None
    opening: float = 0.0
    closing: float = 0.0

    @property
    def active(self) -> bool:
        return (self.lens is not None and self.lens.active) or (
            self.motion is not None and self.motion.anything_moves)

    def time(self, index: int) -> float:
        """Sample ``index``'s time in the shutter (frames relative to the frame)."""
        return shutter_time(index, self.opening, self.closing)

    def camera(self, camera: Camera, index: int, jitter=None) -> Camera:
        """Sample ``index``'s camera: moved to its time, offset by ``jitter`` (a function of
        the camera, the pixel offset of anti-aliasing), then seen through its aperture point.
        The jitter comes before the lens: the lens shears the jittered projection."""
        if self.motion is not None and self.motion.camera_moves:
            camera = moved_camera(camera, self._camera_world(camera, self.motion.camera_matrix(self.time(index))))
        if jitter is not None:
            camera = jitter(camera)
        if self.lens is not None and self.lens.active:
            camera = lens_camera(camera, self.lens, self.lens.aperture_point(*aperture_uv(index)))
        return camera

    def scene(self, scene: SceneData, index: int) -> SceneData:
        """The scene at sample ``index``'s time: its instance table with the matrices of that
        time (the same meshes, slots and ids), or ``scene`` itself when nothing moves."""
        motion = self.motion
        geometry = scene.geometry
        if (motion is None or not (motion.moving.any() or motion.deformations)
                or not isinstance(geometry, InstancedGeometry)):
            return scene
        instances = geometry.instances
        if len(instances) != motion.instances.shape[1]:
            return scene  # the table changed since the steps were taken: show the frame's time
        time = self.time(index)
        meshes = list(instances.meshes)
        for mesh_index in motion.deformations:
            base = meshes[mesh_index] if mesh_index < len(meshes) else None
            positions, normals = motion.mesh_arrays(mesh_index, time)
            if base is None or base.positions.shape != positions.shape or base.normals.shape != normals.shape:
                continue
            shaped = base.deformed(positions, normals)
            shaped.version = next(_SAMPLE_VERSIONS)
            meshes[mesh_index] = shaped
        moved = Instances(meshes=meshes, mesh=instances.mesh,
                          matrices=motion.instance_matrices(time, instances.matrices),
                          slot_materials=instances.slot_materials, random_ids=instances.random_ids,
                          colors=instances.colors)
        return SceneData(geometry=InstancedGeometry(moved, geometry.object_names), materials=scene.materials,
                         lights=scene.lights, sky=scene.sky)

    @staticmethod
    def _camera_world(camera: Camera, matrix_world: np.ndarray) -> np.ndarray:
        """The scale-free world matrix of the camera at another time (the view never scales)."""
        m = np.asarray(matrix_world, np.float64).copy()
        norms = np.linalg.norm(m[:3, :3], axis=0)
        norms[norms == 0] = 1.0
        m[:3, :3] /= norms
        return m
