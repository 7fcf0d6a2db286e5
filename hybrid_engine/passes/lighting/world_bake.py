# SPDX-License-Identifier: GPL-3.0-or-later
"""The World's node graph, baked on the GPU into the equirectangular environment.

A World is a graph like a material's (Background colour x strength, fed by Environment and
Sky Textures through Mapping, Mix and colour nodes), but it depends on the direction only.
So it is not run where the sky is read (every escaping ray, the irradiance projection, the
rough reflections' mip levels); it is run once per texel of an equirectangular target, by
one compute pass of the node-program interpreter (lighting/world_bake.comp.glsl), and the
target then stands where an environment image stood (sky_light.py): its mips are the
prefiltered levels, its SH projection the irradiance, as for an image.

When: the graph is compiled on every update (a few hundred words) and its words compared
with the last bake's, with the images' identities; the pass runs only when either
differs. A frame whose World did not change costs a compile of a small graph, never a
dispatch; a value edit costs one dispatch and no shader compile (the interpreter reads the
words). ``bakes`` counts the dispatches.

Resolution: BAKE_WIDTH x BAKE_WIDTH / 2 texels, chosen by measurement on the CPU driver, where
a bake's time grows with the texels (a value edit waits for one bake): four times the
texels cost about five times as long. An equirectangular image read directly keeps its own
resolution (sky_light.py), so the bake's size matters only for what a graph computes, whose
detail is a sky gradient or an image seen through it.

Sky Textures: each Multiple Scattering node gets a transmittance table first
(sky_tables.py: one small dispatch per node, in the same update), which its in-scattering
reads at every step; the other models need none.
"""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ...gpu import shader_loader
from ...gpu.bindings import Image, bind
from ...scene.node_codes import FAMILY_ATTRIBUTES
from ...scene.node_program import NodeProgram, compile_graph
from ...scene.shader_graph import ShaderGraph
from ..scene_upload.textures import pack_layers
from .sky_tables import SkyTables

# Width of the baked environment (height: half of it); see docs/ARCHITECTURE.md "World".
BAKE_WIDTH = 512
_GROUP = 8  # world_bake.comp.glsl local size (8 x 8)


class WorldBake:
    """The baked environment of the last graph given (``texture``, mipmapped)."""

    def __init__(self, ctx, width: int = BAKE_WIDTH) -> None:
        self.ctx = ctx
        self.width = int(width)
        self.texture = None
        self.program: NodeProgram | None = None
        self.bakes = 0  # dispatches of the bake (tests, statistics)
        self._words = None
        self._program_buffer = None
        self._objects = ctx.buffer(np.zeros(32, np.uint32).tobytes())  # NodeObjects: a header, no instances
        self._no_textures = ctx.texture_array((1, 1, 1), 4, np.zeros(4, np.float32).tobytes(), dtype="f4")
        self._images = None
        self._image_key: tuple | None = None
        self._key: tuple | None = None
        self.sky_tables = SkyTables(ctx)

    def update(self, graph: ShaderGraph, images: Sequence[np.ndarray] = ()) -> bool:
        """Bake ``graph`` unless the last bake had the same words and images; True when it baked."""
        graph = self.sky_tables.assign(graph)
        program = compile_graph(graph, "World")
        image_key = tuple((id(image), image.shape) for image in images)
        key = (program.words.tobytes(), image_key, self.width)
        self.program = program
        if key == self._key:
            return False
        if image_key != self._image_key:
            self._upload_images(images)
            self._image_key = image_key
        self.sky_tables.update(graph)
        self._bake(program)
        self._key = key
        self.bakes += 1
        return True

    def _upload_images(self, images: Sequence[np.ndarray]) -> None:
        if self._images is not None:
            self._images.release()
            self._images = None
        if not images:
            return
        width = max(int(image.shape[1]) for image in images)
        height = max(int(image.shape[0]) for image in images)
        layers = pack_layers([np.asarray(image, np.float32) for image in images], width, height)
        tex = self.ctx.texture_array((width, height, len(images)), 4, layers.tobytes(), dtype="f2")
        tex.repeat_x, tex.repeat_y = True, False
        tex.build_mipmaps()
        tex.filter = (self.ctx.LINEAR_MIPMAP_LINEAR, self.ctx.LINEAR)
        self._images = tex

    def _target(self):
        height = max(self.width // 2, 1)
        if self.texture is None or self.texture.size != (self.width, height):
            if self.texture is not None:
                self.texture.release()
            self.texture = self.ctx.texture((self.width, height), 4, dtype="f4")
            self.texture.repeat_x, self.texture.repeat_y = True, False
        return self.texture

    def _bake(self, program: NodeProgram) -> None:
        words = program.words
        data = np.ascontiguousarray(words if len(words) else np.zeros(1, np.uint32), np.uint32).tobytes()
        if self._program_buffer is None or self._program_buffer.size < len(data):
            if self._program_buffer is not None:
                self._program_buffer.release()
            self._program_buffer = self.ctx.buffer(reserve=max(len(data), 256))
        self._program_buffer.write(data)
        target = self._target()
        images = self._images if self._images is not None else self._no_textures
        lod = max(0.0, math.log2(images.size[0] / target.size[0])) if self._images is not None else 0.0
        # The node families the World's nodes need (Mix, Math, Mapping...), as the scene's
        # material shaders get theirs: a new family costs one compile.
        # A World has no mesh or object: its Attribute nodes read as missing, with no store.
        defines = {family: 1 for family in sorted(program.families - {FAMILY_ATTRIBUTES})}
        # tex_sky.glsl: the scattering models' and Hosek-Wilkie's code, only where a World uses it
        defines.update({name: 1 for name in self.sky_tables.defines})
        prog = shader_loader.compute(self.ctx, "lighting/world_bake.comp.glsl", defines or None)
        bind(prog, storage={"NodeProgram": self._program_buffer, "NodeObjects": self._objects},
             images={"u_target": Image(target, read=False, write=True)},
             textures={"u_world_images": images, "u_textures": self._no_textures,
                       "u_sky_transmittance": self.sky_tables.texture},
             uniforms={"u_world_lod": lod})
        prog.run(-(-target.size[0] // _GROUP), -(-target.size[1] // _GROUP), 1)
        self.ctx.memory_barrier()
        target.build_mipmaps()
        target.filter = (self.ctx.LINEAR_MIPMAP_LINEAR, self.ctx.LINEAR)

    def release(self) -> None:
        self.sky_tables.release()
        for obj in (self.texture, self._program_buffer, self._objects, self._no_textures, self._images):
            if obj is not None:
                obj.release()
        self.texture = self._program_buffer = self._images = None
        self._key = self._image_key = None
