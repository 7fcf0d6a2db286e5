# SPDX-License-Identifier: GPL-3.0-or-later
"""The ``vector`` pass: Cycles' Vector pass, the screen-space motion of what each pixel sees,
made on the GPU over a final render's samples.

The compositor's Vector Blur node (and any retimer or temporal denoiser of a studio's
pipeline) reads, per pixel, where the surface seen there was on the frame before and will be
on the frame after. Cycles writes it as four channels in pixels (its kernel's
``primitive_motion_vector``): xy = the previous frame's raster position minus this frame's,
zw = this frame's minus the next frame's, raster y pointing up (row 0 at the bottom, as the
render result stores it), and the mean over the samples that hit a surface (its film divides
by the count of those samples: the background, which no sample hits, is 0). Only where
Motion Blur is off: with it the scene is evaluated across the shutter instead of at the
frames around it, and Cycles leaves the pass at 0; so does the Blender adapter.

How it is made: one compute invocation per pixel and sample (``gpu_shaders/film/
vector.comp.glsl``) takes the surface point the sample's G-buffer shows there (its depth
through the sample's view-projection) back to the previous and on to the next frame: a
rigid instance through its world-to-world motion (``previous matrix x current matrix^-1``,
Cycles' ``motion_pass`` transforms), a deforming mesh through its triangle's corners at
those frames, the point keeping its weights in the triangle, and both through the camera of
that frame. The pixel's instance is the one whose world rows hold the row the G-buffer keeps
for it, so nothing is drawn again, and what the G-buffer's alpha test dropped is not there
(no G-buffer read-back, no per-pixel host work). The same invocation adds the sample's
vector into sums on the GPU and writes their mean, which the frame that reads its image
reads back once. The motion table lists only what moves.

What differs from Cycles: the camera of the other frames keeps this frame's lens (an
animated focal length or shift is not followed), and a mesh whose vertex count changes
between the frames moves rigidly (Cycles drops its deformation motion the same way).
"""
from __future__ import annotations

import math

import moderngl
import numpy as np

from ...gpu import shader_loader
from ...gpu.bindings import Image, bind
from ...gpu.render_targets import release_all
from ...gpu.triangle_input import input_defines, input_split, input_storage
from ...scene import matrix4
from ...scene.data import SceneData
from ...scene.geometry import InstancedGeometry
from ...scene.matrix4 import affine_inverses
from ...scene.motion import MotionSteps
from ...scene.raster_view import gl_matrix
from ...scene.settings import RenderSettings
from ..frame_context import FrameContext, PassIO
from .accumulate import AccumulationError

WORKGROUP = 8
# Blender's pass: its name, channels, channel ids and kind, as register_pass takes them.
PASS = ("Vector", 4, "XYZW", "VECTOR")
# MotionSteps' steps of a Vector pass: the frame before, the frame, the frame after.
FRAME_TIMES = (-1.0, 0.0, 1.0)


class VectorRequest:
    """The motion a Vector pass follows: the instance table's and the camera's matrices (and
    the deforming meshes' vertices) at the frames before and after (``motion``, steps at
    ``FRAME_TIMES``). Compared by identity: one request is one render's motion."""

    def __init__(self, motion: MotionSteps) -> None:
        if tuple(float(t) for t in motion.times) != FRAME_TIMES:
            raise ValueError(f"a Vector pass needs steps at the frames {FRAME_TIMES}, got {motion.times}")
        self.motion = motion


def camera_motion(view: np.ndarray, cameras: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The views of the frames before and after, for a sample drawn with ``view`` at the
    frame: the camera's rigid move between the frames (``cameras``: its world matrices at
    ``FRAME_TIMES``, scale removed) applied to ``view``, so the sample's own eye (a lens
    point, a region) moves with it. A camera that does not move keeps ``view`` exactly."""
    rigid = np.array(cameras, np.float64)
    norms = np.linalg.norm(rigid[:, :3, :3], axis=1)
    rigid[:, :3, :3] /= np.where(norms == 0.0, 1.0, norms)[:, None, :]
    out = []
    for other in (rigid[0], rigid[2]):
        if np.array_equal(other, rigid[1]):
            out.append(np.asarray(view, np.float64))
        else:  # view_other = view . world_current . world_other^-1
            out.append(np.asarray(view, np.float64) @ rigid[1] @ affine_inverses(other[None])[0])
    return out[0], out[1]


def motion_table(scene: SceneData, request: VectorRequest) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What the kernel reads (vector.comp.glsl): per instance that moves or deforms,
    ``rows`` (first world row, end row, index into ``matrices`` or -1, index into
    ``corners`` or -1), sorted by row; ``matrices`` (2 per rigid instance: world to the
    previous and to the next frame's world, float32 (n, 4, 4)); ``corners`` (a deforming
    instance's world positions at the previous and next frame, two vec4 per corner of its
    rows). Empty when the instance table is not the one the motion was read for."""
    motion = request.motion
    geometry = scene.geometry
    empty = (np.zeros((1, 4), np.int32), np.zeros((2, 4, 4), np.float32), np.zeros((2, 4), np.float32))
    if not isinstance(geometry, InstancedGeometry) or len(geometry.instances) != motion.instances.shape[1]:
        return empty
    instances = geometry.instances
    ranges = geometry.object_ranges.astype(np.int64)
    deforming = np.zeros(len(instances), bool)
    for mesh_index in motion.deformations:
        deforming |= np.asarray(instances.mesh) == mesh_index
    which = np.flatnonzero(motion.moving | deforming)
    if not len(which):
        return empty
    rows = np.full((len(which), 4), -1, np.int32)
    rows[:, 0] = ranges[which, 0]
    rows[:, 1] = ranges[which, 0] + ranges[which, 1]
    matrices: list[np.ndarray] = []
    corners: list[np.ndarray] = []
    corner_count = 0
    current = np.asarray(instances.matrices, np.float64)
    for slot, k in enumerate(which):
        previous, following = motion.instances[0, k], motion.instances[2, k]
        mesh = instances.meshes[int(instances.mesh[k])]
        shapes = motion.deformations.get(int(instances.mesh[k]))
        if shapes is not None and shapes[0].shape[1:] == mesh.positions.shape:
            positions = shapes[0]
            at = mesh.corner_vertices
            pair = np.empty((len(at), 2, 4), np.float32)
            for side, (step, matrix) in enumerate(((0, previous), (2, following))):
                points = positions[step][at].astype(np.float64)
                pair[:, side, :3] = points @ matrix[:3, :3].T + matrix[:3, 3]
                pair[:, side, 3] = 1.0
            rows[slot, 3] = 2 * corner_count
            corners.append(pair.reshape(-1, 4))
            corner_count += len(at)
        else:
            to_object = affine_inverses(current[k:k + 1])[0]
            rows[slot, 2] = len(matrices)
            matrices += [previous @ to_object, following @ to_object]
    order = np.argsort(rows[:, 0], kind="stable")
    return (rows[order],
            np.asarray(matrices, np.float32).reshape(-1, 4, 4) if matrices else empty[1],
            np.concatenate(corners) if corners else empty[2])


class VectorPass:
    """Per sample, the motion of what each pixel sees added into the view's sums (``run``),
    and their mean, Cycles' Vector pass (``read``)."""

    name = "vector"

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        # Compiled with the pass, as the other film passes compile theirs (an input split over
        # several storage blocks compiles its own variant when it first comes).
        shader_loader.compute(ctx, "film/vector.comp.glsl")
        self.size: tuple[int, int] | None = None
        self.count = 0  # samples in the sums
        self._targets: dict[str, object] = {}
        self._table: dict[str, object] = {}
        self._table_key: tuple | None = None
        self._entries = 0

    def io(self, settings: RenderSettings) -> PassIO:
        return PassIO(reads=("scene", "world_triangles", "gbuffer"), writes=("vector",))

    def run(self, frame: FrameContext) -> None:
        self.add(frame.read("scene"), frame.read("world_triangles"), frame.read("gbuffer"), frame.camera,
                 frame.outputs.vector, frame.sample)
        frame.write("vector", self)

    def add(self, scene: SceneData, gpu, targets, camera, request: VectorRequest, sample: int) -> None:
        """Add sample ``sample`` of ``camera``'s view, whose primary G-buffer is ``targets``
        (0 starts the sums over; any other must follow the last, of the same size, else
        AccumulationError)."""
        size = (int(camera.width), int(camera.height))
        if sample != 0 and (sample != self.count or size != self.size):
            raise AccumulationError(f"Vector sample {sample} of a {size[0]}x{size[1]} view does not follow the "
                                    f"{self.count} samples so far; start again at sample 0")
        self._ensure(size)
        self._upload_table(scene, request)
        projection = np.asarray(camera.projection_matrix(), np.float64)
        view = np.asarray(camera.view_matrix(), np.float64)
        previous, following = camera_motion(view, request.motion.camera)
        view_proj = np.asarray(camera.view_projection(), np.float64)
        split = input_split(max(int(gpu.triangle_count), 1))
        program = shader_loader.compute(self.ctx, "film/vector.comp.glsl", input_defines(split) or None)
        bind(program,
             storage={"MotionRows": self._table["rows"], "MotionMatrices": self._table["matrices"],
                      "MotionCorners": self._table["corners"], **input_storage(gpu.positions.buffer, split)},
             textures={"u_depth": targets.depth, "u_normal_material": targets.normal_material, "u_row": targets.row},
             images={"u_sums": Image(self._targets["sums"], read=True, write=True),
                     "u_hits": Image(self._targets["hits"], read=True, write=True),
                     "u_vector_pass": Image(self._targets["mean"], read=False, write=True)},
             # The G-buffer's own matrix: the points are the ones it drew.
             uniforms={"u_view_proj": gl_matrix(view_proj), "u_inv_view_proj": gl_matrix(matrix4.inverse(view_proj)),
                       "u_previous_view_proj": gl_matrix(projection @ previous),
                       "u_next_view_proj": gl_matrix(projection @ following),
                       "u_entries": self._entries, "u_size": size, "u_restart": int(sample == 0),
                       "u_use_indices": 0})
        program.run(math.ceil(size[0] / WORKGROUP), math.ceil(size[1] / WORKGROUP), 1)
        self.ctx.memory_barrier(moderngl.SHADER_IMAGE_ACCESS_BARRIER_BIT | moderngl.TEXTURE_UPDATE_BARRIER_BIT)
        self.count = sample + 1

    def read(self) -> dict[str, np.ndarray]:
        """{"Vector": (H, W, 4) float32}, row 0 at the bottom: the mean over the samples so far."""
        if self.count == 0 or self.size is None:
            return {}
        width, height = self.size
        out = np.empty((height, width, 4), np.float32)
        self._targets["mean"].read_into(out)
        return {PASS[0]: out}


    def _upload_table(self, scene: SceneData, request: VectorRequest) -> None:
        """The motion table (``motion_table``), made again only for another request or scene."""
        key = (id(request), id(scene.geometry))
        if key == self._table_key:
            return
        release_all(self._table.values())
        rows, matrices, corners = motion_table(scene, request)
        self._entries = len(rows)  # the empty table's one entry covers no row
        self._table = {"rows": self.ctx.buffer(np.ascontiguousarray(rows, np.int32).tobytes()),
                       "matrices": self.ctx.buffer(np.ascontiguousarray(np.transpose(matrices, (0, 2, 1)),
                                                                        np.float32).tobytes()),
                       "corners": self.ctx.buffer(np.ascontiguousarray(corners, np.float32).tobytes())}
        self._table_key = key

    def _ensure(self, size: tuple[int, int]) -> None:
        if size == self.size:
            return
        release_all(self._targets.values())
        self._targets = {"sums": self.ctx.texture(size, 4, dtype="f4"), "hits": self.ctx.texture(size, 1, dtype="f4"),
                         "mean": self.ctx.texture(size, 4, dtype="f4")}
        self.size, self.count = size, 0

    def release(self) -> None:
        release_all(self._targets.values())
        release_all(self._table.values())
        self._targets, self._table, self._table_key = {}, {}, None
        self.size, self.count = None, 0
