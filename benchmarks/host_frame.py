# SPDX-License-Identifier: GPL-3.0-or-later
"""The host's (Python's) work per HYBRID Chess frame, without Blender.

``python -m benchmarks.host_frame [--detail 1] [--frames 8] [--kernels gpu] [--json PATH]``

A frame is real time on a GPU only if the host records its commands faster than the GPU runs
them; a frame whose main thread is busy for as long as the frame lasts leaves the GPU waiting on
Python. This measures that main thread: ``time.thread_time()`` around ``Renderer.render`` with
``timing=False`` (no ``ctx.finish()`` per pass) and ``read_image=False`` (the final read-back
waits for the GPU, which is not the host's work), HYBRID Chess (``benchmarks/scenes/chess.py``)
at the frame target's settings (max depth 4, cube faces 512), for two kinds of frame:

``moving``
    The animation's frames in turn: every piece that moves, the spheres and the camera.
``still``
    The same scene and camera again: nothing changed, as a viewport redraws.

``thread_time`` counts the calling thread only. llvmpipe runs fragment and compute work on
threads of its own, so what it adds here is its vertex processing and binning of the draws
(done on the calling thread), which depends on the triangle count; a small ``--detail`` keeps
that small and leaves mostly the Python a GPU driver would also pay. The resolution hardly
matters to the host: ``--resolution`` lets that be checked. ``--kernels`` forces the kernel
shapes (``gpu/variants.py``): ``gpu`` (the default) is what a GPU runs, so the host work
measured is a GPU's.

``--root`` imports ``hybrid_engine`` from another checkout, so that two trees can be measured
side by side by alternating processes (``--compare``: rounds of A then B, medians of each).
"""
from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

REPOSITORY = Path(__file__).resolve().parent.parent
WARM_UP_FRAMES = 2  # the first uploads everything; the second teaches the shadow cache what moves
FIRST_FRAME = 0
RESOLUTION = (320, 180)
CUBE_RESOLUTION = 512
MAX_DEPTH = 4
NEAR_SIZE = 3.5


class DrawClock:
    """Main-thread CPU time spent inside moderngl's draw calls: on llvmpipe the vertex
    processing and binning of a draw run there, work a GPU does itself."""

    NAMES = ("render", "render_indirect")

    def __init__(self) -> None:
        self.seconds = 0.0
        self._saved: dict[str, object] = {}

    def __enter__(self) -> "DrawClock":
        import moderngl

        for name in self.NAMES:
            original = self._saved[name] = getattr(moderngl.VertexArray, name)

            def timed(*args, _original=original, **kwargs):
                start = time.thread_time()
                try:
                    return _original(*args, **kwargs)
                finally:
                    self.seconds += time.thread_time() - start

            setattr(moderngl.VertexArray, name, timed)
        return self

    def __exit__(self, *exc) -> None:
        import moderngl

        for name, original in self._saved.items():
            setattr(moderngl.VertexArray, name, original)


def measure(detail: float, frames: int, resolution: tuple[int, int], kernels: str) -> dict:
    """Main-thread CPU milliseconds per frame, moving and still (lists, in frame order):
    ``*_ms`` all of it, ``*_python_ms`` less the time inside draw calls (DrawClock)."""
    from hybrid_engine.frame.renderer import Renderer
    from hybrid_engine.gpu import gl_context, variants
    from hybrid_engine.scene.settings import RenderSettings

    from benchmarks.scenes.chess import CHESS_CUBE_FAR, build_chess

    variants.set_override(kernels)
    ctx = gl_context.get_context()
    width, height = resolution
    settings = RenderSettings(mode="HYBRID", near_size=NEAR_SIZE, cube_far=CHESS_CUBE_FAR, max_depth=MAX_DEPTH,
                              cube_resolution=CUBE_RESOLUTION, cube_back_layer=True)
    scenes = [build_chess(detail, FIRST_FRAME + k, width, height) for k in range(WARM_UP_FRAMES + frames)]
    renderer = Renderer(ctx)
    found: dict[str, list[tuple[float, float]]] = {"moving": [], "still": []}

    def host_ms(scene, camera) -> tuple[float, float]:
        ctx.finish()  # the last frame's GPU work is not this frame's
        with DrawClock() as draws:
            start = time.thread_time()
            renderer.render(scene, camera, settings, timing=False, read_image=False)
            spent = time.thread_time() - start
        ctx.finish()
        return spent * 1e3, (spent - draws.seconds) * 1e3

    try:
        for k, (scene, camera) in enumerate(scenes):
            spent = host_ms(scene, camera)
            if k >= WARM_UP_FRAMES:
                found["moving"].append(spent)
        scene, camera = scenes[-1]
        for _ in range(frames):
            found["still"].append(host_ms(scene, camera))
        chosen = variants.chosen()
    finally:
        renderer.release()
        variants.set_override(None)  # the process's kernels follow the renderer again
    report = {"detail": detail, "resolution": f"{width}x{height}", "kernels": kernels, "variants": chosen}
    for kind, values in found.items():
        report[f"{kind}_ms"] = [round(total, 3) for total, _ in values]
        report[f"{kind}_median_ms"] = round(statistics.median(total for total, _ in values), 3)
        report[f"{kind}_python_median_ms"] = round(statistics.median(python for _, python in values), 3)
    return report


def compare(roots: list[str], rounds: int, arguments: list[str]) -> dict:
    """Run this script on each root in turn, ``rounds`` times (A B A B ...), in fresh
    processes; per root the medians of its rounds' medians and the ratio to the first."""
    runs: dict[str, list[dict]] = {root: [] for root in roots}
    for _ in range(rounds):
        for root in roots:
            out = subprocess.run([sys.executable, "-m", "benchmarks.host_frame", "--root", root, *arguments],
                                 cwd=REPOSITORY, check=True, capture_output=True, text=True).stdout
            runs[root].append(json.loads(out.strip().splitlines()[-1]))
    keys = ("moving", "still", "moving_python", "still_python")
    report = {}
    for root, found in runs.items():
        report[root] = {key: round(statistics.median(r[f"{key}_median_ms"] for r in found), 3) for key in keys}
        report[root]["rounds"] = [[r[f"{key}_median_ms"] for key in keys] for r in found]
    base = report[roots[0]]
    for root in roots[1:]:
        report[root]["ratio"] = {key: round(report[root][key] / base[key], 3) for key in keys}
    return report


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--detail", type=float, default=1.0)
    parser.add_argument("--frames", type=int, default=8)
    parser.add_argument("--resolution", default=f"{RESOLUTION[0]}x{RESOLUTION[1]}")
    parser.add_argument("--kernels", default="gpu", help="gpu, cpu or auto (gpu/variants.py)")
    parser.add_argument("--root", default=None, help="import hybrid_engine from this checkout")
    parser.add_argument("--compare", nargs="+", default=None, metavar="ROOT",
                        help="alternate fresh processes over these checkouts")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--json", default=None)
    args = parser.parse_args(argv)
    if args.compare:
        passed = ["--detail", str(args.detail), "--frames", str(args.frames), "--resolution", args.resolution,
                  "--kernels", args.kernels]
        report = compare(args.compare, args.rounds, passed)
    else:
        if args.root:
            sys.path.insert(0, str(Path(args.root).resolve()))
        width, height = (int(v) for v in args.resolution.lower().split("x"))
        report = measure(args.detail, args.frames, (width, height), args.kernels)
    text = json.dumps(report)
    if args.json:
        Path(args.json).write_text(text + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
