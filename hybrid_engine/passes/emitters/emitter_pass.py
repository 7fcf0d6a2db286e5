# SPDX-License-Identifier: GPL-3.0-or-later
"""The frame's emitter table: right after the instance transform, so that the table follows
the world-space triangles of this frame (a moving lamp moves its light), and before any pass
that gathers light reads it (the ``emitters`` resource: an ``EmitterTable``, whose
``bindings()`` a kernel compiled with ``EMITTER_LIGHT`` binds).

Its timing row is the transform's step (``instance_transform``): the table is a few
dispatches over the emissive triangles when the transform wrote rows or an emission changed,
and none at all when nothing emits or nothing changed."""
from __future__ import annotations

from ...scene.settings import RenderSettings
from ..frame_context import FrameContext, PassIO
from .emitter_table import EmitterTable


class EmitterTablePass:
    """Updates one ``EmitterTable``, kept across frames, and hands it to the frame."""

    name = "instance_transform"

    def __init__(self, ctx) -> None:
        self.table = EmitterTable(ctx)

    def io(self, settings: RenderSettings) -> PassIO:
        return PassIO(reads=("scene", "world_triangles", "delta"), writes=("emitters",))

    def run(self, frame: FrameContext) -> None:
        self.table.update(frame.read("scene"), frame.read("world_triangles"),
                          rows_unchanged=frame.read("delta").unchanged)
        frame.write("emitters", self.table)

    def release(self) -> None:
        self.table.release()
