# SPDX-License-Identifier: GPL-3.0-or-later
"""Batched Cycles-vs-GLSL comparisons for the colour and vector nodes, on exact inputs.

The plane's pixel centres sit at whole-plus-half object coordinates (extent = size / 2), so
``floor(x + extent)`` is the pixel's column index in Cycles as in GLSL, though Cycles' x is a
ray-plane hit a few ulps off the centre. Every node input is then an affine function of the
column u and row v with short binary fractions (``u * su + v * sv + o``), which both sides
compute exactly: what differs between the two images is the node's own arithmetic, and a
discontinuous operation (floor, compare, modulo) is compared on the very same inputs.

Many cases share one compute shader: the probe point's w carries the case number. Cycles needs
one small render per case (a few hundredths of a second each)."""
from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from node_oracle import cycles_emission_plane, glsl_probe, plane_points

SIZE = 32
EXTENT = SIZE / 2.0

Spec = tuple[float, float, float]  # (su, sv, o): the input u * su + v * sv + o


def glsl_float(x: float) -> str:
    """A GLSL float literal holding x exactly (inputs are short binary fractions)."""
    text = repr(float(x))
    return text if ("." in text or "e" in text or "inf" in text) else text + ".0"


def glsl_affine(spec: Spec) -> str:
    su, sv, o = spec
    return f"(uv.x * {glsl_float(su)} + uv.y * {glsl_float(sv)} + {glsl_float(o)})"


def glsl_vec3(specs: tuple[Spec, Spec, Spec]) -> str:
    return "vec3(" + ", ".join(glsl_affine(s) for s in specs) + ")"


def by_id(sockets, identifier: str):
    """A node's socket by identifier (names repeat across a Mix node's data types)."""
    return next(s for s in sockets if s.identifier == identifier)


class Grid:
    """Cycles sockets for the pixel's (u, v) and affine inputs built from them."""

    def __init__(self, nodes, links, vector) -> None:
        self.nodes, self.links = nodes, links
        split = nodes.new("ShaderNodeSeparateXYZ")
        links.new(vector, split.inputs[0])
        self.u = self._floor(split.outputs["X"])
        self.v = self._floor(split.outputs["Y"])

    def _math(self, operation: str, a, b=None):
        node = self.nodes.new("ShaderNodeMath")
        node.operation = operation
        for socket, value in ((node.inputs[0], a), (node.inputs[1], b)):
            if value is None:
                continue
            if isinstance(value, (int, float)):
                socket.default_value = float(value)
            else:
                self.links.new(value, socket)
        return node.outputs[0]

    def _floor(self, coordinate):
        return self._math("FLOOR", self._math("ADD", coordinate, EXTENT))

    def scalar(self, spec: Spec):
        su, sv, o = spec
        return self._math("ADD", self._math("ADD", self._math("MULTIPLY", self.u, su),
                                            self._math("MULTIPLY", self.v, sv)), o)

    def vector(self, specs: tuple[Spec, Spec, Spec]):
        combine = self.nodes.new("ShaderNodeCombineXYZ")
        for k, spec in enumerate(specs):
            self.links.new(self.scalar(spec), combine.inputs[k])
        return combine.outputs[0]

    def color(self, specs: tuple[Spec, Spec, Spec]):
        combine = self.nodes.new("ShaderNodeCombineColor")
        combine.mode = "RGB"
        for k, spec in enumerate(specs):
            self.links.new(self.scalar(spec), combine.inputs[k])
        return combine.outputs[0]


@dataclass
class Case:
    """One node configuration: ``build(grid)`` adds it in Cycles and returns the socket shown;
    ``glsl`` is the probe's statements (``uv`` is the pixel's (u, v)) ending in a return of
    a vec4 whose rgb is compared, or a function giving them once Cycles has rendered (for
    tables baked from the Blender objects that ``build`` made). Such a function receives
    ``add_rows(values) -> first index``, which stores (n, <= 4) floats where the probe reads
    them as ``points[first index + k]``, as a table in a GPU buffer."""
    name: str
    build: Callable[[Grid], object]
    glsl: str | Callable[[Callable[[np.ndarray], int]], str]


def render_cases(ctx, out_dir, cases: list[Case], includes: list[str]) -> list[tuple[np.ndarray, np.ndarray]]:
    """(cycles, ours) (SIZE, SIZE, 3) images per case; one shader for all cases."""
    images = []
    for case in cases:
        def build(nodes, links, vector, case=case):
            return case.build(Grid(nodes, links, vector))
        images.append(cycles_emission_plane(build, out_dir, SIZE, EXTENT))
    pixels = len(cases) * SIZE * SIZE
    extra: list[np.ndarray] = []

    def add_rows(values: np.ndarray) -> int:
        rows = np.zeros((len(values), 4), np.float32)
        rows[:, : np.asarray(values).shape[1]] = values
        first = pixels + sum(len(e) for e in extra)
        extra.append(rows)
        return first

    sources = [case.glsl(add_rows) if callable(case.glsl) else case.glsl for case in cases]
    stacked = np.zeros((len(cases), SIZE, SIZE, 4), np.float32)
    stacked[..., :3] = plane_points(SIZE, EXTENT)
    stacked[..., 3] = np.arange(len(cases), dtype=np.float32)[:, None, None]
    # The table rows run through the probe too; their results are dropped.
    rows = np.concatenate([stacked.reshape(-1, 4), *extra])
    branches = "\n".join(f"    if (case_index == {k}) {{\n{source}\n    }}" for k, source in enumerate(sources))
    body = (f"    vec2 uv = floor(p.xy + {glsl_float(EXTENT)});\n"
            f"    int case_index = int(p.w);\n{branches}\n    return vec4(0.0);")
    ours = glsl_probe(ctx, includes, body, rows)[:pixels, :3].reshape(len(cases), SIZE, SIZE, 3)
    return [(cycles, ours[k]) for k, cycles in enumerate(images)]


def errors(cycles: np.ndarray, ours: np.ndarray) -> np.ndarray:
    """Absolute difference, relative above magnitude 1; a NaN on one side only is infinite."""
    diff = np.abs(ours.astype(np.float64) - cycles) / np.maximum(1.0, np.abs(cycles))
    both_nan = np.isnan(ours) & np.isnan(cycles)
    diff[both_nan] = 0.0
    diff[np.isnan(diff)] = np.inf
    return diff


def check_cases(ctx, out_dir, cases: list[Case], includes: list[str],
                mean_bar: float = 0.01, p99_bar: float = 0.02) -> dict[str, tuple[float, float, float]]:
    """Render every case on both sides and assert the issue's bar (mean <= 1 %, 99th
    percentile <= 2 %) and that its first channel varies (a constant image proves little).
    Returns {name: (mean, p99, max)} for reports."""
    results, failures = {}, []
    for case, (cycles, ours) in zip(cases, render_cases(ctx, out_dir, cases, includes)):
        e = errors(cycles, ours)
        mean, p99, worst = float(e.mean()), float(np.percentile(e, 99)), float(e.max())
        results[case.name] = (mean, p99, worst)
        if not np.isfinite(cycles).all() or np.ptp(cycles[..., 0]) == 0.0:
            failures.append(f"{case.name}: Cycles' image is constant or not finite")
        elif not (mean <= mean_bar and p99 <= p99_bar):
            failures.append(f"{case.name}: mean {mean:.3g} p99 {p99:.3g} max {worst:.3g}")
    if os.environ.get("HYBRID_NODE_REPORT"):  # per-case figures for reports: pytest -s
        for name, (mean, p99, worst) in results.items():
            print(f"{name:>28s} mean {mean:.2e} p99 {p99:.2e} max {worst:.2e}")
    assert not failures, "\n".join(failures)
    return results
