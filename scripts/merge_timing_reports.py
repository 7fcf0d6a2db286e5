# SPDX-License-Identifier: GPL-3.0-or-later
"""Merge the timing reports of a render farm's chunks into one report.

Usage: python scripts/merge_timing_reports.py --prefix OUT/hybrid_rt_timing [--frames 1-250]
       (--folder OUT/hybrid_rt_timing_chunks | REPORT.json ...)

Reads each chunk's PREFIX.json (``bpy.ops.hybrid_rt.timing_report``), puts the frames in order,
recomputes the summary over all of them and writes PREFIX.json, PREFIX.csv and PREFIX.svg
(``hybrid_engine/reports/timing_merge.py``; no Blender needed). With ``--frames`` a frame that
no chunk reported is an error. The Flamenco job type (farm/flamenco/hybrid_rt_render.js) runs
the same merge as its last task, inside Blender, where it also writes the PNG chart. Prints the
paths written; exits with 1 and the reason when the reports cannot be merged.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
if str(REPO_ROOT) not in sys.path:
    sys.path.insert(0, str(REPO_ROOT))

from hybrid_engine.reports import timing_merge  # noqa: E402 - after the path is set
from hybrid_engine.reports.timing_report import TimingReportError  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--prefix", required=True, help="output prefix: PREFIX.json, .csv and .svg")
    parser.add_argument("--folder", help="a folder of chunk reports (every .json in it)")
    parser.add_argument("--frames", help="the frames the chunks must cover, e.g. '1-250' or '3, 5-10'")
    parser.add_argument("reports", nargs="*", help="chunk reports (.json)")
    args = parser.parse_args(argv)
    try:
        paths = list(args.reports)
        if args.folder:
            paths += [str(path) for path in timing_merge.chunk_reports(args.folder)]
        written = timing_merge.merge_files(paths, args.prefix, frames=args.frames)
    except TimingReportError as exc:
        print(f"merge_timing_reports: {exc}", file=sys.stderr)
        return 1
    for path in written.values():
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
