# SPDX-License-Identifier: GPL-3.0-or-later
"""Light and shadow linking of emissive objects, as Cycles links its mesh lights.

An emissive object with a receiver collection lights only its receivers, and one with a
blocker collection is shadowed only by its blockers (scene/light_linking.py: the sets are
Blender's, resolved over the lamps and the emissive objects together). The emitter table
samples triangles, and a triangle knows its material row, so the masks ride on the rows
(``MaterialTable.emitter_light_mask`` / ``emitter_shadow_mask``: the adapter gives a linked
object its own copies of its rows). This module uploads them, one ``uvec4`` per row (light
mask low and high word, shadow mask low and high word), as the storage block
``EmitterLinks`` that ``gpu_shaders/include/emitter_links.glsl`` reads under
``EMITTER_LINKING``.

A scene whose emitters are not linked uploads nothing and defines nothing, so its kernels
are the ones it compiled before, and its image the same bit for bit.
"""
from __future__ import annotations

import numpy as np

from ...gpu.bindings import Bindings
from ...gpu.dispatch import GrowBuffer
from ...scene.data import MaterialTable
from ...scene.light_linking import emission_linked, mask_words


def link_rows(materials: MaterialTable) -> np.ndarray:
    """(M, 4) uint32: each row's emitter light mask and shadow mask, low word first."""
    return np.concatenate([mask_words(materials.emitter_light_mask),
                           mask_words(materials.emitter_shadow_mask)], axis=1)


class EmitterLinks:
    """The ``EmitterLinks`` block of a frame, kept across frames and rewritten only when the
    masks change."""

    def __init__(self, ctx) -> None:
        self._buffer = GrowBuffer(ctx, "emitter links")
        self._uploaded: bytes | None = None
        self.linked = False

    def update(self, materials: MaterialTable) -> None:
        """This frame's masks; ``linked`` says whether any emissive row is linked."""
        self.linked = emission_linked(materials)
        if not self.linked:
            self._uploaded = None
            return
        rows = np.ascontiguousarray(link_rows(materials)).tobytes()
        if rows != self._uploaded:
            self._buffer.upload(rows)
            self._uploaded = rows

    @property
    def defines(self) -> dict:
        """``EMITTER_LINKING`` only when some emitter is linked."""
        return {"EMITTER_LINKING": 1} if self.linked else {}

    def bindings(self) -> Bindings:
        """The ``EmitterLinks`` block while linked, else nothing."""
        return Bindings(storage={"EmitterLinks": self._buffer.buffer}) if self.linked else Bindings()

    def release(self) -> None:
        self._buffer.release()
        self._uploaded = None
        self.linked = False
