# SPDX-License-Identifier: GPL-3.0-or-later
"""A frame's statistics (kept triangles, objects per class, rays per bounce), read only when
asked, after the frame.

The counters a frame's passes keep live on the GPU: the near-cube cull counts its objects
per class, the trace its rays and BVH nodes, the LBVH build holds its leaf count. Reading any
of them back while the frame runs makes the host wait for every command recorded so far,
which drains the GPU in mid-frame (a GPU runs the host's commands some way behind the host).
So a pass only *deposits* the counter: which buffer, where, how many uint32 words, and how
to turn them into named counts. At the frame's end the renderer has the GPU copy every
deposit into one small buffer of a ring (``ctx.copy_buffer``, no synchronisation), and the
frame's counts are read from it the first time a caller asks (``LazyCounts``): a final
render and a timing report ask, after the image is read anyway; a viewport asks only when
it refreshes its statistics line, a frame or more later, when the copy has long been done.

A slot is reused ``slots`` frames later. A frame whose counts were never asked for and are
still referenced then keeps its copy: the slot takes a new buffer and the old one stays with
that frame, released once its counts are read or the frame is dropped. Reading it there
instead would make the host wait, in the middle of recording a frame, for everything the
GPU has been given so far (a driver reads a buffer only after the commands before the read
have run), and a caller that merely holds its results (a viewport keeping the last frame's)
asked for nothing. Late readers get their own frame's numbers whatever the frame rate.
"""
from __future__ import annotations

import weakref
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Callable, Iterator

import numpy as np

from .dispatch import GrowBuffer

# uint32 words of a deposit -> named counts.
Decoder = Callable[[np.ndarray], Mapping[str, int]]

DEFAULT_SLOTS = 3


@dataclass(frozen=True)
class Deposit:
    """``words`` uint32 of ``buffer`` from byte ``offset`` (a multiple of 4), and ``decode``,
    which names them."""

    buffer: object
    words: int
    decode: Decoder
    offset: int = 0


class FrameStatistics:
    """The GPU-side counters one frame's passes deposited, in order."""

    def __init__(self) -> None:
        self.deposits: list[Deposit] = []

    def deposit(self, buffer, words: int, decode: Decoder, offset: int = 0) -> None:
        """Add ``words`` uint32 of ``buffer`` at byte ``offset`` to the frame's statistics:
        copied at the frame's end, decoded when the counts are asked for."""
        if offset % 4:
            raise ValueError(f"a deposit starts at a multiple of 4 bytes, got offset {offset}")
        self.deposits.append(Deposit(buffer, int(words), decode, int(offset)))


class PendingCounts:
    """The copied counters of one frame in a ring slot; ``resolve()`` reads them (once)."""

    def __init__(self, buffer, layout: list[tuple[int, int, Decoder]], nbytes: int) -> None:
        self._buffer = buffer
        self._layout = layout  # (word offset, words, decode)
        self._nbytes = nbytes
        self._values: dict[str, int] | None = None

    @property
    def resolved(self) -> bool:
        return self._values is not None

    def resolve(self) -> dict[str, int]:
        if self._values is None:
            words = (np.frombuffer(self._buffer.read(size=self._nbytes), np.uint32) if self._nbytes
                     else np.empty(0, np.uint32))
            values: dict[str, int] = {}
            for first, count, decode in self._layout:
                values.update({name: int(value) for name, value in decode(words[first:first + count]).items()})
            self._values = values
            self._buffer = None
        return self._values


class StatisticsRing:
    """``slots`` small GPU buffers the frames' statistics are copied into, in turn."""

    def __init__(self, ctx, slots: int = DEFAULT_SLOTS) -> None:
        if slots < 1:
            raise ValueError(f"a statistics ring needs at least one slot, got {slots}")
        self.ctx = ctx
        self._slots = [GrowBuffer(ctx, f"frame statistics {index}", min_bytes=64) for index in range(slots)]
        for slot in self._slots:  # made now, so that frames that copy nothing leave none to make later
            slot.ensure(64)
        self._pending: list[weakref.ref | None] = [None] * slots
        self._next = 0
        # Buffers handed over to frames still held and unread: (the frame's counts, buffer).
        self._kept: list[tuple[weakref.ref, GrowBuffer]] = []

    def collect(self, statistics: FrameStatistics) -> PendingCounts:
        """Copy the frame's deposits into the next slot on the GPU; nothing is read."""
        index = self._next
        self._next = (index + 1) % len(self._slots)
        self._release_kept()
        earlier = self._pending[index]() if self._pending[index] is not None else None
        if earlier is not None and not earlier.resolved:
            # A frame `slots` ago, still held and never read: it keeps its buffer (module doc).
            self._kept.append((self._pending[index], self._slots[index]))
            self._slots[index] = GrowBuffer(self.ctx, f"frame statistics {index}", min_bytes=64)
            self._slots[index].ensure(64)
        nbytes = sum(4 * deposit.words for deposit in statistics.deposits)
        slot = self._slots[index].ensure(nbytes)
        layout, at = [], 0
        for deposit in statistics.deposits:
            if deposit.words:
                self.ctx.copy_buffer(slot, deposit.buffer, 4 * deposit.words, read_offset=deposit.offset,
                                     write_offset=4 * at)
            layout.append((at, deposit.words, deposit.decode))
            at += deposit.words
        pending = PendingCounts(slot, layout, nbytes)
        self._pending[index] = weakref.ref(pending)
        return pending

    @property
    def kept(self) -> int:
        """Buffers held by frames whose slots have moved on (tests)."""
        return len(self._kept)

    def _release_kept(self) -> None:
        """Release the kept buffers whose frames were read or dropped."""
        still = []
        for pending, buffer in self._kept:
            alive = pending()
            if alive is None or alive.resolved:
                buffer.release()
            else:
                still.append((pending, buffer))
        self._kept = still

    def release(self) -> None:
        for pending in self._pending + [pending for pending, _ in self._kept]:
            alive = pending() if pending is not None else None
            if alive is not None and not alive.resolved:
                alive.resolve()
        for slot in self._slots:
            slot.release()
        self._release_kept()
        self._pending = [None] * len(self._slots)


class LazyCounts(Mapping):
    """A frame's counts: those the host knows, then the GPU's, read on first access."""

    def __init__(self, host: Mapping[str, int], pending: PendingCounts | None = None) -> None:
        self._host = dict(host)
        self._pending = pending
        self._all: dict[str, int] | None = None if pending is not None else self._host

    @property
    def host(self) -> dict[str, int]:
        """The counts the host knows, read from nothing."""
        return dict(self._host)

    @property
    def resolved(self) -> bool:
        """Whether the GPU's counts have been read (no read happens until a key is asked)."""
        return self._all is not None

    def _resolve(self) -> dict[str, int]:
        if self._all is None:
            self._all = {**self._host, **self._pending.resolve()}
            self._pending = None
        return self._all

    def __getitem__(self, name: str) -> int:
        return self._resolve()[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._resolve())

    def __len__(self) -> int:
        return len(self._resolve())

    def __repr__(self) -> str:
        return f"LazyCounts({self._all!r})" if self._all is not None else "LazyCounts(<not read>)"
