# SPDX-License-Identifier: GPL-3.0-or-later
"""The two shapes of the sort and scan kernels side by side: ``python -m benchmarks.kernel_variants``.

Usage::

    python -m benchmarks.kernel_variants [--quick] [--rounds N] [--json PATH]

Contenders, each in its ``"cpu"`` (llvmpipe-shaped) and ``"gpu"`` (GPU-shaped) form
(:mod:`hybrid_engine.gpu.variants`):

* the radix sort of 2^20 random 30-bit keys with their indices (``RadixSort.sort``, 4 passes;
  the GPU shape with its multi-workgroup histogram scan);
* one exclusive scan of 10^6 and of 4,096 counts (``PrefixScan.run``; 4,096 is the near-cube
  cull's chunk count for 4M triangles);
* the LBVH build over a mesh-like scene of 10^6 triangles with each sort shape
  (``LBVHBuilder(sort_family=...)``, as bench.py's lbvh section builds).

Method: the machine's speed drifts within a run, so the contenders of each row alternate round
by round after one warm-up each, and the report gives medians and their ratio (gpu / cpu) from
the same run. A run re-uploads its input first (the sort and scan work in place) and is
timed as wall clock bracketed by ``ctx.finish()``; the upload is outside the bracket.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path
from typing import Callable

import numpy as np

from hybrid_engine.gpu import gl_context
from hybrid_engine.gpu.prefix_scan import PrefixScan
from hybrid_engine.gpu.radix_sort import RadixSort
from hybrid_engine.passes.lbvh import lbvh

from .bench import SEED, _interleaved, gpu_build_ms, machine_info, mesh_like_scene

FAMILIES = ("cpu", "gpu")
FULL = {"sort_keys": 1 << 20, "scan_counts": (1_000_000, 4096), "build_triangles": 1_000_000}
QUICK = {"sort_keys": 5000, "scan_counts": (3000, 100), "build_triangles": 5000}
SORT_BITS = 30
ROUNDS = 7


def _timed(ctx, prepare: Callable[[], None], work: Callable[[], object]) -> float:
    """Milliseconds of ``work`` after ``prepare`` (not timed), bracketed by ctx.finish()."""
    prepare()
    ctx.finish()
    start = time.perf_counter()
    work()
    ctx.finish()
    return (time.perf_counter() - start) * 1e3


def _row(name: str, medians: dict[str, float]) -> dict:
    return {"name": name, "cpu_ms": round(medians["cpu"], 4), "gpu_ms": round(medians["gpu"], 4),
            "gpu_over_cpu": round(medians["gpu"] / medians["cpu"], 3)}


def sort_row(ctx, rng: np.random.Generator, count: int, rounds: int) -> dict:
    keys = rng.integers(0, 1 << SORT_BITS, count).astype(np.uint32)
    key_bytes, value_bytes = keys.tobytes(), np.arange(count, dtype=np.uint32).tobytes()
    buffers = [ctx.buffer(reserve=count * 4) for _ in range(4)]
    sorters = {family: RadixSort(ctx, family, scan_family=family) for family in FAMILIES}

    def prepare() -> None:
        buffers[0].write(key_bytes)
        buffers[2].write(value_bytes)

    def contender(family: str) -> Callable[[], float]:
        return lambda: _timed(ctx, prepare, lambda: sorters[family].sort(buffers[:2], buffers[2:], count, SORT_BITS))

    try:
        return _row(f"sort {count:,} keys ({SORT_BITS} bits)", _interleaved({f: contender(f) for f in FAMILIES}, rounds))
    finally:
        for sorter in sorters.values():
            sorter.release()
        for buffer in buffers:
            buffer.release()


def scan_row(ctx, rng: np.random.Generator, count: int, rounds: int) -> dict:
    counts = rng.integers(0, 1025, count).astype(np.uint32)
    data_bytes = np.append(counts, np.uint32(0)).tobytes()
    buffer = ctx.buffer(reserve=len(data_bytes))
    scans = {family: PrefixScan(ctx, family) for family in FAMILIES}

    def contender(family: str) -> Callable[[], float]:
        return lambda: _timed(ctx, lambda: buffer.write(data_bytes), lambda: scans[family].run(buffer, count))

    try:
        return _row(f"scan {count:,} counts", _interleaved({f: contender(f) for f in FAMILIES}, rounds))
    finally:
        for scan in scans.values():
            scan.release()
        buffer.release()


def build_row(ctx, rng: np.random.Generator, triangles: int, rounds: int) -> dict:
    tris = mesh_like_scene(triangles, rng)
    buffer = ctx.buffer(tris.tobytes())
    builders = {family: lbvh.LBVHBuilder(ctx, sort_family=family, scan_family=family) for family in FAMILIES}

    def contender(family: str) -> Callable[[], float]:
        return lambda: gpu_build_ms(builders[family], buffer, len(tris))

    try:
        return _row(f"LBVH build {triangles:,} triangles", _interleaved({f: contender(f) for f in FAMILIES}, rounds))
    finally:
        for builder in builders.values():
            builder.release()
        buffer.release()


def commit() -> str:
    """The checked-out commit (and whether the tree differs from it), for the report."""
    root = Path(__file__).resolve().parent.parent
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=root, capture_output=True,
                              text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=root,
                               capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + ("+changes" if dirty else "")


def run(quick: bool = False, rounds: int = ROUNDS) -> dict:
    ctx = gl_context.get_context()
    sizes = QUICK if quick else FULL
    rng = np.random.default_rng(SEED)
    rows = [sort_row(ctx, rng, sizes["sort_keys"], rounds)]
    rows += [scan_row(ctx, rng, count, rounds) for count in sizes["scan_counts"]]
    rows.append(build_row(ctx, rng, sizes["build_triangles"], rounds))
    return {"machine": machine_info(), "commit": commit(), "rounds": rounds, "rows": rows}


def format_table(report: dict) -> str:
    machine = report["machine"]
    lines = [f"renderer: {machine['gl_renderer']}, {machine['cpu_count']} CPUs; commit {report['commit']}",
             f"GPU times: {machine['gpu_timing']}; medians of {report['rounds']} alternating rounds", "",
             f"{'':<36} {'cpu ms':>9} {'gpu ms':>9} {'gpu/cpu':>8}"]
    for row in report["rows"]:
        lines.append(f"{row['name']:<36} {row['cpu_ms']:>9.2f} {row['gpu_ms']:>9.2f} {row['gpu_over_cpu']:>8.2f}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="tiny sizes (a smoke test)")
    parser.add_argument("--rounds", type=int, default=ROUNDS, help=f"alternating rounds (default {ROUNDS})")
    parser.add_argument("--json", type=Path, help="also write the report here")
    args = parser.parse_args(argv)
    report = run(args.quick, args.rounds)
    print(format_table(report))
    if args.json:
        args.json.write_text(json.dumps(report, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
