# SPDX-License-Identifier: GPL-3.0-or-later
"""benchmarks/light_noise.py: the still and moving noise of the traced diffuse light, measured
the viewport's way, at a size small enough for the test suite."""
from __future__ import annotations

import json

from benchmarks import light_noise


def test_the_room_is_closed_and_lit_by_one_lamp_behind_a_partition():
    scene = light_noise.room()
    assert len(scene.lights) == 1 and scene.geometry.triangle_count == 14


def test_a_small_run_reports_still_and_moving_flip_and_denoising_lowers_the_first_samples_error(gl, tmp_path):
    out = tmp_path / "noise.json"
    report = light_noise.main(["--size", "32x24", "--reference", "4", "--frames", "6", "--json", str(out)])
    assert json.loads(out.read_text()) == json.loads(json.dumps(report))
    assert set(report["still_denoised"]) == set(light_noise.STILL_SAMPLES)
    assert len(report["moving_denoised"]) == 6
    assert report["moving_after_five_max"] == max(report["moving_denoised"][5:])
    assert report["still_denoised"][1] < report["still_undenoised"][1]
