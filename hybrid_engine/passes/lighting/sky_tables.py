# SPDX-License-Identifier: GPL-3.0-or-later
"""What a World's Sky Textures need before the bake: the Multiple Scattering sky's
transmittance tables, made on the GPU, and the Hosek-Wilkie sky's parameters for its sun.

Blender's Multiple Scattering model (García Liñán's spectral sky) reads, at each of the 64
steps along a view ray, how much sunlight reaches that point through the atmosphere, and how
much reaches the ground below it. Marching towards the sun from every step of every texel
would cost 64 x 64 density evaluations a texel; as in Blender, a table of the transmittance
to the top of the atmosphere by zenith angle and altitude (256 x 64, include/nodes/
sky_atmosphere.glsl) is made once and read bilinearly. It depends only on the node's three
densities (Air, Aerosol, Ozone), so each Multiple Scattering node of the World gets its own
block of rows in one texture (``sky_table_row``), remade only when the densities change.
A Hosek-Wilkie node gets the model's 30 numbers for its sun, turbidity and albedo
(``hosek_state``, sky_hosek.py) in its words, as Cycles computes them on the host.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ...gpu import shader_loader
from ...gpu.bindings import Image, bind
from ...scene.shader_graph import ShaderGraph
from ...scene.sky_hosek import hosek_state

TABLE_WIDTH = 256  # sky_atmosphere.glsl SKY_LUT_W
TABLE_ROWS = 64  # SKY_LUT_H: one node's block
_GROUP = 8  # sky_transmittance.comp.glsl local size


def _densities(settings: dict) -> tuple[float, float, float]:
    return tuple(float(settings.get(name, 1.0)) for name in ("air_density", "aerosol_density", "ozone_density"))


def _scattering(node) -> bool:
    return node.kind == "TEX_SKY" and str(node.settings.get("sky_type", "MULTIPLE_SCATTERING")) in (
        "MULTIPLE_SCATTERING", "SINGLE_SCATTERING")


def _hosek(node) -> bool:
    return node.kind == "TEX_SKY" and str(node.settings.get("sky_type")) == "HOSEK_WILKIE"


def _uses_table(node) -> bool:
    return node.kind == "TEX_SKY" and str(node.settings.get("sky_type", "MULTIPLE_SCATTERING")) == "MULTIPLE_SCATTERING"


class SkyTables:
    """``texture``: the stacked tables of the last graph given (a 1 x 1 stand-in without any)."""

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.texture = ctx.texture((1, 1), 4, np.ones(4, np.float32).tobytes(), dtype="f4")
        self.made = 0  # tables computed (tests, statistics)
        # The models of the last graph that tex_sky.glsl compiles in on demand (world_bake.py).
        self.defines: tuple[str, ...] = ()
        self._key: tuple = ()

    @staticmethod
    def assign(graph: ShaderGraph) -> ShaderGraph:
        """``graph`` with each Multiple Scattering node's ``sky_table_row`` and each Hosek-Wilkie
        node's ``hosek_state`` (sky_hosek.py) set: a copy when any is."""
        if not any(_uses_table(node) or _hosek(node) for node in graph.nodes):
            return graph
        nodes, block = [], 0
        for node in graph.nodes:
            if _uses_table(node):
                node = dataclasses.replace(node, settings={**node.settings, "sky_table_row": block * TABLE_ROWS})
                block += 1
            elif _hosek(node):
                state = hosek_state(node.settings.get("sun_direction", (0.0, 0.0, 1.0)),
                                    float(node.settings.get("turbidity", 2.2)),
                                    float(node.settings.get("ground_albedo", 0.3)))
                node = dataclasses.replace(node, settings={**node.settings, "hosek_state": tuple(state)})
            nodes.append(node)
        return dataclasses.replace(graph, nodes=nodes)

    def update(self, graph: ShaderGraph) -> None:
        """Make the tables of ``graph`` (as ``assign`` numbered them) unless they are made."""
        self.defines = tuple(name for name, used in (
            ("NODE_SKY_SCATTERING", any(_scattering(node) for node in graph.nodes)),
            ("NODE_SKY_HOSEK", any(_hosek(node) for node in graph.nodes))) if used)
        key = tuple(_densities(node.settings) for node in graph.nodes if _uses_table(node))
        if key == self._key or not key:
            return
        height = TABLE_ROWS * len(key)
        if self.texture.size != (TABLE_WIDTH, height):
            self.texture.release()
            self.texture = self.ctx.texture((TABLE_WIDTH, height), 4, dtype="f4")
            self.texture.filter = (self.ctx.LINEAR, self.ctx.LINEAR)  # tex_sky.glsl reads it filtered
            self.texture.repeat_x = self.texture.repeat_y = False
        prog = shader_loader.compute(self.ctx, "lighting/sky_transmittance.comp.glsl")
        for block, density in enumerate(key):
            bind(prog, images={"u_target": Image(self.texture, read=False, write=True)},
                 uniforms={"u_row": block * TABLE_ROWS, "u_density": density})
            prog.run(-(-TABLE_WIDTH // _GROUP), -(-TABLE_ROWS // _GROUP), 1)
        self.ctx.memory_barrier()
        self.made += len(key)
        self._key = key

    def release(self) -> None:
        self.texture.release()
        self._key = ()
