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

Counts stay on the GPU. The traversal kernel also counts the children each hit will spawn,
per workgroup; a one-workgroup scan (``wave_scan.comp.glsl``) turns those counts into stable
compaction offsets and writes the next queue's count and indirect dispatch arguments, from
which the next kernels are dispatched (``ComputeShader.run_indirect``), and the shading
kernel writes each child straight into its place in the next queue. The compaction keeps
the parents' order, so a pixel's rays stay together in every queue and one invocation per
pixel adds them in order: the image is the same on every run, without float atomics. The
counters of a wave (one depth) are summed per workgroup in shared memory, then added to the
tracer's CounterBuffer with one atomic per kind, in the megakernel's layout
(tracer.COUNTER_KINDS x COUNTER_DEPTHS).

Memory is what a GPU at 1080p can spare (wave_queue.glsl, wave_hit.glsl): a queued ray is
RAY_BYTES (position and direction to the bit, its weight in a shared exponent, its pixel;
its depth, reach and random key are recomputed, not stored), a hit HIT_BYTES, and each
record is rewritten in place as it is consumed (the hit's position over the ray's origin,
the light it brought over that), so two ray queues, an occlusion queue and the hits are all
the wave pipeline holds besides a vec4 per pixel. The queues start at one ray per pixel;
a wave that wants more gives the rays past the end the sky along their direction (as the
megakernel does with rays that find no room on its stack) and records on the GPU how many
it wanted. The statistics reader calls ``note_overflow`` (tracer.HybridTracer.read_stats),
which reads that record and grows the queues for the next frame; a final render asks
``overflows`` whether any of its samples overflowed (frame/antialias.py) and renders them
again.

PROVENANCE and the diagnostic views stay on the megakernel: they are per-pixel answers, not
ray traffic. With World Light Rays (``DIFFUSE_GATHER``) the occlusion queue carries the first
bounce's diffuse gather rays instead, traced closest-hit at any distance and shaded
(``wave_occlusion.comp.glsl``).
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
RAY_WORDS = 10  # a queued ray, 32-bit words (wave_queue.glsl RAY_WORDS)
OCCLUSION_WORDS = 9  # a queued occlusion ray (no blur)
HIT_WORDS = 10  # a hit (wave_hit.glsl HIT_WORDS; NODE_PROGRAM_HIT_WORDS more with NODE_PROGRAMS)
NODE_PROGRAM_HIT_WORDS = 8  # the triangle row, the tangent frame (6) and the ray cone's footprint
RAY_BYTES, OCCLUSION_BYTES, HIT_BYTES = 4 * RAY_WORDS, 4 * OCCLUSION_WORDS, 4 * HIT_WORDS
ACCUM_BYTES = 16  # a pixel's traced light and whether it takes it (wave_primary.comp.glsl)
MIN_CAPACITY = WAVE_LOCAL  # the fewest slots a queue is made with
GROWTH = 1.25  # an overflowed queue grows to what its wave wanted, with this much headroom
WAVE_MODES = ("HYBRID", "FULL_BVH")
SHADERS = {name: (f"trace/wave_{name}.comp.glsl", {})
           for name in ("primary", "traverse", "shade", "occlusion", "scan", "resolve", "composite")}
SHADERS["count_primary"] = ("trace/wave_primary.comp.glsl", {"WAVE_COUNT": 1})
_QUEUE_BARRIER = moderngl.SHADER_STORAGE_BARRIER_BIT | moderngl.COMMAND_BARRIER_BIT


def queue_bytes(pixels: int, rays: int, occlusions: int) -> int:
    """GPU bytes of the wave pipeline's buffers for a view of ``pixels`` with queues of
    ``rays`` and ``occlusions`` slots (two ray queues, the hits, the occlusion queue, a
    vec4 per pixel and the per-workgroup counts)."""
    blocks = math.ceil(max(pixels, rays) / WAVE_LOCAL)
    return (rays * (2 * RAY_BYTES + HIT_BYTES) + occlusions * OCCLUSION_BYTES + pixels * ACCUM_BYTES
            + blocks * 8)


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


# Whether the wave kernels link with a set of split-array defines (waves_fit), per set.
_fits: dict[tuple, bool] = {}


def waves_fit(ctx, defines: dict) -> bool:
    """Whether every wave kernel built with the trace's ``defines`` links. The traversal
    kernel binds the most storage blocks; an array split over several blocks (a scene past
    the driver's block size, gpu/dispatch.py) adds blocks and can take it over the driver's
    limit for a compute shader. Then the frame is traced by the per-pixel kernel, which binds
    fewer. Decided by building the kernels once per set of splits (the driver is the one
    that counts the blocks it keeps); a build that fails with the arrays unsplit is a real
    error and raised."""
    if not any(name.endswith("_BLOCKS") and int(value) > 1 for name, value in defines.items()):
        return True
    key = (id(ctx), tuple(sorted(defines.items())))
    if key not in _fits:
        try:
            for path, extra in SHADERS.values():
                shader_loader.compute(ctx, path, {**defines, **extra})
            _fits[key] = True
        except shader_loader.ShaderError:
            single = {name: (1 if name.endswith("_BLOCKS") else value) for name, value in defines.items()}
            for path, extra in SHADERS.values():
                shader_loader.compute(ctx, path, {**single, **extra})
            _fits[key] = False
    return _fits[key]


def wave_count(max_depth: int) -> int:
    """The bounce depths that trace rays: 1 .. max_depth, and the one more the depth limit
    traces (trace_ray.glsl push)."""
    depth = max(int(max_depth), 0)
    return depth + min(depth, 1)


class WaveTracer:
    """The wave pipeline's programs and queues (sized from what the frames wanted, kept
    across frames)."""

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.ray_capacity = 0  # slots of each ray queue (and of the hits)
        self.occlusion_capacity = 0  # slots of the occlusion queue
        self.pixels = 0
        self._hit_bytes = HIT_BYTES  # a hit record: NODE_PROGRAM_HIT_WORDS more with node programs
        self.overflows = 0  # frames noted (note_overflow) whose waves wanted more than the queues held
        self._request: tuple[int, int] | None = None  # (rays, occlusions) for _request_pixels
        self._request_pixels = 0
        self._buffers: dict[str, moderngl.Buffer] = {}
        self._state = None
        self._overflow_slot = 0
        self._wanted = ctx.buffer(reserve=16)  # WaveOverflow: the most any wave wanted since read
        self._wanted.write(bytes(16))

    @property
    def capacity(self) -> int:
        return self.ray_capacity

    def set_capacity(self, rays: int, occlusions: int) -> None:
        """Queues of ``rays`` and ``occlusions`` slots for the next frame of the current
        view size (scaled with the view when it changes); for tests and tools."""
        self._request = (max(int(rays), 1), max(int(occlusions), 1))
        self._request_pixels = self.pixels

    def _capacities(self, pixels: int) -> tuple[int, int]:
        """The queues' slots for a view of ``pixels``: one ray per pixel to start with, then
        what the frames wanted (note_overflow), scaled with the view."""
        if self._request is None:
            self._request = (max(pixels, MIN_CAPACITY),) * 2
        elif self._request_pixels != pixels and self._request_pixels > 0:
            self._request = tuple(max(MIN_CAPACITY, math.ceil(slots * pixels / self._request_pixels))
                                  for slots in self._request)
        self._request_pixels = pixels
        return self._request

    def _ensure(self, pixels: int, hit_bytes: int = HIT_BYTES) -> None:
        rays, occlusions = self._capacities(pixels)
        if (rays, occlusions, pixels, hit_bytes) == (self.ray_capacity, self.occlusion_capacity, self.pixels,
                                                     self._hit_bytes):
            return
        self._release_queues()
        self._hit_bytes = hit_bytes
        sizes = {"rays0": rays * RAY_BYTES, "rays1": rays * RAY_BYTES, "hits": rays * hit_bytes,
                 "occlusions": occlusions * OCCLUSION_BYTES, "accum": pixels * ACCUM_BYTES,
                 "block_sums": math.ceil(max(pixels, rays) / WAVE_LOCAL) * 8}
        self._buffers = {name: self.ctx.buffer(reserve=size) for name, size in sizes.items()}
        self.ray_capacity, self.occlusion_capacity, self.pixels = rays, occlusions, pixels

    def bytes_allocated(self) -> int:
        """GPU bytes the pipeline holds now (queues, per-pixel sums, counts, state)."""
        state = 0 if self._state is None else self._state.size
        return sum(buffer.size for buffer in self._buffers.values()) + state + self._wanted.size

    def _state_slots(self, waves: int) -> int:
        return 2 * (waves + 2) + 1  # rays and occlusions of waves 0 .. waves + 1, then overflow

    def run(self, inputs: TraceInputs, settings: RenderSettings) -> None:
        """Trace the frame's secondary rays in waves and add their light to the colour."""
        ctx = self.ctx
        width, height = inputs.size
        pixels = width * height
        self._ensure(pixels, HIT_BYTES + (4 * NODE_PROGRAM_HIT_WORDS if "NODE_PROGRAMS" in inputs.defines else 0))
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
        programs = {name: shader_loader.compute(ctx, path, {**inputs.defines, **defines})
                    for name, (path, defines) in SHADERS.items()}
        b = self._buffers
        capacities = {"u_ray_capacity": self.ray_capacity, "u_occlusion_capacity": self.occlusion_capacity}
        common = {**inputs.storage, "WaveState": self._state, "BlockSums": b["block_sums"],
                  "PixelAccum": b["accum"], "Hits": b["hits"], "WaveOverflow": self._wanted}

        def run_over(name: str, slot: int, storage: dict | None = None, uniforms: dict | None = None) -> None:
            prog = programs[name]
            bind(prog, *inputs.parts, storage={**common, **(storage or {})}, textures=inputs.textures,
                 images={}, uniforms={**inputs.uniforms, "u_wave_slot": slot, **(uniforms or {})})
            prog.run_indirect(self._state, slot * 16)
            ctx.memory_barrier(_QUEUE_BARRIER)

        def scan(parent_slot: int, depth: int) -> None:
            """The children counts of the parents in ``parent_slot`` into offsets and the
            dispatch arguments of the queues of wave depth + 1."""
            prog = programs["scan"]
            bind(prog, storage=common, uniforms={
                "u_wave_slot": parent_slot, "u_ray_slot": 2 * (depth + 1), "u_occlusion_slot": 2 * depth + 1,
                "u_overflow_slot": overflow_slot, "u_max_groups_x": max_x, **capacities})
            prog.run(1, 1, 1)
            ctx.memory_barrier(_QUEUE_BARRIER)

        def next_queues(depth: int) -> dict:
            return {"NextRays": b[f"rays{(depth + 1) % 2}"], "NextOcclusions": b["occlusions"]}

        ray_words = {"u_ray_words": RAY_WORDS}
        run_over("count_primary", 0)
        scan(0, 0)
        run_over("primary", 0, storage=next_queues(0), uniforms=capacities)
        for depth in range(1, waves + 1):
            rays, slot = b[f"rays{depth % 2}"], 2 * depth
            run_over("traverse", slot, storage={"Rays": rays}, uniforms={"u_wave_depth": depth, **ray_words})
            scan(slot, depth)
            run_over("shade", slot, storage={"Rays": rays, **next_queues(depth)},
                     uniforms={"u_wave_depth": depth, **ray_words, **capacities})
            occlusions = {"Rays": b["occlusions"]}
            run_over("occlusion", slot + 1, storage=occlusions, uniforms={"u_ray_words": OCCLUSION_WORDS})
            run_over("resolve", slot, storage={"Rays": rays}, uniforms=ray_words)
            run_over("resolve", slot + 1, storage=occlusions, uniforms={"u_ray_words": OCCLUSION_WORDS})
        composite = programs["composite"]
        bind(composite, storage={"PixelAccum": b["accum"]}, images={"u_color": inputs.images["u_color"]},
             uniforms={"u_size": (width, height)})
        composite.run(math.ceil(width / 8), math.ceil(height / 8), 1)
        ctx.memory_barrier(moderngl.SHADER_STORAGE_BARRIER_BIT | moderngl.SHADER_IMAGE_ACCESS_BARRIER_BIT)
        self._overflow_slot = overflow_slot
        if gl_context.debug_checks_enabled():
            gl_context.check_error(f"{settings.trace_mode} trace in waves")

    def overflowed(self) -> tuple[int, int]:
        """The most rays and occlusion rays any wave of the last frame wanted, beyond the
        capacities where rays took the sky instead (a read-back: for tests and reports)."""
        state = np.frombuffer(self._state.read(), np.uint32).reshape(-1, 4)
        return int(state[self._overflow_slot, 0]), int(state[self._overflow_slot, 1])

    def deposit_statistics(self, statistics) -> None:
        """The most rays any wave of this frame wanted, into the frame's statistics
        (gpu/statistics.py):
        when a caller reads the frame's counts (the viewport's header, a report), a queue
        that was too short grows for the frames after, and nothing waits in the frame."""
        statistics.deposit(self._state, 2, self._observe_wanted, offset=16 * self._overflow_slot)

    def _observe_wanted(self, words: np.ndarray) -> dict[str, int]:
        rays, occlusions = int(words[0]), int(words[1])
        self._grow_for(rays, occlusions)
        return {"wave_rays_wanted": rays, "wave_occlusion_rays_wanted": occlusions}

    def _grow_for(self, rays: int, occlusions: int) -> bool:
        """Ask for queues that hold ``rays`` and ``occlusions`` next frame when the present
        ones do not (an overflow)."""
        # The queues the next frame gets: those asked for already, if larger (an overflow read
        # twice, from the frame's statistics and again, is one overflow).
        ray_slots, occlusion_slots = self.ray_capacity, self.occlusion_capacity
        if self._request is not None and self._request_pixels == self.pixels:
            ray_slots, occlusion_slots = max(ray_slots, self._request[0]), max(occlusion_slots, self._request[1])
        if rays <= ray_slots and occlusions <= occlusion_slots:
            return False
        self._request = (_grown(ray_slots, rays), _grown(occlusion_slots, occlusions))
        self._request_pixels = self.pixels
        self.overflows += 1
        return True

    def note_overflow(self) -> bool:
        """Read (16 bytes) and clear the most rays any wave wanted since the last call; if a
        queue held fewer, count an overflow and grow it for the next frame. Called by the
        statistics reader: the frame itself never waits for it."""
        wanted = np.frombuffer(self._wanted.read(), np.uint32)
        self._wanted.write(bytes(16))
        return self._grow_for(int(wanted[0]), int(wanted[1]))

    def release(self) -> None:
        self._release_queues()
        if self._state is not None:
            self._state.release()
            self._state = None
        self._wanted.release()

    def _release_queues(self) -> None:
        for buffer in self._buffers.values():
            buffer.release()
        self._buffers = {}
        self.ray_capacity = self.occlusion_capacity = self.pixels = 0


def _grown(capacity: int, wanted: int) -> int:
    """A queue's slots once a wave wanted ``wanted`` of its ``capacity``: what it wanted and
    some headroom (the next frame's waves rarely want exactly as many), in whole workgroups."""
    if wanted <= capacity:
        return capacity
    return math.ceil(wanted * GROWTH / WAVE_LOCAL) * WAVE_LOCAL
