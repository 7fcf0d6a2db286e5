# SPDX-License-Identifier: GPL-3.0-or-later
"""Last frame's world rows of the instances whose mesh deformed this frame.

A deformed mesh (an armature, shape keys, a mesh edited in place) keeps its triangles and
rewrites its vertices, so its instances' world rows are transformed again while the
instance table's matrix may stay the same: nothing in the table says where a surface point
stood last frame. The world rows still hold it until the transform overwrites them, so
``InstanceTransformer.transform`` copies those instances' position rows here first, packed
one instance after another, a copy on the GPU and no read-back. The surface-motion pass
(passes/surface_motion/) places each pixel's point on its triangle of last frame, and turns
its normal as that triangle turned, from them. Only the frame that captured them may read
them.
"""
from __future__ import annotations

import numpy as np

from ...gpu.dispatch import GrowBuffer, max_block_bytes


class PreviousRows:
    """The captured rows: ``instances`` (sorted) and ``offsets``, each instance's first row
    in the packed ``positions`` buffer (``row_bytes`` per row: the world rows' own,
    instance_transform.OUTPUT_ROW_BYTES["positions"]); empty when this frame deformed
    nothing, or its rows could not be trusted (the world buffers were replaced)."""

    def __init__(self, ctx, row_bytes: dict[str, int]) -> None:
        self.ctx = ctx
        self.row_bytes = int(row_bytes["positions"])
        self.positions = GrowBuffer(ctx, "previous world positions")
        self.instances = np.zeros(0, np.int64)
        self.offsets = np.zeros(0, np.int64)
        self.rows = 0

    def clear(self) -> None:
        self.instances = np.zeros(0, np.int64)
        self.offsets = np.zeros(0, np.int64)
        self.rows = 0

    def capture(self, instances: np.ndarray, ranges: np.ndarray, outputs: dict[str, object]) -> None:
        """Copy the world rows ``ranges`` ((first row, count) per instance of ``instances``,
        sorted) of ``outputs`` (GPUScene's buffers by name) into the packed buffers, before
        the transform overwrites them."""
        ranges = np.asarray(ranges, np.int64).reshape(-1, 2)
        keep = ranges[:, 1] > 0
        instances, ranges = np.asarray(instances, np.int64)[keep], ranges[keep]
        offsets = np.concatenate([[0], np.cumsum(ranges[:, 1])]).astype(np.int64)
        total = int(offsets[-1])
        self.clear()
        # The surface-motion pass reads them as one storage block: past the driver's block
        # size (millions of deformed triangles) those pixels start over instead.
        if total == 0 or total * self.row_bytes > max_block_bytes():
            return
        # Instances whose rows follow one another (a crowd of one deforming mesh) are one copy.
        starts, ends = ranges[:, 0], ranges[:, 0] + ranges[:, 1]
        runs = np.flatnonzero(np.r_[True, starts[1:] != ends[:-1]])
        run_ends = np.r_[runs[1:], len(ranges)]
        row = self.row_bytes
        self.positions.ensure(total * row)
        source = outputs["positions"].buffer
        for first_index, end_index in zip(runs, run_ends):
            rows = int(offsets[end_index] - offsets[first_index])
            self.ctx.copy_buffer(self.positions.buffer, source, rows * row,
                                 read_offset=int(starts[first_index]) * row,
                                 write_offset=int(offsets[first_index]) * row)
        self.instances, self.offsets, self.rows = instances, offsets[:-1], total

    def offsets_of(self, instances: np.ndarray) -> np.ndarray:
        """Each of ``instances``' first row in the packed buffers, -1 for those not captured."""
        instances = np.asarray(instances, np.int64)
        if not len(self.instances):
            return np.full(len(instances), -1, np.int64)
        at = np.clip(np.searchsorted(self.instances, instances), 0, len(self.instances) - 1)
        return np.where(self.instances[at] == instances, self.offsets[at], -1)

    def release(self) -> None:
        self.positions.release()
        self.clear()
