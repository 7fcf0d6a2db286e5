# SPDX-License-Identifier: GPL-3.0-or-later
"""What the node interpreter's texture families cost to compile: ``python -m benchmarks.node_family_compile``.

Usage::

    python -m benchmarks.node_family_compile [--rounds N] [--shader trace/hybrid_trace.comp.glsl]

Compiles one shader that runs node programs (by default the tracer's megakernel) with no
node programs, with the interpreter and no texture family, with each family alone and with
every family (node_codes.TEXTURE_FAMILIES), alternating the configurations round by round
(the machine's speed drifts within a run), and prints the median wall time of each compile
and its ratio to the interpreter without families. A nonce define makes every compile a
new source, so neither moderngl's nor the driver's shader cache answers.
"""
from __future__ import annotations

import argparse
import statistics
import time

from hybrid_engine.gpu import gl_context, shader_loader
from hybrid_engine.scene import node_codes as nc

ROUNDS = 3


def configurations() -> dict[str, dict[str, int]]:
    families = sorted(set(nc.TEXTURE_FAMILIES.values()))
    configs: dict[str, dict[str, int]] = {"no node programs": {}, "interpreter, no family": {"NODE_PROGRAMS": 1}}
    for family in families:
        configs[family] = {"NODE_PROGRAMS": 1, family: 1}
    configs["every family"] = {"NODE_PROGRAMS": 1, **{f: 1 for f in families}}
    return configs


def measure(shader: str, rounds: int) -> dict[str, list[float]]:
    ctx = gl_context.get_context()
    times: dict[str, list[float]] = {name: [] for name in configurations()}
    nonce = int(time.time())
    for round_ in range(rounds):
        for name, defines in configurations().items():
            nonce += 1
            ctx.finish()
            start = time.perf_counter()
            shader_loader.compute(ctx, shader, {**defines, "NODE_COMPILE_BENCH_NONCE": nonce})
            ctx.finish()
            times[name].append(time.perf_counter() - start)
    return times


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=ROUNDS)
    parser.add_argument("--shader", default="trace/hybrid_trace.comp.glsl")
    args = parser.parse_args(argv)
    times = measure(args.shader, args.rounds)
    base = statistics.median(times["interpreter, no family"])
    print(f"{args.shader} on {gl_context.renderer_name()}, median of {args.rounds} compiles")
    for name, values in times.items():
        median = statistics.median(values)
        print(f"  {name:24s} {median:7.2f} s  x{median / base:5.2f}")


if __name__ == "__main__":
    main()
