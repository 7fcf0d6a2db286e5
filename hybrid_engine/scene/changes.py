# SPDX-License-Identifier: GPL-3.0-or-later
"""Which triangles changed since the last frame, so that only they are re-uploaded.

The paper's scenes live on the GPU; ours arrive from the host every frame (Blender's
evaluated meshes, or a builder's arrays) as world-space triangle soup. Packing and writing
all of it costs hundreds of milliseconds per million triangles on a 2-core machine, while an
animation frame typically moves a few objects. ``GeometryTracker`` keeps a host copy of the
last geometry uploaded and compares the new one with it bit for bit (no identity or version
trust: a caller may edit its arrays in place), giving the ranges of triangles to re-upload.
A comparison reads every triangle once (tens of milliseconds per million) but writes nothing
when nothing moved. Layout changes (triangle count, object ranges, UVs appearing) force a
full upload.

An object whose first triangle changed is taken whole without reading the rest of it: in an
animation that is an object that moved or deformed, nearly all of whose triangles changed,
and comparing them row by row costs more than writing them. The ranges then hold some unchanged rows of such an object, which costs only a few megabytes of
writing; they never hold a row of an object that did not change, which the shadow layers
rely on (shadow_cache.py).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .data import Geometry, GeometryEdit
from .instances import InstancedGeometry

# Changed triangles closer than this are uploaded as one range: one buffer write per range
# costs more than a few kilobytes of unchanged data.
MERGE_GAP_TRIANGLES = 2048


@dataclass(frozen=True)
class GeometryDelta:
    """What changed between two frames' geometry.

    ``full``: upload everything (first frame, or the layout changed). Otherwise ``ranges``
    lists the (first, count) triangle ranges to re-upload, empty when nothing changed.
    """

    full: bool
    ranges: tuple[tuple[int, int], ...] = field(default_factory=tuple)
    changed_triangles: int = 0
    # The tracker's update count: a consumer may apply a delta incrementally only when it
    # applied the previous one (sequence - 1); any other consumer needs a full upload.
    sequence: int = 0

    @property
    def unchanged(self) -> bool:
        return not self.full and not self.ranges

    @classmethod
    def everything(cls, count: int, sequence: int = 0) -> "GeometryDelta":
        return cls(full=True, ranges=((0, int(count)),) if count else (), changed_triangles=int(count),
                   sequence=sequence)


def _rows_as_words(array: np.ndarray, n: int) -> np.ndarray:
    """(n, k) uint32 view of an array with n rows (bitwise comparison: NaN equals itself)."""
    return np.ascontiguousarray(array).view(np.uint32).reshape(n, -1)


def changed_rows(old: np.ndarray, new: np.ndarray) -> np.ndarray:
    """Bool per row: does row i differ bit for bit.

    ``(a != b).any(axis=1)`` reduces over rows of 9 words one element at a time; OR-ing the
    per-word flags eight bytes at a time (as uint64) touches far fewer elements."""
    n = len(new)
    if n == 0:
        return np.zeros(0, bool)
    differs = _rows_as_words(old, n) != _rows_as_words(new, n)  # (n, k)
    k = differs.shape[1]
    if k < 8:
        # Column by column: any(axis=1) over a few words per row is much slower.
        out = differs[:, 0].copy()
        for column in range(1, k):
            out |= differs[:, column]
        return out
    differs = differs.view(np.uint8)
    out = np.zeros(n, np.uint64)
    for start in range(0, k - k % 8, 8):
        out |= differs[:, start:start + 8].view(np.uint64)[:, 0]
    if k % 8:
        out |= differs[:, k - k % 8:].any(axis=1)
    return out != 0


def range_mask(ranges: np.ndarray, n: int) -> np.ndarray:
    """Bool per row of ``n``: does row i lie in one of the (first, count) ``ranges``."""
    marks = np.zeros(n + 1, np.int64)
    ranges = np.asarray(ranges, np.int64).reshape(-1, 2)
    np.add.at(marks, ranges[:, 0], 1)
    np.add.at(marks, ranges[:, 0] + ranges[:, 1], -1)
    return np.cumsum(marks[:n]) > 0


def merge_ranges(mask: np.ndarray, gap: int = MERGE_GAP_TRIANGLES) -> list[tuple[int, int]]:
    """(first, count) runs of True in ``mask``, runs closer than ``gap`` merged."""
    idx = np.flatnonzero(mask)
    if len(idx) == 0:
        return []
    breaks = np.flatnonzero(np.diff(idx) > gap)
    starts = np.r_[idx[0], idx[breaks + 1]]
    ends = np.r_[idx[breaks], idx[-1]] + 1
    return [(int(s), int(e - s)) for s, e in zip(starts, ends)]


class GeometryTracker:
    """Remembers the geometry last uploaded and tells what a new frame changed."""

    def __init__(self) -> None:
        self.reset()
        self.sequence = 0
        self.compared = False  # whether the last update compared triangles bit for bit

    def reset(self) -> None:
        """Forget the last geometry (the next update is a full upload)."""
        self._last = None
        self._edit = None
        self._layout: tuple | None = None  # (triangles, UVs present, object ranges) last seen

    def update(self, geometry: Geometry) -> GeometryDelta:
        """The delta from the last call's geometry, which is remembered. A geometry that says
        which objects its producer rewrote since the version this tracker saw last
        (``Geometry.edit``) is taken at its word: only those objects' rows are copied; any
        other is compared bit for bit."""
        self.sequence += 1
        edit = geometry.edit
        delta = self._edited(geometry, edit)
        if delta is None and isinstance(geometry, InstancedGeometry):
            # Made on the GPU: its rows are never compared on the host (reading them would
            # transform every instance on the CPU).
            delta = GeometryDelta.everything(geometry.triangle_count, self.sequence)
        self.compared = delta is None
        if delta is None:
            delta = self._compared(geometry)
        if edit is not None:
            # A producer's geometry comes with its edits: no copy of the rows is kept to
            # compare with (a later geometry without edits is uploaded whole).
            self._last = None
        self._edit = (edit.source, edit.generation) if edit is not None else None
        self._layout = (geometry.triangle_count, geometry.has_uvs, geometry.object_ranges.copy())
        return delta

    def _edited(self, geometry: Geometry, edit: GeometryEdit | None) -> GeometryDelta | None:
        """The delta of an in-place edit that follows the last geometry (or is the same
        version of it: nothing changed), else None. The rows are not compared, nor kept."""
        layout = self._layout
        if (edit is None or layout is None or layout[0] != geometry.triangle_count
                or layout[1] != geometry.has_uvs
                or not np.array_equal(layout[2], geometry.object_ranges)):
            return None
        if self._edit == (edit.source, edit.generation):
            return GeometryDelta(full=False, sequence=self.sequence)
        if edit.objects is None or self._edit != (edit.source, edit.generation - 1):
            return None
        objects = geometry.object_ranges[np.asarray(edit.objects, np.int64)].reshape(-1, 2).astype(np.int64)
        objects = objects[objects[:, 1] > 0]
        if len(objects) == 0:
            return GeometryDelta(full=False, sequence=self.sequence)
        objects = objects[np.argsort(objects[:, 0], kind="stable")]
        starts, ends = objects[:, 0], objects[:, 0] + objects[:, 1]
        # Objects closer than MERGE_GAP_TRIANGLES are sent as one range (as merge_ranges).
        breaks = np.flatnonzero(starts[1:] - ends[:-1] > MERGE_GAP_TRIANGLES)
        firsts = np.r_[starts[0], starts[breaks + 1]]
        lasts = np.r_[ends[breaks], ends[-1]]
        ranges = tuple((int(a), int(b - a)) for a, b in zip(firsts, lasts))
        return GeometryDelta(full=False, ranges=ranges, changed_triangles=int(objects[:, 1].sum()),
                             sequence=self.sequence)

    @staticmethod
    def _arrays(geometry: Geometry) -> dict[str, np.ndarray]:
        arrays = {"triangles": geometry.triangles, "normals": geometry.normals,
                  "material_ids": geometry.material_ids}
        if geometry.uvs is not None:
            arrays["uvs"] = geometry.uvs
        return arrays

    def _compared(self, geometry: Geometry) -> GeometryDelta:
        seq = self.sequence
        n = geometry.triangle_count
        arrays = self._arrays(geometry)
        last = self._last
        same_layout = (
            last is not None
            and last.keys() == arrays.keys() | {"object_ranges"}
            and len(last["triangles"]) == n
            and np.array_equal(last["object_ranges"], geometry.object_ranges)
        )
        if not same_layout:
            self._last = {name: np.array(a, copy=True) for name, a in arrays.items()}
            self._last["object_ranges"] = np.array(geometry.object_ranges, copy=True)
            return GeometryDelta.everything(n, seq)
        # Objects whose first triangle changed are taken whole (module docstring); the rows
        # of the others are compared one by one, run by run.
        objects = geometry.object_ranges[geometry.object_ranges[:, 1] > 0]
        firsts = objects[:, 0]
        first_changed = np.zeros(len(objects), bool)
        for name, a in arrays.items():
            first_changed |= changed_rows(last[name][firsts], a[firsts])
        mask = range_mask(objects[first_changed], n)
        for first, count in merge_ranges(~mask, gap=1):  # gap 1: exact runs, none merged
            end = first + count
            for name, a in arrays.items():
                mask[first:end] |= changed_rows(last[name][first:end], a[first:end])
        changed = int(mask.sum())
        if changed == 0:
            return GeometryDelta(full=False, sequence=seq)
        # Ranges even when most triangles moved: writing them costs no more than a whole
        # upload (the arrays go to the GPU as they are, scene_upload/scene_buffers.py), and ``full`` stays
        # reserved for layout changes, so that consumers keeping per-object state (the
        # shadow layers) still learn which objects stayed still.
        ranges = merge_ranges(mask)
        for name, a in arrays.items():
            for first, count in ranges:
                last[name][first:first + count] = a[first:first + count]
        return GeometryDelta(full=False, ranges=tuple(ranges), changed_triangles=changed, sequence=seq)
