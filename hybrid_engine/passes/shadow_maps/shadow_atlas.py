# SPDX-License-Identifier: GPL-3.0-or-later
"""The shadow atlas: every light's shadow-map slots in two depth layers (paper §3.5).

One atlas holds all slots side by side, so a shading pass binds two textures and one slot
table whatever the number of lights. Objects at rest and moving objects keep separate
layers (shadow_cache.py): a frame in which only the moving objects changed re-renders the
dynamic layer alone, and the lookup takes the nearer depth of the two.

The atlas is lighting data, not a raster pass's private state: the deferred shading and the
tracer both read it through :class:`~hybrid_engine.passes.lighting.resources.FrameResources`; the
shadow pass (shadow_depth.py) only draws into the layers laid out here.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...gpu.dispatch import SceneLimitError
from ...gpu.render_targets import sampled_depth_texture

# struct ShadowSlot (gpu_shaders/include/scene_layout.glsl)           // total: 96 bytes
SHADOW_SLOT_DTYPE = np.dtype([("view_proj", np.float32, (4, 4)), ("rect", np.int32, 4), ("texel", np.float32, 4)])
# Rows of the ShadowSlotBuffer uniform block (include/lighting.glsl): 48 KiB of 96-byte slots.
MAX_SHADOW_SLOTS = 512
assert SHADOW_SLOT_DTYPE.itemsize == 96


@dataclass
class ShadowView:
    """One shadow slot: its view-projection, the angular or world size of its frustum (full
    width at unit distance for perspective slots, full world width for orthographic) and its
    depth range (near, far), which the soft-shadow filter needs to turn stored depths back
    into distances."""

    view_proj: np.ndarray
    extent: float
    perspective: bool
    near: float = 0.0
    far: float = 1.0


class ShadowAtlas:
    """Both depth layers of the atlas, their framebuffers and the slot table (SSBO)."""

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.static = None
        self.dynamic = None
        self._fbos: dict[bool, object] = {}
        self.size: tuple[int, int] | None = None
        self._cols = 1
        # The uniform block's whole size: a block reads what it declares.
        self.slot_buffer = ctx.buffer(reserve=MAX_SHADOW_SLOTS * SHADOW_SLOT_DTYPE.itemsize)
        self.slots = np.zeros(1, SHADOW_SLOT_DTYPE)

    def _ensure(self, slots: int, resolution: int) -> int:
        """Allocate both layers for ``slots`` square maps; returns the slot size, reduced
        (documented fallback) when the atlas would exceed the driver's texture size."""
        cols = max(1, math.ceil(math.sqrt(slots)))
        rows = max(1, math.ceil(slots / cols))
        max_size = int(self.ctx.info.get("GL_MAX_TEXTURE_SIZE", 8192))
        res = min(resolution, max_size // cols, max_size // rows)
        size = (cols * res, rows * res)
        if self.size != size:
            self._release_layers()
            layers = []
            for _ in range(2):
                tex = sampled_depth_texture(self.ctx, size)
                tex.filter = (self.ctx.NEAREST, self.ctx.NEAREST)
                fbo = self.ctx.framebuffer(depth_attachment=tex)
                fbo.use()
                fbo.viewport = (0, 0, *size)
                fbo.clear(depth=1.0)
                layers.append((tex, fbo))
            (self.static, static_fbo), (self.dynamic, dynamic_fbo) = layers
            self._fbos = {False: static_fbo, True: dynamic_fbo}
            self.size = size
        self._cols = cols
        return res

    def layout(self, views: list[ShadowView], resolution: int) -> None:
        """Allocate both layers for ``views`` and write the slot table."""
        if len(views) > MAX_SHADOW_SLOTS:
            raise SceneLimitError(f"the scene's lamps need {len(views)} shadow maps; Hybrid RT holds at most "
                                  f"{MAX_SHADOW_SLOTS}: turn off Cast Shadow on some lamps (a point lamp takes 6, "
                                  "a sun 1 plus its Sun Cascades)")
        slots = np.zeros(max(len(views), 1), SHADOW_SLOT_DTYPE)
        if views:
            res = self._ensure(len(views), int(resolution))
            for i, view in enumerate(views):
                x, y = (i % self._cols) * res, (i // self._cols) * res
                slots[i]["view_proj"] = np.asarray(view.view_proj, np.float32).T  # column-major for GLSL
                slots[i]["rect"] = (x, y, res, 0)
                slots[i]["texel"] = (view.extent / res, float(view.perspective), view.near, view.far)
        elif self.static is None:
            self._ensure(1, 1)  # keep valid textures bound for the shading passes
        self.slot_buffer.write(slots.tobytes())
        self.slots = slots

    def ensure_bindable(self) -> None:
        """Valid (1x1) layers before any light was laid out, so passes can always bind."""
        if self.static is None:
            self._ensure(1, 1)

    def rect(self, slot: int) -> tuple[int, int, int, int]:
        """The viewport (x, y, w, h) of ``slot`` in the atlas."""
        x, y, res, _ = (int(v) for v in self.slots[slot]["rect"])
        return x, y, res, res

    def begin_layer(self, dynamic: bool, rects: list[tuple[int, int, int, int]] | None = None):
        """Bind one layer and clear it whole, or only the slot rectangles ``rects`` (the
        slots about to be re-rendered; the others keep their depths); returns its
        framebuffer."""
        fbo = self._fbos[dynamic]
        fbo.use()
        fbo.viewport = (0, 0, *self.size)
        if rects is None:
            fbo.clear(depth=1.0)
        for rect in rects or ():
            fbo.clear(depth=1.0, viewport=rect)
        return fbo

    def layer_framebuffer(self, dynamic: bool):
        """One layer's framebuffer (for drawing into slots after ``begin_layer``)."""
        return self._fbos[dynamic]

    def read_layers(self) -> tuple[np.ndarray, np.ndarray]:
        """The static and dynamic layers' depths ((H, W) float32 each; for tests)."""
        w, h = self.size
        return tuple(np.frombuffer(tex.read(), np.float32).reshape(h, w).copy()
                     for tex in (self.static, self.dynamic))

    def _release_layers(self) -> None:
        from ...gpu.gl_context import park_framebuffer

        park_framebuffer()  # never delete the bound framebuffer
        for obj in (*self._fbos.values(), self.static, self.dynamic):
            if obj is not None:
                obj.release()
        self._fbos = {}
        self.static = self.dynamic = None
        self.size = None

    def release(self) -> None:
        self._release_layers()
        self.slot_buffer.release()
