# SPDX-License-Identifier: GPL-3.0-or-later
"""The tracer in waves: the GPU-shaped variant of the ``trace`` kernel (gpu/variants.py).

The megakernel (``gpu_shaders/trace/hybrid_trace.comp.glsl``) runs, per pixel, a
depth-first stack of rays: on a CPU driver that is the fast shape (few dispatches, no
barriers), but on a GPU the pixels without a mirror idle in their warp while their
neighbours loop, and every ray's counters hit the same few addresses. Here the same rays
are traced breadth-first, one wave per bounce depth (paper §3.4's rays, in the order of
Laine, Karras and Aila's "Megakernels Considered Harmful", 2013):

* wave 0 compacts the specular pixels of the G-buffer into the first ray queue;
* per depth, a traversal kernel finds each ray's closest hit (BVH, cube-map march), a
  shading kernel apart from it shades the hits and spawns the next wave's rays, an any-hit
  kernel traces the occlusion rays, and a resolve kernel adds the wave's light to its pixels;
* a composite kernel adds each pixel's traced light to its deferred-shaded colour.

Tracing and shading are the megakernel's own functions (``gpu_shaders/include/trace_ray.glsl``),
so the two variants give the same rays, counters and image up to the order of the sums.

Counts stay on the GPU: a one-workgroup scan (``wave_scan.comp.glsl``) turns the children
counts of a wave into stable compaction offsets and writes the next queue's count and
indirect dispatch arguments, from which the next kernels are dispatched
(``ComputeShader.run_indirect``). The compaction keeps the parents' order, so a pixel's rays
stay together in every queue and one invocation per pixel adds them in order: the image is
the same on every run, without float atomics. The counters of a wave (one depth) are summed
per workgroup in shared memory, then added to the tracer's CounterBuffer with one atomic per
kind, in the megakernel's layout (tracer.COUNTER_KINDS x COUNTER_DEPTHS).

A queue holds ``RAYS_PER_PIXEL`` rays per pixel (at least ``MIN_CAPACITY``): a wave that
would hold more gives the rays past it the sky along their direction, as the megakernel
does with rays that find no room on its stack; ``overflowed`` reports the most any wave
wanted, read only on request.

PROVENANCE, the diagnostic views and the World's light by rays (``WorldLightRays``) stay on
the megakernel: they are per-pixel answers, not ray traffic.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import moderngl
import numpy as np

from ...gpu import gl_context, shader_loader, variants
from ...gpu.bindings import bind
from ...gpu.dispatch import max_workgroups_x
from ...scene.settings import RenderSettings
from .diagnostic_views import is_diagnostic

WAVE_LOCAL = 64  # the queue kernels' workgroup (wave_queue.glsl WAVE_LOCAL)
RAY_BYTES = 64  # WaveRay, std430
HIT_BYTES = 64  # WaveHit, std430
CHILDREN_PER_PARENT = 3  # reflection, refraction, occlusion
RAYS_PER_PIXEL = 4
MIN_CAPACITY = 1 << 16
WAVE_MODES = ("HYBRID", "FULL_BVH")
SHADERS = {name: f"trace/wave_{name}.comp.glsl"
           for name in ("primary", "traverse", "shade", "occlusion", "scan", "scatter", "resolve", "composite")}
_QUEUE_BARRIER = moderngl.SHADER_STORAGE_BARRIER_BIT | moderngl.COMMAND_BARRIER_BIT


@dataclass
class TraceInputs:
    """What a trace kernel binds (HybridTracer.inputs): defines, the owners' bindings, the
    tracer's storage, textures, images and uniforms, and the view's size."""

    defines: dict
    parts: tuple
    storage: dict
    textures: dict
    images: dict
    uniforms: dict
    size: tuple[int, int]


def uses_waves(settings: RenderSettings, renderer: str | None = None, override: str | None = None) -> bool:
    """Whether the ``trace`` pass of ``settings`` runs in waves: the GPU-shaped ``trace``
    kernel, in a mode that traces rays (not PROVENANCE) and not a diagnostic view."""
    return (variants.choose("trace", renderer, override) == "gpu" and settings.trace_mode in WAVE_MODES
            and not is_diagnostic(settings))


def wave_count(max_depth: int) -> int:
    """The bounce depths that trace rays: 1 .. max_depth, and the one more the depth limit
    traces (trace_ray.glsl push)."""
    depth = max(int(max_depth), 0)
    return depth + min(depth, 1)


class WaveTracer:
    """The wave pipeline's programs and queues (grown with the view, kept across frames)."""

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.capacity = 0
        self.pixels = 0
        self._buffers: dict[str, moderngl.Buffer] = {}
        self._state = None
        self._overflow_slot = 0

    def _ensure(self, pixels: int) -> None:
        capacity = max(pixels * RAYS_PER_PIXEL, MIN_CAPACITY)
        if capacity == self.capacity and pixels == self.pixels:
            return
        self._release_queues()
        blocks = math.ceil(capacity / WAVE_LOCAL)
        sizes = {"rays0": capacity * RAY_BYTES, "rays1": capacity * RAY_BYTES,
                 "occlusions": capacity * RAY_BYTES, "hits": capacity * HIT_BYTES,
                 "children": CHILDREN_PER_PARENT * capacity * RAY_BYTES, "masks": capacity * 4,
                 "contributions": capacity * 16, "occlusion_contributions": capacity * 16,
                 "block_sums": blocks * 8, "accum": pixels * 16}
        self._buffers = {name: self.ctx.buffer(reserve=size) for name, size in sizes.items()}
        self.capacity, self.pixels = capacity, pixels

    def _state_slots(self, waves: int) -> int:
        return 2 * (waves + 2) + 1  # rays and occlusions of waves 0 .. waves + 1, then overflow

    def run(self, inputs: TraceInputs, settings: RenderSettings) -> None:
        """Trace the frame's secondary rays in waves and add their light to the colour."""
        ctx = self.ctx
        width, height = inputs.size
        pixels = width * height
        self._ensure(pixels)
        waves = wave_count(settings.max_depth)
        slots = self._state_slots(waves)
        overflow_slot = slots - 1
        max_x = max_workgroups_x()
        state = np.zeros((slots, 4), np.uint32)
        groups = math.ceil(pixels / WAVE_LOCAL)
        state[0] = (min(groups, max_x), math.ceil(groups / min(groups, max_x)), 1, pixels)
        if self._state is None or self._state.size < state.nbytes:
            if self._state is not None:
                self._state.release()
            self._state = ctx.buffer(reserve=max(state.nbytes, 1024))
        self._state.write(state.tobytes())
        programs = {name: shader_loader.compute(ctx, path, inputs.defines) for name, path in SHADERS.items()}
        b = self._buffers
        common = {**inputs.storage, "WaveState": self._state, "Children": b["children"], "ChildMasks": b["masks"],
                  "BlockSums": b["block_sums"], "PixelAccum": b["accum"]}

        def run_over(name: str, slot: int, storage: dict | None = None, uniforms: dict | None = None,
                     images: dict | None = None) -> None:
            prog = programs[name]
            bind(prog, *inputs.parts, storage={**common, **(storage or {})}, textures=inputs.textures,
                 images=images or {}, uniforms={**inputs.uniforms, "u_wave_slot": slot, **(uniforms or {})})
            prog.run_indirect(self._state, slot * 16)
            ctx.memory_barrier(_QUEUE_BARRIER)

        def compact(parent_slot: int, depth: int, contributions) -> None:
            """The children of the parents in ``parent_slot`` into the queues of wave depth + 1."""
            scan = programs["scan"]
            bind(scan, storage=common, uniforms={
                "u_wave_slot": parent_slot, "u_ray_slot": 2 * (depth + 1), "u_occlusion_slot": 2 * depth + 1,
                "u_overflow_slot": overflow_slot, "u_capacity": self.capacity, "u_max_groups_x": max_x})
            scan.run(1, 1, 1)
            ctx.memory_barrier(_QUEUE_BARRIER)
            run_over("scatter", parent_slot, storage={
                "NextRays": b[f"rays{(depth + 1) % 2}"], "NextOcclusions": b["occlusions"],
                "Contributions": contributions},
                uniforms={"u_capacity": self.capacity, "u_first_wave": int(depth == 0)})

        run_over("primary", 0)
        compact(0, 0, b["contributions"])
        for depth in range(1, waves + 1):
            rays, slot = b[f"rays{depth % 2}"], 2 * depth
            run_over("traverse", slot, storage={"Rays": rays, "Hits": b["hits"]}, uniforms={"u_wave_depth": depth})
            run_over("shade", slot, storage={"Rays": rays, "Hits": b["hits"], "Contributions": b["contributions"]})
            compact(slot, depth, b["contributions"])
            run_over("occlusion", slot + 1, storage={"Rays": b["occlusions"],
                                                      "Contributions": b["occlusion_contributions"]})
            run_over("resolve", slot, storage={"Rays": rays, "Contributions": b["contributions"]})
            run_over("resolve", slot + 1, storage={"Rays": b["occlusions"],
                                                    "Contributions": b["occlusion_contributions"]})
        composite = programs["composite"]
        bind(composite, storage={"PixelAccum": b["accum"]}, images={"u_color": inputs.images["u_color"]},
             uniforms={"u_size": (width, height)})
        composite.run(math.ceil(width / 8), math.ceil(height / 8), 1)
        ctx.memory_barrier(moderngl.SHADER_STORAGE_BARRIER_BIT | moderngl.SHADER_IMAGE_ACCESS_BARRIER_BIT)
        self._overflow_slot = overflow_slot
        if gl_context.debug_checks_enabled():
            gl_context.check_error(f"{settings.trace_mode} trace in waves")

    def overflowed(self) -> tuple[int, int]:
        """The most rays and occlusion rays any wave of the last frame wanted, beyond
        ``capacity`` where rays took the sky instead (a read-back: for tests and reports)."""
        state = np.frombuffer(self._state.read(), np.uint32).reshape(-1, 4)
        return int(state[self._overflow_slot, 0]), int(state[self._overflow_slot, 1])

    def release(self) -> None:
        self._release_queues()
        if self._state is not None:
            self._state.release()
            self._state = None

    def _release_queues(self) -> None:
        for buffer in self._buffers.values():
            buffer.release()
        self._buffers = {}
        self.capacity = self.pixels = 0
