# SPDX-License-Identifier: GPL-3.0-or-later
"""The ``surface_motion`` pass: where each primary pixel's surface was on the last frame, for
the instances that moved since.

The denoiser's temporal step (passes/denoise/) finds a pixel's history by taking its surface
point to last frame's image. Through the camera's motion alone, an object that moves (an
animation played, an object grabbed in the viewport) lands on another surface there, and
every pixel of it starts over each frame: the moving object is shown from one or two
samples, filtered hard and blotchy. SVGF and EEVEE follow it by motion vectors.

Here the host compares the instance table's matrices with the last frame's, where the
upload found some instance changed, and lists the instances that moved with their
world-to-world move ``previous matrix x current matrix^-1``, the transform Cycles' motion
pass takes (passes/film/vector.py makes the Vector pass with the same). A deformed mesh
(an armature, shape keys: the same triangles, new vertices) moves its surface under an
unchanged matrix; the instance transform kept its instances' rows of last frame
(scene_upload/previous_rows.py), and they join the list with those rows. The GPU then runs
one invocation per primary pixel (surface_motion/surface_motion.comp.glsl): the G-buffer
keeps each pixel's world row, and a pixel whose row lies in a listed instance gets where
its surface point stood last frame, with its entry, in the ``surface_motion`` image (0: no
move there), and the rotation of its normal in a second. Nothing is drawn again, so the
cost follows the image's pixels, however many triangles moved, and a pixel is its own
surface's by its row: no depth comparison decides it. Where the camera's motion alone
finds no history for a pixel (the object moved off that point), the temporal step takes
the pixel's point and normal back and looks for them again in last frame's image; so does
the diffuse gather, which traces more paths where a pixel has no history
(include/surface_motion.glsl). A frame where nothing changed costs nothing on either side.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import moderngl
import numpy as np

from ...gpu import gl_context, shader_loader
from ...gpu.bindings import Image, bind
from ...gpu.render_targets import release_all
from ...gpu.triangle_input import input_defines, input_split, input_storage
from ...scene.geometry import InstancedGeometry
from ...scene.matrix4 import affine_inverses
from ...scene.settings import RenderSettings
from ..frame_context import FrameContext, PassIO

# The compute kernel's workgroup: 8 x 8 pixels.
WORKGROUP = 8


# Follow the instances' moves; False finds nothing moved, the denoiser's reprojection before
# this pass (a switch for benchmarks/moving_object_noise.py).
FOLLOW_MOVES = True


@dataclass
class SurfaceMotion:
    """What the pass leaves for the denoiser and the diffuse gather, textures of the primary
    view's size (textures, since the gather's kernel is short of storage blocks):
    ``texture`` (RGBA32F: the surface's world point of last frame and the moved instance's
    entry + 1 per pixel, 0 where nothing moved) and ``turn`` (RGBA16F: the quaternion taking
    the surface's normal now to its normal then), or ``moving`` False with neither valid
    (include/surface_motion.glsl reads them)."""

    moving: bool
    texture: object = None
    turn: object = None


class InstanceMoves:
    """The host's side: which instances moved since the last frame it saw, and how."""

    def __init__(self) -> None:
        self._matrices: np.ndarray | None = None
        self._meshes: np.ndarray | None = None

    def moves(self, geometry, unchanged: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """(instances that moved, sorted; their world-to-world matrices previous x current^-1,
        float64 (n, 4, 4)) since the last call; none on a first call, or where the instance
        table's layout (count, meshes) changed. ``unchanged``: the upload found no instance
        changed since the last frame, which was this call's last: nothing is compared."""
        none = (np.zeros(0, np.int64), np.zeros((0, 4, 4)))
        if not isinstance(geometry, InstancedGeometry):
            self._matrices = None
            return none
        if unchanged and self._matrices is not None:
            return none
        instances = geometry.instances
        current = np.asarray(instances.matrices)
        meshes = np.asarray(instances.mesh)
        previous = self._matrices
        if previous is None or previous.shape != current.shape or not np.array_equal(self._meshes, meshes):
            self._matrices, self._meshes = current.astype(np.float64), meshes.copy()
            return none
        moved = np.flatnonzero(np.any(previous != current, axis=(1, 2)))
        if not len(moved):
            return none
        before = previous[moved].copy()
        previous[moved] = current[moved]
        return moved, before @ affine_inverses(previous[moved])

    def forget(self) -> None:
        self._matrices = None
        self._meshes = None


def row_ranges(object_ranges: np.ndarray, moved: np.ndarray, previous: np.ndarray | None = None) -> np.ndarray:
    """(first row, end row, entry, previous) of each moved instance (entry: its index in
    ``moved``; previous: its first row among last frame's captured rows, ``previous``, or -1
    where its move is its matrix's), sorted by first row: what the vertex stage looks a row
    up in."""
    ranges = np.asarray(object_ranges, np.int64)[moved]
    previous = np.full(len(moved), -1, np.int64) if previous is None else np.asarray(previous, np.int64)
    table = np.stack([ranges[:, 0], ranges[:, 0] + ranges[:, 1], np.arange(len(moved)), previous], axis=1)
    return table[np.argsort(table[:, 0], kind="stable")]


def with_deformed(moved: np.ndarray, matrices: np.ndarray, captured: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The moved instances and the ``captured`` deformed ones (previous_rows.PreviousRows:
    their rows of last frame hold their move, matrix and all), sorted, with their matrices
    (the identity for a deformed instance that did not move)."""
    if not len(captured):
        return moved, matrices
    entries = np.union1d(moved, captured)
    all_matrices = np.broadcast_to(np.eye(4), (len(entries), 4, 4)).copy()
    all_matrices[np.searchsorted(entries, moved)] = matrices
    return entries, all_matrices


class SurfaceMotionPass:
    """The moved instances' entries per primary pixel (module docstring): a compute pass over
    the primary view, in its step, right after the G-buffer."""

    name = "primary_raster"

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        # Compiled with the pass, not in the first frame that moves something (an input split
        # over several storage blocks compiles its own variant when it first comes).
        shader_loader.compute(ctx, "surface_motion/surface_motion.comp.glsl")
        self.moves = InstanceMoves()
        self._texture = None
        self._turn = None
        self._matrices = None
        self._buffers: dict[str, moderngl.Buffer] = {}

    def io(self, settings: RenderSettings) -> PassIO:
        return PassIO(reads=("scene", "delta", "world_triangles", "gbuffer"), writes=("surface_motion",))

    def run(self, frame: FrameContext) -> None:
        scene = frame.read("scene")
        moved, matrices = self.moves.moves(scene.geometry, frame.read("delta").unchanged)
        gpu = frame.read("world_triangles")
        previous = gpu.previous_rows
        moved, matrices = with_deformed(moved, matrices, previous.instances)
        if not len(moved) or not gpu.triangle_count or not FOLLOW_MOVES:
            frame.write("surface_motion", SurfaceMotion(False))
            return
        targets = frame.read("gbuffer")
        view = frame.view
        self._ensure((view.width, view.height))
        table = row_ranges(scene.geometry.object_ranges, moved, previous.offsets_of(moved))
        rows = self._buffer("rows", table.astype(np.int32))  # ivec4 rows
        split = input_split(gpu.triangle_count)
        program = shader_loader.compute(self.ctx, "surface_motion/surface_motion.comp.glsl",
                                        input_defines(split) or None)
        bind(program,
             storage={"MotionRows": rows, **input_storage(gpu.positions.buffer, split),
                      # unread unless a deformed instance is listed: any buffer stands in
                      "PreviousPositions": previous.positions.buffer if previous.rows > 0 else rows},
             textures={"u_depth": targets.depth, "u_normal_material": targets.normal_material,
                       "u_row": targets.row, "u_motion_matrices": self._matrix_texture(matrices)},
             images={"u_previous": Image(self._texture, read=False, write=True),
                     "u_turn": Image(self._turn, read=False, write=True)},
             uniforms={**view.uniforms(), "u_entries": len(table), "u_use_indices": 0})
        program.run(math.ceil(view.width / WORKGROUP), math.ceil(view.height / WORKGROUP), 1)
        if gl_context.debug_checks_enabled():
            gl_context.check_error("surface motion")
        self.ctx.memory_barrier(moderngl.TEXTURE_FETCH_BARRIER_BIT | moderngl.SHADER_IMAGE_ACCESS_BARRIER_BIT)
        frame.write("surface_motion", SurfaceMotion(True, self._texture, self._turn))

    def read(self) -> np.ndarray:
        """The last frame's motion image as (H, W, 4) float32 (last frame's point, entry + 1;
        zeros where nothing moved), row 0 at the bottom; empty before any frame moved
        something (tests, diagnostics)."""
        if self._texture is None:
            return np.zeros((0, 0, 4), np.float32)
        width, height = self._texture.size
        return np.frombuffer(self._texture.read(), np.float32).reshape(height, width, 4).copy()

    def read_turn(self) -> np.ndarray:
        """The last frame's normal rotations as (H, W, 4) float32 quaternions (tests)."""
        width, height = self._turn.size
        return np.frombuffer(self._turn.read(), np.float16).reshape(height, width, 4).astype(np.float32)

    def forget(self) -> None:
        """The next frame moves nothing (its last frame is not the denoiser's history)."""
        self.moves.forget()

    def _buffer(self, name: str, data: np.ndarray) -> moderngl.Buffer:
        """The storage buffer ``name`` holding ``data``, grown (never shrunk) as needed."""
        raw = data.tobytes()
        buffer = self._buffers.get(name)
        if buffer is None or buffer.size < len(raw):
            if buffer is not None:
                buffer.release()
            buffer = self._buffers[name] = self.ctx.buffer(reserve=max(len(raw), 256))
        buffer.write(raw)
        return buffer

    def _matrix_texture(self, matrices: np.ndarray):
        """``matrices`` (n, 4, 4) in the RGBA32F texture of SurfaceMotion.matrices, grown (never
        shrunk) to n rows."""
        columns = np.ascontiguousarray(np.transpose(matrices, (0, 2, 1)), np.float32)  # row e: 4 columns
        texture = self._matrices
        if texture is None or texture.size[1] < len(matrices):
            if texture is not None:
                texture.release()
            texture = self._matrices = self.ctx.texture((4, max(len(matrices), 16)), 4, dtype="f4")
            texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        texture.write(columns.tobytes(), viewport=(0, 0, 4, len(matrices)))
        return texture

    def _ensure(self, size: tuple[int, int]) -> None:
        if self._texture is not None and self._texture.size == size:
            return
        release_all([part for part in (self._texture, self._turn) if part is not None])
        self._texture = self.ctx.texture(size, 4, dtype="f4")
        self._turn = self.ctx.texture(size, 4, dtype="f2")
        for texture in (self._texture, self._turn):
            texture.filter = (moderngl.NEAREST, moderngl.NEAREST)

    def release(self) -> None:
        release_all([part for part in (self._texture, self._turn, self._matrices, *self._buffers.values())
                     if part is not None])
        self._texture = self._turn = self._matrices = None
        self._buffers = {}
