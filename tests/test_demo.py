# SPDX-License-Identifier: GPL-3.0-or-later
"""The quick start's `make demo` (scripts/demo.py), run small in a child process: it must
build the chess scene, write the HYBRID and PROVENANCE images and the timing report, and
print the per-pass table."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np

from conftest import REPO_ROOT


def test_the_demo_writes_its_images_and_timing_report(tmp_path):
    output = tmp_path / "demo.png"
    run = subprocess.run(
        [sys.executable, str(REPO_ROOT / "scripts" / "demo.py"), "--output", str(output),
         "--detail", "0.02", "--width", "64", "--height", "36", "--report-frames", "2"],
        capture_output=True, text=True, timeout=600, cwd=tmp_path,
    )
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    for name in ("demo.png", "demo_provenance.png", "demo_timing.json", "demo_timing.csv", "demo_timing.png"):
        assert (tmp_path / name).is_file(), name
    assert "mode HYBRID" in run.stdout and "trace" in run.stdout and "cube_map_raster" in run.stdout
    report = json.loads((tmp_path / "demo_timing.json").read_text())
    assert [f["frame"] for f in report["frames"]] == [0, 1]

    import bpy

    images = {}
    for name in ("demo.png", "demo_provenance.png"):
        image = bpy.data.images.load(str(tmp_path / name))
        try:
            pixels = np.empty(image.size[0] * image.size[1] * 4, np.float32)
            image.pixels.foreach_get(pixels)
            images[name] = pixels.reshape(image.size[1], image.size[0], 4)
        finally:
            bpy.data.images.remove(image)
    assert images["demo.png"].shape == (36, 64, 4)
    # PROVENANCE paints the specular pixels pure blue (BVH) or red (cube map): both appear.
    rgb = images["demo_provenance.png"][..., :3]
    assert ((rgb[..., 2] > 0.6) & (rgb[..., 0] < 0.4)).any()
    assert ((rgb[..., 0] > 0.6) & (rgb[..., 2] < 0.4)).any()
