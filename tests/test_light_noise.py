# SPDX-License-Identifier: GPL-3.0-or-later
"""benchmarks/light_noise.py: the still and moving noise of the traced diffuse light, measured
the viewport's way, at a size small enough for the test suite."""
from __future__ import annotations

import json
from dataclasses import replace

import numpy as np

from benchmarks import light_noise


def test_the_room_is_closed_and_lit_by_one_lamp_behind_a_partition():
    scene = light_noise.room()
    assert len(scene.lights) == 1 and scene.geometry.triangle_count == 14


def test_a_small_run_reports_still_moving_and_stopped_flip_and_denoising_lowers_the_first_samples_error(
        gl, tmp_path):
    out, cache = tmp_path / "noise.json", tmp_path / "references.npz"
    args = ["--size", "32x24", "--reference", "4", "--settle", "2", "--frames", "7", "--check",
            "--cache", str(cache), "--json", str(out)]
    report = light_noise.main(args)
    assert json.loads(out.read_text()) == json.loads(json.dumps(report))
    assert set(report["still_denoised"]) == set(light_noise.STILL_SAMPLES) == set(report["stopped_denoised"])
    assert len(report["moving_denoised_after_five"]) == 2
    assert report["moving_after_five_max"] == max(report["moving_denoised_after_five"])
    assert report["still_denoised"][1] < report["still_undenoised"][1]
    assert set(report["reference_check"]) == {"flip_reference_to_doubled", "still_denoised_against_doubled"}
    # The references are kept: a second run measures against the very same images.
    assert light_noise.main(args) == report


def test_no_frames_measures_the_still_view_alone(gl):
    report = light_noise.main(["--size", "32x24", "--reference", "4", "--settle", "2", "--frames", "0"])
    assert set(report["still_denoised"]) == set(light_noise.STILL_SAMPLES)
    assert report["moving_denoised_after_five"] == [] and report["stopped_denoised"] == {}
    assert report["moving_after_five_max"] is None


def test_the_reference_is_the_fed_back_light_settled_and_unfiltered(gl):
    # With Bounce Feedback, a renderer without the denoiser has no fed-back bounces and is
    # darker; the reference (temporal step only, settled) holds them.
    scene = light_noise.room()
    settings = replace(light_noise._viewport_settings(), bounce_feedback=True)
    camera = light_noise.camera_at(0.0, 32, 24)
    maker = light_noise.Reference(scene, settings, settle=12)
    try:
        reference = maker.image(camera, 4)
        assert maker.renderer.denoiser.levels == 0
    finally:
        maker.release()
    from hybrid_engine.frame.renderer import Renderer

    plain = Renderer()
    try:
        undenoised = sum(plain.render(scene, camera, settings, sample=i).image[..., :3] for i in range(4)) / 4
    finally:
        plain.release()
    assert reference.mean() > 1.03 * undenoised.mean(), (reference.mean(), undenoised.mean())


def test_references_of_more_diffuse_rays_are_kept_apart_and_reported(gl, tmp_path):
    cache = tmp_path / "references.npz"
    args = ["--size", "32x24", "--reference", "2", "--settle", "2", "--frames", "0", "--cache", str(cache)]
    plain = light_noise.main(args)
    more = light_noise.main([*args, "--reference-rays", "4"])
    assert (plain["reference_rays"], more["reference_rays"]) == (1, 4)
    with np.load(cache) as kept:
        keys = set(kept.files)
        assert keys == {"still_32x24_2_2", "still_32x24_rays4_2_2"}
        # Four paths a frame: a reference of as many frames is less grainy than one path's.
        grain = lambda image: float(np.abs(np.diff(image[..., 1], axis=1)).mean())  # noqa: E731
        assert grain(kept["still_32x24_rays4_2_2"]) < 0.8 * grain(kept["still_32x24_2_2"])
