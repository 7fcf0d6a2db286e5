# SPDX-License-Identifier: GPL-3.0-or-later
"""benchmarks/light_noise.py: the still and moving noise of the traced diffuse light, measured
the viewport's way, at a size small enough for the test suite."""
from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

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
    blocks = (report["still_denoised_blocks"], report["stopped_denoised_blocks"])
    assert all(set(figures) == set(light_noise.STILL_SAMPLES) for figures in blocks)
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


def test_realizations_average_the_still_figures_over_other_sets_of_the_gathers_numbers(gl, tmp_path):
    cache = tmp_path / "references.npz"
    args = ["--size", "32x24", "--reference", "4", "--settle", "2", "--frames", "0", "--cache", str(cache)]
    one = light_noise.main(args)
    two = light_noise.main([*args, "--realizations", "2"])
    first, second = two["still_denoised_each"]
    assert two["realizations"] == 2 and "realizations" not in one
    assert first == one["still_denoised"]  # the first set is the product's numbers
    assert first != second  # the second draws other paths
    for samples in light_noise.STILL_SAMPLES:
        assert two["still_denoised"][samples] == pytest.approx((first[samples] + second[samples]) / 2, abs=1e-4)


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


def test_the_block_error_takes_a_shift_of_light_whole_and_per_pixel_grain_by_a_quarter():
    # The reference's grain is independent from pixel to pixel: a 4x4 block's mean holds a
    # quarter of it, where a bias over the block (a filter's shift, a blotch) stays whole.
    rng = np.random.default_rng(3)
    y, x = np.mgrid[0:48, 0:64]
    truth = np.repeat((0.2 + 0.6 * x / 63.0 + 0.1 * y / 47.0)[..., None], 3, axis=2).astype(np.float32)
    assert abs(light_noise.block_error(truth, 1.02 * truth) - 0.02) < 1e-6
    grain = truth * (1.0 + 0.04 * rng.standard_normal(truth.shape[:2]))[..., None]
    per_pixel = float(np.sqrt(np.mean((grain[..., 1] / truth[..., 1] - 1.0) ** 2)))
    assert abs(per_pixel - 0.04) < 0.004
    assert abs(light_noise.block_error(truth, grain) - 0.01) < 0.002


def test_a_reference_from_other_sample_numbers_draws_other_paths_also_from_a_new_renderer(gl):
    # The gather draws by the denoiser history's frames where a history is kept: two new
    # makers asked for other numbers must not make the same image, and asked for the same,
    # must. Forty settling frames leave the first frame, which draws by its sample, about a
    # hundredth of the blend: the numbers of the frames that count make the difference.
    scene, settings = light_noise.room(), light_noise._viewport_settings()
    camera = light_noise.camera_at(0.0, 32, 24)

    def reference(first: int) -> np.ndarray:
        maker = light_noise.Reference(scene, settings, settle=40)
        try:
            return maker.image(camera, 2, first=first)
        finally:
            maker.release()

    again, same, other = reference(0), reference(0), reference(1000)
    np.testing.assert_array_equal(again, same)
    assert np.abs(other - again).mean() > 0.1 * again.mean()
