# SPDX-License-Identifier: GPL-3.0-or-later
"""A probe kernel that evaluates the emitters' next-event estimate at given points: the
test-side entry to ``emitter_irradiance`` (gpu_shaders/include/emitter_light.glsl), which the
diffuse gather calls inside its own kernel (tests/shaders/emitter_probe.comp.glsl). The scene
goes through the frame's own upload, instance transform and LBVH build (over all of it, as
FULL_BVH traces)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from hybrid_engine.gpu import shader_loader
from hybrid_engine.gpu.bindings import bind, split_storage
from hybrid_engine.gpu.render_targets import sampled_depth_texture
from hybrid_engine.gpu.dispatch import dispatch, split_blocks, storage_barrier
from hybrid_engine.passes.emitters.emitter_links import EmitterLinks
from hybrid_engine.passes.emitters.emitter_table import EmitterTable
from hybrid_engine.passes.lbvh.lbvh import LBVHBuilder
from hybrid_engine.passes.scene_upload.scene_buffers import GPUScene
from hybrid_engine.passes.trace.tracer import COUNTER_WORDS, NORMAL_BYTES, TRACE_MODES
from hybrid_engine.scene.data import SceneData

PROBE_SHADER = Path(__file__).resolve().parent / "shaders" / "emitter_probe.comp.glsl"
LOCAL_SIZE = 64
# Samples one invocation draws (the probe spreads a point's samples over invocations).
CHUNK = 256


class EmitterProbe:
    """``scene`` on the GPU with its BVH and emitter table, and the probe kernel over them."""

    def __init__(self, ctx, scene: SceneData, scan_family: str | None = None) -> None:
        self.ctx = ctx
        self.world = GPUScene(ctx)
        self.scene, _ = self.world.upload(scene)
        self.world.transform()
        self.builder = LBVHBuilder(ctx)
        self.bvh = self.builder.build(self.world.positions.buffer, self.world.triangle_count)
        self.table = EmitterTable(ctx, scan_family)
        self.table.update(self.scene, self.world)
        self.links = EmitterLinks(ctx)  # the frame's lighting owns it (passes/lighting/resources.py)
        self.links.update(self.scene.materials)
        self._counters = ctx.buffer(reserve=COUNTER_WORDS * 4)
        # The lamps' and the sky's blocks the shared code declares; the estimate reads none.
        self._unused = ctx.buffer(reserve=1 << 16)
        self._dummies = [sampled_depth_texture(ctx, (1, 1)), ctx.texture((1, 1), 4, dtype="f4"),
                         ctx.texture((1, 1), 2, dtype="f4")]

    def _bind(self, defines: dict, storage: dict, uniforms: dict) -> object:
        split = split_blocks(self.world.triangle_count, NORMAL_BYTES, "probe normals")
        prog = shader_loader.compute(self.ctx, PROBE_SHADER, {
            **self.bvh.traversal_defines(), **split.defines("TRI_NORMAL_BLOCKS", "TRI_NORMAL_BLOCK_SIZE"),
            **self.links.defines, **defines})
        depth, rgba, rg = self._dummies
        bind(prog, self.world.bindings(), self.table.bindings(), self.links.bindings(),
             storage={**self.bvh.storage(), **split_storage("TriangleNormals", self.world.normals.buffer, split),
                      "CounterBuffer": self._counters, "TriangleUVBuffer": self.world.uv_rows.buffer,
                      "SkyIrradiance": self._unused, "LightBuffer": self._unused,
                      "ShadowSlotBuffer": self._unused, **storage},
             textures={"u_cube_depth": depth, "u_cube_normal_material": rgba, "u_cube_surface": rgba,
                       "u_cube_geometric": rg, "u_cube_hiz": rg},
             uniforms={"u_mode": TRACE_MODES["FULL_BVH"], **uniforms})
        return prog

    def irradiance(self, points, normals, samples: int, seed: int = 1,
                   receiver_set: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """The mean of ``samples`` estimates (rounded up to whole chunks) at each point (N, 3)
        and the shadow rays traced for each point (N,). ``receiver_set``: the points' light
        linking set (the emitters' linking is read only when some emitter is linked)."""
        points = np.asarray(points, np.float32).reshape(-1, 3)
        normals = np.broadcast_to(np.asarray(normals, np.float32).reshape(-1, 3), points.shape)
        count = len(points)
        chunks = -(-int(samples) // CHUNK)
        pad = np.zeros((count, 1), np.float32)
        bufs = [self.ctx.buffer(np.hstack([points, pad]).tobytes()),
                self.ctx.buffer(np.hstack([normals, pad]).tobytes()),
                self.ctx.buffer(reserve=count * chunks * 16)]
        try:
            prog = self._bind({}, {"Points": bufs[0], "Normals": bufs[1], "Results": bufs[2]},
                              {"u_count": count * chunks, "u_samples": CHUNK, "u_chunks": chunks,
                               "u_seed": int(seed), "u_receiver_set": int(receiver_set)})
            dispatch(prog, count * chunks, LOCAL_SIZE)
            storage_barrier(self.ctx)
            out = np.frombuffer(bufs[2].read(), np.float32).reshape(count, chunks, 4)
        finally:
            for buf in bufs:
                buf.release()
        sums = out.astype(np.float64).sum(axis=1)
        return sums[:, :3] / (chunks * CHUNK), sums[:, 3].astype(np.int64)

    def picks(self, draws: int, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """``draws`` emitter picks by the table's CDF: (index, probability) each (-1, 0 when
        nothing emits)."""
        out_buf = self.ctx.buffer(reserve=draws * 8)
        try:
            prog = self._bind({"PICK_PROBE": 1}, {"Picks": out_buf}, {"u_count": draws, "u_seed": int(seed)})
            dispatch(prog, draws, LOCAL_SIZE)
            storage_barrier(self.ctx)
            out = np.frombuffer(out_buf.read(), np.float32).reshape(draws, 2)
        finally:
            out_buf.release()
        return out[:, 0].astype(np.int64), out[:, 1].astype(np.float64)

    def release(self) -> None:
        for obj in (self._counters, self._unused, *self._dummies):
            obj.release()
        self.table.release()
        self.links.release()
        self.builder.release()
        self.world.release()
