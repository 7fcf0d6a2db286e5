# SPDX-License-Identifier: GPL-3.0-or-later
"""benchmarks/chess_flip_split.py: the split of HYBRID's Chess difference from FULL_BVH into
noise and bias, and into the light that makes it."""
from __future__ import annotations

import numpy as np

from benchmarks import chess_flip_split


def test_bias_share_is_one_for_a_difference_both_halves_hold_and_near_zero_for_noise(rng):
    bias = rng.normal(size=(40, 60))
    assert chess_flip_split.bias_share(bias, bias) == 1.0
    noise_a, noise_b = rng.normal(size=(2, 40, 60))
    assert abs(chess_flip_split.bias_share(noise_a, noise_b)) < 0.05
    mixed = chess_flip_split.bias_share(bias + noise_a, bias + noise_b)
    assert 0.35 < mixed < 0.65  # as much bias as noise


def test_without_reflections_the_whole_difference_is_the_primary_diffuse_light(gl):
    report = chess_flip_split.run(0.02, (64, 36), 64, 2, ["depth0"])["variants"]["depth0"]
    # Putting FULL_BVH's Diffuse Indirect into HYBRID's image leaves nothing else to differ.
    assert report["flip_glossy_only"] < 1e-3
    assert report["flip_diffuse_only"] > 0.0
    assert abs(report["flip_diffuse_only"] - report["same_all"]) < 1e-3
    assert report["samples"] == 4 and 0.0 <= report["noise_h"] <= 1.0 and 0.0 <= report["denoised_1"] <= 1.0


def test_escapes_and_stops_are_the_rays_on_which_the_modes_disagree_about_the_sky():
    hybrid = np.array([1.0, 1.0, 0.0, 0.0, 1.0])
    full = np.array([0.0, 1.0, 1.0, 0.0, 0.0])
    escape, stop = chess_flip_split.escapes_and_stops(hybrid, full)
    assert escape.tolist() == [True, False, False, False, True]
    assert stop.tolist() == [False, False, True, False, False]


def test_the_gather_escapes_count_each_disagreeing_ray_once_with_the_footprints_and_without(gl):
    report = chess_flip_split.gather_escapes(0.02, (64, 36), 64, 1)
    assert report["rays"] == 64 * 36
    for key in ("without", "footprints"):
        counts = report[key]
        assert counts["escapes"] + counts["stops"] <= report["rays"]
        assert sum(e for e, _ in counts["by_surface"].values()) <= counts["escapes"]
        assert sum(s for _, s in counts["by_surface"].values()) <= counts["stops"]
        assert 0.0 < counts["sky_hybrid"] <= 1.0


def test_the_paper_mirrors_variant_parts_the_reflections_from_full_bvh_more_and_switches_back(gl):
    # The variant marches the tracer's rays by the paper's one depth per texel
    # (tracer.MIRROR_FOOTPRINTS off), the diffuse paths keeping their footprints: only the
    # reflections' part may change, and the switch is back on after the run.
    from hybrid_engine.passes.trace import tracer

    report = chess_flip_split.run(0.02, (64, 36), 64, 1, ["default", "paper_mirrors"])["variants"]
    assert tracer.MIRROR_FOOTPRINTS
    assert report["paper_mirrors"]["flip_diffuse_only"] == report["default"]["flip_diffuse_only"]
    assert report["paper_mirrors"]["flip_glossy_only"] != report["default"]["flip_glossy_only"]
