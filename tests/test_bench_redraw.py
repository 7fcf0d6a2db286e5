# SPDX-License-Identifier: GPL-3.0-or-later
"""scripts/bench_redraw.py: the host's work per viewport redraw, with its read-backs counted."""
from __future__ import annotations

import subprocess
import sys

from conftest import REPO_ROOT


def test_a_small_run_reports_one_read_back_and_no_finish_per_raster_redraw():
    done = subprocess.run([sys.executable, str(REPO_ROOT / "scripts" / "bench_redraw.py"), "--mode", "RASTER",
                           "--size", "64x48", "--redraws", "3"], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    line = done.stdout.strip().splitlines()[-1]
    assert line.startswith("RASTER 64x48: host per redraw median")
    assert "read-backs per redraw [1]" in line and "ctx.finish() per redraw [0]" in line
