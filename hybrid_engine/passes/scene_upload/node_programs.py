# SPDX-License-Identifier: GPL-3.0-or-later
"""The materials' node programs on the GPU: the words of every graph (scene/node_program.py)
in one storage buffer, and per instance what the programs' input nodes read of their object
(gpu_shaders/include/node_program.glsl, blocks ``NodeProgram`` and ``NodeObjects``).

The program words are compiled on the host at every upload (a graph of tens of nodes is
tens of microseconds) and sent only when they differ from what the GPU holds: a value
edit is an upload of words, never a shader compile. A scene without graphs has neither
buffer bound nor the interpreter compiled (``GPUScene.defines``).

Per instance (``NODE_OBJECT_DTYPE``): the world-to-object map (Texture Coordinate Object,
Generated, Normal Map in object space), the origin (Object Info Location), Object Info
Random (a hash of the instance's index: stable from frame to frame, different between
instances; Blender's own hashes the object's name, which the instance table does not
carry), the object colour (white: the table carries none) and the texture space of
Generated (the mesh's object-space bounds, Blender's automatic texture space: ``texture_space``).
"""
from __future__ import annotations

import os

import numpy as np

from ...gpu import shader_loader
from ...gpu.dispatch import GrowBuffer
from ...scene.closure_alpha import closure_alpha_graph, row_reads_coverage
from ...scene.data import MaterialTable
from ...scene.geometry import InstancedGeometry
from ...scene.matrix4 import affine_inverses
from ...scene.node_program import DISPATCH_NONE, ProgramTable, compile_graph, compile_table, row_estimate
from .node_codegen import GeneratedPrograms, generate

# Set to "interpreter" to run every program in the interpreter (tests compare the two ways).
MODE_ENVIRONMENT_VARIABLE = "HYBRID_RT_NODE_PROGRAMS"
NODE_OBJECT_DTYPE = np.dtype([("to_object", np.float32, (3, 4)), ("location", np.float32, 4),
                              ("color", np.float32, 4), ("space_min", np.float32, 4),
                              ("space_size", np.float32, 4), ("rows", np.int32, 4)])
assert NODE_OBJECT_DTYPE.itemsize == 128


# Blender's automatic texture space (BKE_mesh_texspace_calc) widens an axis thinner than this
# half-size to it. Such an axis is a flat mesh's rounding noise (a grid primitive, a plane
# whose rotation was applied): Blender's Generated there is 0.5 to a few parts in 1e10,
# interpolated from the corners. Taken from a shading point's position, which carries the
# float error of its world coordinates, the noise would be blown up to a visible fraction of
# 0..1, so such an axis is taken as flat (size 0: Generated reads 0.5 across it).
TEXTURE_SPACE_MIN_HALF_SIZE = 1e-5


def texture_space(positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The corner and size of Generated's box over a mesh's object-space ``positions``
    (Generated = (p - corner) / size; include/node_program.glsl ``node_generated``), as
    Blender's automatic texture space makes it: the bounds of the finite points, an axis
    thinner than ``TEXTURE_SPACE_MIN_HALF_SIZE`` flat (size 0, its corner the centre). No
    finite point: flat at the origin."""
    p = np.asarray(positions, np.float32).reshape(-1, 3)
    p = p[np.isfinite(p).all(axis=1)]
    if not len(p):
        return np.zeros(3, np.float32), np.zeros(3, np.float32)
    lo, hi = p.min(axis=0), p.max(axis=0)
    flat = (hi - lo) * np.float32(0.5) < TEXTURE_SPACE_MIN_HALF_SIZE
    centre = (lo + hi) * np.float32(0.5)
    return np.where(flat, centre, lo), np.where(flat, np.float32(0.0), hi - lo)


def instance_random(count: int) -> np.ndarray:
    """Object Info Random of instances 0..count-1: a 32-bit integer hash of the index
    (lowbias32) to [0, 1)."""
    x = np.arange(count, dtype=np.uint64) + np.uint64(0x9E3779B9)
    mask = np.uint64(0xFFFFFFFF)
    x = (x ^ (x >> np.uint64(16))) * np.uint64(0x7FEB352D) & mask
    x = (x ^ (x >> np.uint64(15))) * np.uint64(0x846CA68B) & mask
    x = x ^ (x >> np.uint64(16))
    return (x.astype(np.float64) / 4294967296.0).astype(np.float32)


class NodePrograms:
    """The program words and the per-instance table, uploaded when they change."""

    def __init__(self, ctx) -> None:
        self.words = GrowBuffer(ctx, "node program words")
        self.objects = GrowBuffer(ctx, "node program objects")
        self.table: ProgramTable | None = None
        self._sent_words: bytes | None = None
        self._sent_objects: bytes | None = None
        self._bounds: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
        self.word_uploads = 0  # times the words were sent (tests: an unchanged scene sends none)
        self.closure_alpha = False  # some material's coverage is an alpha program (closure alpha)
        # The alpha programs' words and where they start: what a cache of coverage (the shadow
        # maps' static layer) must be keyed by, since a value edit changes nothing else.
        self.alpha_key = b""
        # Run the programs as generated GLSL (node_codegen.py), the default on llvmpipe and on
        # GPUs alike (docs/BENCHMARKS.md "Shader node programs"); False: the interpreter only;
        # None: as MODE_ENVIRONMENT_VARIABLE says.
        self.generate: bool | None = None
        self.generated: GeneratedPrograms | None = None  # the programs' generated GLSL, if run
        self.generated_key: str | None = None  # its shader_loader.register_source key
        self._generated_for: bytes | None = None

    @property
    def defines(self) -> dict:
        """``NODE_GENERATED`` (the generated source's key) where the programs run as
        generated GLSL, and ``NODE_GENERATED_ONLY`` where every program has its function
        (the interpreter is then left out); nothing where the interpreter runs them all."""
        if self.generated_key is None or self.generated is None or not self.generated.topologies:
            return {}
        return {"NODE_GENERATED": self.generated_key, **({"NODE_GENERATED_ONLY": 1} if self.generated.complete else {})}

    def _generate(self, table: ProgramTable) -> None:
        """Give each program the generated function of its topology (node_codegen.py) unless
        the interpreter is asked for; regenerated only when the words change, and the same
        topologies give the same source (no compile)."""
        wanted = self.generate
        if wanted is None:
            wanted = os.environ.get(MODE_ENVIRONMENT_VARIABLE, "").strip().lower() != "interpreter"
        if not wanted:
            self.generated, self.generated_key, self._generated_for = None, None, None
            return
        key = table.words.tobytes() + table.offsets.tobytes()
        if key != self._generated_for or self.generated is None:
            self.generated = generate(table)
            self.generated_key = shader_loader.register_source(self.generated.source)
            self._generated_for = key
        offsets = table.offsets
        table.words[offsets[offsets >= 0] - 1] = self.generated.dispatch[offsets >= 0]

    @property
    def active(self) -> bool:
        return self.table is not None and not self.table.empty

    def update(self, materials: MaterialTable, rows: np.ndarray, geometry: InstancedGeometry) -> None:
        """Compile the table's graphs, put each program's offset (and the host's estimate of
        its closure, node_program.row_estimate) into the packed material ``rows``, and send
        what changed."""
        graphs = materials.node_graphs
        self.closure_alpha = False
        self.alpha_key = b""
        if not graphs or all(g is None for g in graphs):
            self.table = None
            self.generated, self.generated_key, self._generated_for = None, None, None
            return
        self.table = compile_table(graphs, len(materials), materials.names)
        # The alpha programs follow the surface programs, each after its own dispatch word,
        # so that generated code runs them as it runs the surfaces' (node_generated_run reads
        # the word before a program).
        alpha_words, alpha_offsets, alpha_programs = self._closure_alpha(graphs, materials.names, rows)
        self.alpha_key = alpha_words.tobytes() + alpha_offsets.tobytes()
        run = ProgramTable(np.concatenate([self.table.words, alpha_words]).astype(np.uint32),
                           np.concatenate([self.table.offsets, alpha_offsets]).astype(np.int32),
                           list(self.table.programs) + alpha_programs, self.table.attributes)
        self._generate(run)
        self.table.words[:] = run.words[:len(self.table.words)]  # the surfaces' dispatch words
        rows["textures2"][:, 3] = self.table.offsets
        for m, graph in enumerate(graphs):
            if graph is None:
                continue
            estimate = row_estimate(graph)
            rows["emission"][m, :3] = estimate["emission"]
            rows["emission"][m, 3] = estimate["transmission"]
            rows["params"][m, 0] = estimate["ior"]
            rows["base_color"][m, 3] = 0.0
            rows["textures"][m] = (-1, -1, -1, 0)
            # The program gives roughness and metallic; the alpha image (z) and alpha stay
            # the row's unless the graph has a closure alpha (below).
            rows["textures2"][m, :2] = -1
        words = run.words.tobytes() or bytes(4)
        if words != self._sent_words:
            self.words.upload(words)
            self._sent_words = words
            self.word_uploads += 1
        objects = self._objects(geometry).tobytes()
        if objects != self._sent_objects:
            self.objects.upload(objects)
            self._sent_objects = objects

    # -- closure alpha
    def _closure_alpha(self, graphs, names, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, list]:
        """The alpha programs (scene/closure_alpha.py) of the graphs that have a closure
        alpha, placed after the table's words, each after a dispatch word as the table's
        programs are: such a row's alpha image slot holds -2 - the program's first word
        (include/alpha.glsl), and its alpha factor and clip are 1 and none, since the program
        gives the whole coverage. Compiled with the table's attribute slots, so an alpha that
        reads a Color Attribute reads the surface program's slot. Returns the words, the
        programs' first words and the programs."""
        at = len(self.table.words)
        chunks: list[np.ndarray] = []
        offsets: list[int] = []
        programs: list = []
        for m, graph in enumerate(graphs):
            alpha_graph = closure_alpha_graph(graph)
            if alpha_graph is None or (rows["textures2"][m, 2] >= 0 and row_reads_coverage(graph)):
                continue  # opaque, or the row's alpha image holds the coverage (closure_alpha.py)
            name = f"{names[m] if names else f'material {m}'} (alpha)"
            program = compile_graph(alpha_graph, name, attributes=self.table.attributes)
            at += 1  # the dispatch word
            rows["textures2"][m, 2] = -2 - at
            rows["params2"][m, :2] = (1.0, 0.0)
            chunks += [np.array([DISPATCH_NONE], np.uint32), program.words.astype(np.uint32)]
            offsets.append(at)
            programs.append(program)
            at += len(program.words)
            self.closure_alpha = True
        words = np.concatenate(chunks) if chunks else np.zeros(0, np.uint32)
        return words, np.array(offsets, np.int32), programs
    # -- end of closure alpha

    def _mesh_bounds(self, mesh) -> tuple[np.ndarray, np.ndarray]:
        key = (mesh.mesh_id, mesh.version, id(mesh.positions))
        found = self._bounds.get(key)
        if found is None:
            found = texture_space(mesh.positions)
            if len(self._bounds) > 4096:
                self._bounds.clear()
            self._bounds[key] = found
        return found

    def _objects(self, geometry: InstancedGeometry) -> np.ndarray:
        """The NodeObjects block: a header row (x = the instance count) and one row per instance."""
        instances = geometry.instances
        k = len(instances)
        out = np.zeros(k + 1, NODE_OBJECT_DTYPE)
        out["rows"][0, 0] = k
        if k == 0:
            return out
        body = out[1:]
        # World-to-object rows (K, 3, 4).
        body["to_object"] = affine_inverses(instances.matrices)[:, :3, :].astype(np.float32)
        body["location"][:, :3] = instances.matrices[:, :3, 3]
        body["location"][:, 3] = (instance_random(k) if instances.random_ids is None
                                  else (instances.random_ids.astype(np.float64) / 4294967295.0).astype(np.float32))
        body["color"] = 1.0 if instances.colors is None else instances.colors
        bounds = [self._mesh_bounds(mesh) for mesh in instances.meshes]
        mins = np.array([b[0] for b in bounds], np.float32).reshape(-1, 3)
        sizes = np.array([b[1] for b in bounds], np.float32).reshape(-1, 3)
        body["space_min"][:, :3] = mins[instances.mesh]
        body["space_size"][:, :3] = sizes[instances.mesh]
        body["rows"][:, :2] = geometry.object_ranges
        return out

    def bindings(self) -> dict:
        return {"NodeProgram": self.words.buffer, "NodeObjects": self.objects.buffer}

    def release(self) -> None:
        self.words.release()
        self.objects.release()
