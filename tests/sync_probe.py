# SPDX-License-Identifier: GPL-3.0-or-later
"""Where a frame makes the host wait for the GPU: every read-back and ``ctx.finish()``, in
order, against the frame's pass boundaries.

A read of a GL object (``Buffer.read``, ``Texture.read``, ``Framebuffer.read`` and their
``_into``/``_chunks`` forms) returns only once the GPU has finished every command that
writes it, and ``Context.finish`` waits for all of them: each is a synchronisation point,
which between two passes drains the GPU mid-frame. ``SyncProbe`` wraps those methods of
moderngl's classes and the frame's ``FrameContext.running`` (the bracket around every
pass) and ``Renderer._read_back`` (the frame's end), and records one event per call.

Run as a script it lists the synchronisation points of a RASTER, HYBRID and FULL_BVH
frame of a small scene with a mirror sphere::

    .venv/bin/python tests/sync_probe.py
"""
from __future__ import annotations

import sys
import traceback
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import moderngl

# The read-back methods of each moderngl class that has them, and the context's finish.
READ_METHODS = ("read", "read_into", "read_chunks", "read_chunks_into")
READ_CLASSES = ("Buffer", "Texture", "Texture3D", "TextureArray", "TextureCube", "Framebuffer")
SYNC_METHODS = tuple((name, method) for name in READ_CLASSES for method in READ_METHODS
                     if hasattr(getattr(moderngl, name, None), method)) + (("Context", "finish"),)

_ENGINE = str(Path(__file__).resolve().parent.parent / "hybrid_engine")


@dataclass(frozen=True)
class Event:
    """One recorded call: ``kind`` "begin"/"end" of pass ``name``, or "sync" of ``name``
    (e.g. "Buffer.read") made while ``inside`` ran (a pass's name, "readback" or None
    between passes), from ``site`` (the innermost hybrid_engine frame: file:line function)."""

    kind: str
    name: str
    inside: str | None = None
    site: str = ""


class SyncProbe:
    """Records synchronisation points and pass boundaries while entered (module docstring)."""

    def __init__(self) -> None:
        self.events: list[Event] = []
        self._inside: list[str] = []

    # -- recording -------------------------------------------------------------------------------
    def _sync(self, name: str) -> None:
        self.events.append(Event("sync", name, self._inside[-1] if self._inside else None, _site()))

    def _enter(self, name: str) -> None:
        self._inside.append(name)
        self.events.append(Event("begin", name))

    def _leave(self, name: str) -> None:
        self._inside.pop()
        self.events.append(Event("end", name))

    def __enter__(self) -> "SyncProbe":
        from hybrid_engine.frame.renderer import Renderer
        from hybrid_engine.passes.frame_context import FrameContext

        self._saved: list[tuple[type, str, object]] = []
        for class_name, method in SYNC_METHODS:
            cls = getattr(moderngl, class_name)
            self._patch(cls, method, self._wrap(getattr(cls, method), f"{class_name}.{method}"))
        probe = self
        running = FrameContext.running

        @contextmanager
        def probed_running(frame, frame_pass) -> Iterator[None]:
            probe._enter(frame_pass.name)
            try:
                with running(frame, frame_pass):
                    yield
            finally:
                probe._leave(frame_pass.name)

        self._patch(FrameContext, "running", probed_running)
        read_back = Renderer._read_back

        def probed_read_back(renderer, *args, **kwargs):
            probe._enter("readback")
            try:
                return read_back(renderer, *args, **kwargs)
            finally:
                probe._leave("readback")

        self._patch(Renderer, "_read_back", probed_read_back)
        return self

    def __exit__(self, *exc) -> None:
        for cls, method, original in reversed(self._saved):
            setattr(cls, method, original)
        self._saved = []

    def _patch(self, cls: type, method: str, replacement) -> None:
        self._saved.append((cls, method, cls.__dict__[method]))
        setattr(cls, method, replacement)

    def _wrap(self, original, name: str):
        probe = self

        def wrapped(obj, *args, **kwargs):
            probe._sync(name)
            return original(obj, *args, **kwargs)

        wrapped.__name__ = getattr(original, "__name__", name)
        return wrapped

    # -- what was recorded -----------------------------------------------------------------------
    def syncs(self) -> list[Event]:
        return [event for event in self.events if event.kind == "sync"]

    def finishes(self) -> int:
        return sum(1 for event in self.syncs() if event.name == "Context.finish")

    def reads(self) -> list[Event]:
        return [event for event in self.syncs() if event.name != "Context.finish"]

    def passes_after(self, event: Event) -> list[str]:
        """The passes that began after ``event``: the work a read there drained the GPU
        before."""
        index = self.events.index(event)
        return [e.name for e in self.events[index + 1:] if e.kind == "begin"]

    def clear(self) -> None:
        self.events.clear()


def _site() -> str:
    """The innermost hybrid_engine frame of the current stack, as file:line function."""
    for frame in reversed(traceback.extract_stack()[:-3]):
        if frame.filename.startswith(_ENGINE):
            return f"{Path(frame.filename).relative_to(Path(_ENGINE).parent)}:{frame.lineno} {frame.name}"
    return "(outside hybrid_engine)"


def _report() -> None:
    """Print the synchronisation points of one frame of each mode (module docstring)."""
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
    from hybrid_engine import RenderSettings
    from hybrid_engine.frame.renderer import Renderer
    from test_renderer_syncs import CAMERA, SMALL, scene

    renderer = Renderer()
    timing = "--timing" in sys.argv
    for mode in ("RASTER", "HYBRID", "FULL_BVH"):
        settings = RenderSettings(mode=mode, **SMALL)
        renderer.render(scene(), CAMERA, settings, timing=timing)  # compile and allocate first
        with SyncProbe() as probe:
            result = renderer.render(scene(), CAMERA, settings, timing=timing)
            dict(result.counts)
        print(f"{mode}: {probe.finishes()} finish, {len(probe.reads())} reads (timing={timing})")
        for event in probe.syncs():
            print(f"  {event.name:22s} in {event.inside or '(between passes)':16s} {event.site}")
    renderer.release()


if __name__ == "__main__":
    _report()
