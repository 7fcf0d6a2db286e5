# SPDX-License-Identifier: GPL-3.0-or-later
"""The ``cryptomatte`` pass: Cryptomatte Object, Material and Asset, made and accumulated on
the GPU over a final render's samples.

A compositor picks an object by name and gets its matte from these passes: per pixel the
ids that cover it, ranked by coverage (scene/cryptomatte.py makes the ids, Blender's way).
The coverage must be anti-aliased, or an extracted matte has jagged edges, so it is counted
per sample at the sample's jittered position, as the colour is averaged (antialias.py):
each sample's G-buffer keeps the world row of the triangle each pixel shows there (its
``row`` target), and a compute stage adds one count to the id each kind maps the row to
(``cryptomatte.comp.glsl``): no geometry is drawn for the passes, and a surface the
G-buffer's alpha test drops (a leaf's cut-out) gives its sample to what shows through it,
as the shading does. The counts stay on the GPU in an image array laid out as the passes
themselves; the frame that reads its image sorts and scales them there and reads them back
once.
"""
from __future__ import annotations

import math

import moderngl
import numpy as np

from ...gpu import shader_loader
from ...gpu.bindings import Image, bind
from ...gpu.render_targets import release_all
from ...scene.cryptomatte import KINDS, CryptomatteRequest, name_id, object_name, pass_names
from ...scene.data import SceneData
from ...scene.settings import RenderSettings
from ..frame_context import FrameContext, PassIO
from .accumulate import AccumulationError

WORKGROUP = 8
KIND_CODES = {kind: code for code, kind in enumerate(KINDS)}


class CryptomattePass:
    """Counts, per pixel and kind, the samples each id covers (``run``, every sample) and
    gives the ranked, normalised passes (``read``, once)."""

    name = "cryptomatte"

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.accumulate = shader_loader.compute(ctx, "film/cryptomatte.comp.glsl")
        self.finalize = shader_loader.compute(ctx, "film/cryptomatte.comp.glsl", defines={"FINALIZE": 1})
        self.size: tuple[int, int] | None = None
        self.request: CryptomatteRequest | None = None
        self.count = 0  # samples in the counts
        self._targets: dict[str, object] = {}
        self._ids: dict[str, object] = {}
        self._ids_key: tuple | None = None

    def io(self, settings: RenderSettings) -> PassIO:
        return PassIO(reads=("scene", "world_triangles", "gbuffer"), writes=("cryptomatte",))

    def run(self, frame: FrameContext) -> None:
        self.add(frame.read("scene"), frame.read("world_triangles"), frame.read("gbuffer"), frame.view,
                 frame.outputs.cryptomatte, frame.sample)
        frame.write("cryptomatte", self)

    def add(self, scene: SceneData, gpu, targets, view, request: CryptomatteRequest, sample: int) -> None:
        """Count sample ``sample`` of ``view``, whose primary G-buffer is ``targets`` (0
        starts the counts over; any other must follow the last, of the same size and
        request, else AccumulationError)."""
        size = (int(view.width), int(view.height))
        if sample != 0 and (sample != self.count or size != self.size or request != self.request):
            raise AccumulationError(
                f"Cryptomatte sample {sample} of a {size[0]}x{size[1]} view does not follow the "
                f"{self.count} samples so far; start again at sample 0")
        self._ensure(size, request)
        self._upload_ids(scene, request)
        ctx = self.ctx
        kinds = [KIND_CODES[kind] for kind in request.kinds]
        bind(self.accumulate, gpu.bindings(),
             storage={"ObjectRows": self._ids["rows"], "ObjectIds": self._ids["objects"],
                      "MaterialIds": self._ids["materials"]},
             images={"u_slots": Image(self._targets["slots"], read=True, write=True)},
             textures={"u_row": targets.row, "u_normal_material": targets.normal_material},
             uniforms={"u_size": size, "u_passes": request.slots // 2, "u_kind_count": len(kinds),
                       "u_kinds": tuple(kinds + [0] * (3 - len(kinds))), "u_sample": int(sample),
                       "u_objects": int(self._ids_key[1])})
        self.accumulate.run(math.ceil(size[0] / WORKGROUP), math.ceil(size[1] / WORKGROUP), 1)
        ctx.memory_barrier(moderngl.SHADER_IMAGE_ACCESS_BARRIER_BIT | moderngl.TEXTURE_UPDATE_BARRIER_BIT)
        self.count = sample + 1

    def read(self) -> dict[str, np.ndarray]:
        """The passes (Blender's names: CryptoObject00, ...) as (H, W, 4) float32 arrays, row
        0 at the bottom: per texel two (id, coverage) pairs, ranked by coverage over the
        samples counted so far. Sorts and scales the counts in place: the next sample must
        start over."""
        request, size = self.request, self.size
        if request is None or self.count == 0:
            return {}
        bind(self.finalize, images={"u_slots": Image(self._targets["slots"], read=True, write=True)},
             uniforms={"u_size": size, "u_passes": request.slots // 2, "u_kind_count": len(request.kinds),
                       "u_samples": float(self.count)})
        self.finalize.run(math.ceil(size[0] / WORKGROUP), math.ceil(size[1] / WORKGROUP), 1)
        self.ctx.memory_barrier(moderngl.TEXTURE_UPDATE_BARRIER_BIT | moderngl.SHADER_IMAGE_ACCESS_BARRIER_BIT)
        self.count = 0
        passes = request.slots // 2
        layers = np.empty((len(request.kinds) * passes, size[1], size[0], 4), np.float32)
        self._targets["slots"].read_into(layers)
        out = {}
        for k, kind in enumerate(request.kinds):
            for p, name in enumerate(pass_names(kind, request.levels)):
                out[name] = layers[k * passes + p]
        return out


    def _upload_ids(self, scene: SceneData, request: CryptomatteRequest) -> None:
        """The objects' first rows, their (object, asset) ids and the materials' ids, made
        again only when the names or the rows change."""
        geometry = scene.geometry
        names = tuple(geometry.object_names)
        ranges = np.asarray(geometry.object_ranges, np.int64).reshape(-1, 2)
        assets = request.assets or tuple(object_name(n) for n in names)
        key = (names, len(names), ranges.tobytes(), assets, tuple(scene.materials.names))
        if key == self._ids_key:
            return
        release_all(self._ids.values())
        order = np.lexsort((ranges[:, 1], ranges[:, 0])) if len(ranges) else np.zeros(1, np.int64)
        rows = ranges[order, 0] if len(ranges) else np.zeros(1)
        objects = np.array([(name_id(object_name(names[i])), name_id(assets[i])) for i in order]
                           if len(ranges) else [(0.0, 0.0)], np.float32)
        materials = np.array([name_id(n) for n in scene.materials.names] or [0.0], np.float32)
        self._ids = {"rows": self.ctx.buffer(np.ascontiguousarray(rows, np.int32).tobytes()),
                     "objects": self.ctx.buffer(objects.tobytes()),
                     "materials": self.ctx.buffer(materials.tobytes())}
        self._ids_key = key

    def _ensure(self, size: tuple[int, int], request: CryptomatteRequest) -> None:
        layers = len(request.kinds) * request.slots // 2
        if size == self.size and self.request is not None and \
                len(self.request.kinds) * self.request.slots // 2 == layers:
            self.request = request
            return
        release_all(self._targets.values())
        self._targets = {"slots": self.ctx.texture_array((*size, layers), 4, dtype="f4")}
        self.size, self.request, self.count = size, request, 0

    def release(self) -> None:
        release_all(self._targets.values())
        release_all(self._ids.values())
        self._targets, self._ids, self._ids_key = {}, {}, None
        self.size, self.request, self.count = None, None, 0
