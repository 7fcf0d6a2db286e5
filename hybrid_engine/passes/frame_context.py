# SPDX-License-Identifier: GPL-3.0-or-later
"""The one object every pass of a frame takes, and what each pass says it reads and writes.

As Falcor's render passes declare their inputs and outputs (``RenderPass::reflect``) and take
one ``RenderData``, a pass here declares a ``PassIO`` (the named resources it reads and
writes, which may depend on the settings: FULL_BVH's LBVH reads no near-cube cull) and runs
on one ``FrameContext``: the frame's inputs (the scene, the camera, the settings, the raster
view, the film outputs asked for, the sample index), its counts (those the host knows, in
``counts``; the GPU's counters are deposited in ``statistics``, gpu/statistics.py, and never
read while the frame runs), and the resources earlier passes wrote, by name. No pass constructs another or reaches into another's fields: what it
needs is a resource of the frame.

The declarations are checked twice:

* before a frame runs, ``check_order`` walks the renderer's passes in order and fails with a
  ``PassGraphError`` naming the pass and the resource when a pass reads what no earlier
  pass writes (a setup error, not a black image at run time);
* while a pass runs, the context lets it read and write only what it declared, so a
  declaration cannot drift from the code.
"""
from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass
from typing import Iterator, Protocol, Sequence

import numpy as np

from ..gpu.statistics import FrameStatistics
# What a frame starts with, before any pass ran.
FRAME_INPUTS = ("scene_data", "camera", "settings", "view", "outputs")


class PassGraphError(RuntimeError):
    """Passes in an order where one reads a resource no earlier pass writes, or a pass that
    touched a resource it did not declare."""


@dataclass(frozen=True)
class PassIO:
    """The named resources a pass reads and writes in one configuration. ``optional``: what
    it reads where an earlier pass wrote it and goes without otherwise (``read_optional``:
    the denoiser's motion, which only a denoised frame makes)."""

    reads: tuple[str, ...] = ()
    writes: tuple[str, ...] = ()
    optional: tuple[str, ...] = ()


class FramePass(Protocol):
    """A step of the frame: ``name`` is its row in timing reports (several passes may share
    one: the ambient occlusion and the deferred shading are both ``shade``)."""

    name: str

    def io(self, settings) -> PassIO:
        """What the pass reads and writes under ``settings``."""

    def run(self, frame: "FrameContext") -> None:
        """Do the pass's work for ``frame``."""


def check_order(passes: Sequence[FramePass], settings, inputs: Sequence[str] = FRAME_INPUTS,
                final_reads: Sequence[str] = ()) -> None:
    """Fail with a PassGraphError when a pass reads a resource that neither the frame's
    ``inputs`` nor an earlier pass provides, or the frame's end reads (``final_reads``: what
    the renderer reads back) one that nobody wrote."""
    available = {name: "the frame's inputs" for name in inputs}
    for index, frame_pass in enumerate(passes):
        io = frame_pass.io(settings)
        for resource in io.reads:
            if resource not in available:
                earlier = ", ".join(p.name for p in passes[:index]) or "none"
                raise PassGraphError(
                    f"pass {frame_pass.name!r} ({type(frame_pass).__name__}) reads {resource!r}, which no earlier "
                    f"pass writes in {settings.mode} mode (earlier passes: {earlier})")
        for resource in io.writes:
            available.setdefault(resource, frame_pass.name)
    for resource in final_reads:
        if resource not in available:
            raise PassGraphError(f"the frame reads back {resource!r}, which no pass writes in {settings.mode} mode")


class FrameContext:
    """One frame: its inputs, its counts and the resources its passes write (module
    docstring). ``keep_world``: this frame sees the last frame's geometry from the same eye,
    so the cube map, the near-cube cull and the BVH of the last frame stand. ``denoise``: the
    frame's ambient estimate is filtered (passes/denoise/) before the shading reads it.
    ``accumulate``: the frame's colour joins the film's mean of the view's samples (the
    denoiser then writes its share of that mean)."""

    def __init__(self, ctx, *, scene_data, camera, settings, view, outputs, sample: int = 0,
                 keep_world: bool = False, denoise: bool = False, accumulate: bool = False) -> None:
        self.ctx = ctx
        self.camera = camera
        # The lens centre: the centre of the near cube and of the cube map (paper §3.2).
        self.center = np.asarray(camera.center, np.float64)
        self.settings = settings
        self.view = view
        self.outputs = outputs
        self.sample = int(sample)
        self.keep_world = bool(keep_world)
        self.denoise = bool(denoise)
        self.accumulate = bool(accumulate)
        self.counts: dict[str, int] = {}
        self.statistics = FrameStatistics()
        self._resources: dict[str, object] = {"scene_data": scene_data, "camera": camera, "settings": settings,
                                              "view": view, "outputs": outputs}
        self._running: tuple[str, PassIO] | None = None

    # -- resources -----------------------------------------------------------------------------
    def read(self, name: str):
        """The resource ``name``, which the running pass must have declared it reads (or
        writes: a pass may read back what it wrote)."""
        self._check("read", name)
        if name not in self._resources:
            raise PassGraphError(f"{self._who()} reads {name!r} before any pass wrote it")
        return self._resources[name]

    def read_optional(self, name: str):
        """The resource ``name`` if an earlier pass wrote it, else None; the running pass must
        declare it among its optional reads."""
        if self._running is not None and name not in self._running[1].optional:
            raise PassGraphError(f"{self._who()} reads {name!r} as optional, which it does not declare "
                                 f"(optional {list(self._running[1].optional)})")
        return self._resources.get(name)

    def write(self, name: str, value) -> None:
        """Set the resource ``name``, which the running pass must have declared it writes."""
        self._check("write", name)
        self._resources[name] = value

    def has(self, name: str) -> bool:
        return name in self._resources

    def provide(self, resources: dict[str, object]) -> None:
        """Resources the renderer hands in from outside the passes (a kept cube map and BVH)."""
        self._resources.update(resources)

    def resource(self, name: str):
        """A resource for the renderer itself (between passes), unchecked."""
        return self._resources[name]

    @contextmanager
    def running(self, frame_pass: FramePass) -> Iterator[None]:
        """Run ``frame_pass`` with its declarations enforced."""
        self._running = (frame_pass.name, frame_pass.io(self.settings))
        try:
            yield
        finally:
            self._running = None

    def _check(self, verb: str, name: str) -> None:
        if self._running is None:
            return
        _, io = self._running
        allowed = io.reads + io.writes if verb == "read" else io.writes
        if name not in allowed:
            raise PassGraphError(f"{self._who()} {verb}s {name!r}, which it does not declare "
                                 f"(reads {list(io.reads)}, writes {list(io.writes)})")

    def _who(self) -> str:
        return f"pass {self._running[0]!r}" if self._running is not None else "the renderer"
