# SPDX-License-Identifier: GPL-3.0-or-later
"""The moving-object noise benchmark (benchmarks/moving_object_noise.py) runs end to end at a
tiny size, the pillar moved by its matrix and by deforming its mesh, and measures both
variants over the pillar's own pixels."""
from __future__ import annotations

import math

import pytest

from benchmarks import moving_object_noise
from hybrid_engine.passes.surface_motion import surface_motion


@pytest.mark.parametrize("deform", [False, True])
def test_a_tiny_run_measures_the_pillars_pixels_following_its_move_and_not(gl, deform):
    report = moving_object_noise.measure(48, 36, reference=2, frames=7, settle=1, slide=0.1, deform=deform)
    assert report["deform"] == deform
    for key in ("following", "camera_only"):
        figures = report[key]
        assert len(figures["whole"]) == len(figures["box"]) == 2
        assert all(0.0 < value < 1.0 and math.isfinite(value) for value in figures["whole"] + figures["box"])
    assert surface_motion.FOLLOW_MOVES  # switched back on
