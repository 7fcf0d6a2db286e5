# SPDX-License-Identifier: GPL-3.0-or-later
"""The one read-back of a frame: the film's mean image into a host array Blender can draw.

Blender's ``gpu`` module draws from a float32 buffer (``gpu.types.Buffer`` knows FLOAT,
INT, UINT, UBYTE, UINT_24_8 and 10_11_11_REV, no half floats: ``bpygpu_dataformat_items``
in Blender's ``source/blender/python/gpu/gpu_py.cc``), so the image comes back as RGBA32F
into one persistent (H, W, 4) float32 array, made again only when the size changes: no
allocation, no conversion and no copy on the host beyond the read itself. Reading RGBA16F
would halve the bytes moved but cost a float16 to float32 conversion of every pixel on the
host, several times the read (docs/BENCHMARKS.md).

Two shapes, chosen by ``variants.choose("readback")``:

* ``"cpu"`` (synchronous): the image is read when the frame is submitted. On llvmpipe the
  "GPU" is the CPU, a pixel-buffer copy is one more pass over the image, and nothing runs
  meanwhile that waiting would hold back.
* ``"gpu"`` (asynchronous): the image is copied into a pixel buffer on the GPU's timeline and
  a fence placed after it (gpu/fences.py); the host maps it once the fence has passed,
  at the latest on the next redraw, so the host never waits for the frame's GPU work and a
  redraw shows the image of the one before when the GPU is behind.
"""
from __future__ import annotations

from collections import deque

import numpy as np

from ..gpu import fences, variants


class ImageReadback:
    """Brings submitted images (RGBA32F textures) to the host (module docstring)."""

    def __init__(self, ctx, family: str | None = None) -> None:
        self.ctx = ctx
        self.family = family or variants.choose("readback")
        self.asynchronous = self.family == "gpu"
        self._host: np.ndarray | None = None
        self._pixel_buffers: list = []
        self._queue: deque = deque()  # (pixel buffer, fence, tag) in submission order
        self._next_buffer = 0
        self.image: np.ndarray | None = None  # the newest image on the host
        self.tag: object = None  # what the caller said the newest image on the host is

    @property
    def pending(self) -> bool:
        """Whether a submitted image has not reached the host yet."""
        return bool(self._queue)

    def submit(self, texture, tag: object = None) -> None:
        """Start bringing ``texture`` (RGBA32F) to the host; ``tag`` comes back as ``self.tag``
        once it is there. The synchronous shape reads it now."""
        width, height = (int(v) for v in texture.size)
        host = self._host_array(width, height)
        if not self.asynchronous:
            texture.read_into(host)
            self.image, self.tag = host, tag
            return
        buffer = self._pixel_buffer(host.nbytes)
        texture.read_into(buffer)
        self._queue.append((buffer, fences.Fence(), tag, (height, width)))

    def collect(self, wait: bool = False) -> bool:
        """Map every submitted copy older than the newest, and the newest too once its fence
        has passed (or at once with ``wait``); returns whether ``image`` changed."""
        changed = False
        while self._queue:
            buffer, fence, tag, shape = self._queue[0]
            newest = len(self._queue) == 1
            if newest and not wait and not fence.signalled():
                break
            self._queue.popleft()
            fence.release()
            if self._host is None or self._host.shape[:2] != shape:  # the size changed since
                continue
            buffer.read_into(self._host)
            self.image, self.tag, changed = self._host, tag, True
        return changed

    def _host_array(self, width: int, height: int) -> np.ndarray:
        if self._host is None or self._host.shape[:2] != (height, width):
            self._host = np.zeros((height, width, 4), np.float32)
            self.image = None
        return self._host

    def _pixel_buffer(self, nbytes: int):
        """The next of two pixel buffers (one being mapped while the other is written)."""
        if not self._pixel_buffers or self._pixel_buffers[0].size < nbytes:
            self.collect(wait=True)
            for buffer in self._pixel_buffers:
                buffer.release()
            self._pixel_buffers = [self.ctx.buffer(reserve=nbytes) for _ in range(2)]
        if len(self._queue) >= len(self._pixel_buffers):
            self.collect(wait=True)
        buffer = self._pixel_buffers[self._next_buffer]
        self._next_buffer = 1 - self._next_buffer
        return buffer

    def release(self) -> None:
        for _buffer, fence, _tag, _shape in self._queue:
            fence.release()
        self._queue.clear()
        for buffer in self._pixel_buffers:
            buffer.release()
        self._pixel_buffers = []
        self._host = self.image = None
