# SPDX-License-Identifier: GPL-3.0-or-later
"""Anti-aliased final renders (hybrid_engine/frame/antialias.py): where the samples lie, that the
averaged edge matches the analytic pixel coverage, and that keeping the first sample's cube
map and BVH for the others changes nothing but the time."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine import Camera, RenderSettings
from hybrid_engine.scene.camera import look_at
from hybrid_engine.frame.antialias import jittered_camera, render_antialiased, sample_offsets
from hybrid_engine.frame.film import FrameOutputs
from test_film import SMALL, analytic_floor, cameras, floor_scene

# A coverage estimate from n samples errs by about 1 / sqrt(n) at worst on one pixel and far
# less on average over an edge (the Halton points are stratified).
COVERAGE_MEAN_ERROR = 0.08
PIXEL_FILTER = 1.5  # Blender's default Film > Pixel Filter width


def test_sample_offsets_start_at_the_centre_and_spread_over_the_pixel():
    offsets = sample_offsets(16)
    assert offsets.shape == (16, 2) and tuple(offsets[0]) == (0.0, 0.0)
    assert (np.abs(offsets) < 0.5).all()
    assert len({tuple(o) for o in offsets}) == 16
    # Four points in each quarter of the pixel (the centre counted in the upper right).
    quarters = np.bincount((offsets[:, 0] >= 0).astype(int) * 2 + (offsets[:, 1] >= 0), minlength=4)
    assert (np.abs(quarters - 4) <= 1).all(), quarters
    np.testing.assert_array_equal(sample_offsets(1), [[0.0, 0.0]])
    with pytest.raises(ValueError, match="at least one sample"):
        sample_offsets(0)


@pytest.mark.parametrize("name", ["persp", "ortho"])
def test_a_jittered_camera_moves_the_image_by_the_offset_in_pixels(name, rng):
    camera = cameras()[name]
    dx, dy = 0.3, -0.2
    moved = jittered_camera(camera, dx, dy)
    points = np.c_[rng.uniform(-2, 2, (50, 3)), np.ones(50)]

    def pixels(cam):
        clip = points @ cam.view_projection().T
        ndc = clip[:, :2] / clip[:, 3:]
        return (ndc + 1) * 0.5 * (cam.width, cam.height)

    np.testing.assert_allclose(pixels(moved), pixels(camera) - (dx, dy), atol=1e-9)
    assert jittered_camera(camera, 0.0, 0.0) is camera


def blackman_harris(x: np.ndarray, width: float) -> np.ndarray:
    """The 4-term Blackman-Harris window ``width`` pixels wide, centred at 0 (Cycles' pixel filter)."""
    t = 2.0 * np.pi * (x / width + 0.5)
    return 0.35875 - 0.48829 * np.cos(t) + 0.14128 * np.cos(2 * t) - 0.01168 * np.cos(3 * t)


def analytic_coverage(camera, width: float = PIXEL_FILTER, grid: int = 12) -> np.ndarray:
    """The floor's share of each pixel weighted by the pixel filter: the filtered coverage
    integrated over a grid x grid lattice of sub-pixel positions across the filter's width."""
    positions = ((np.arange(grid) + 0.5) / grid - 0.5) * width
    weights = blackman_harris(positions, width)
    total = np.zeros((camera.height, camera.width))
    for sx, wx in zip(positions, weights):
        for sy, wy in zip(positions, weights):
            hit, _ = analytic_floor(jittered_camera(camera, sx, sy))
            total += wx * wy * hit
    return total / weights.sum() ** 2


def test_averaged_samples_give_edge_pixels_the_filtered_fraction_each_side_covers(renderer):
    camera = cameras()["persp"]
    coverage = analytic_coverage(camera)
    edge = (coverage > 0.1) & (coverage < 0.9)  # clearly partial: the filter's tails aside
    solid = (coverage == 0) | (coverage == 1)
    assert edge.sum() > 20
    outputs = FrameOutputs(transparent=True)
    settings = RenderSettings(mode="RASTER", **SMALL)
    one = render_antialiased(renderer, floor_scene(), camera, settings, 1, outputs=outputs,
                             filter_width=PIXEL_FILTER).image[..., 3]
    many = render_antialiased(renderer, floor_scene(), camera, settings, 32, outputs=outputs,
                              filter_width=PIXEL_FILTER).image[..., 3]
    assert set(np.unique(one)) <= {0.0, 1.0}
    assert np.abs(one[edge] - coverage[edge]).mean() > 2 * COVERAGE_MEAN_ERROR, "one sample cannot resolve edges"
    assert np.abs(many[edge] - coverage[edge]).mean() < COVERAGE_MEAN_ERROR
    np.testing.assert_array_equal(many[solid], coverage[solid])


def test_later_samples_keep_the_cube_map_and_bvh_and_give_the_same_image(renderer, monkeypatch):
    camera = cameras()["persp"]
    settings = RenderSettings(mode="HYBRID", **SMALL)
    scene = floor_scene(mirror=True)
    renderer.render(scene, camera, settings)  # the traced passes exist from here on
    calls = {"render_cube_map": 0, "build": 0}
    for name, owner, method in (("render_cube_map", renderer.cube_map, "render"),
                                ("build", renderer.lbvh.builder, "build")):
        original = getattr(owner, method)

        def counted(*args, _name=name, _original=original, **kwargs):
            calls[_name] += 1
            return _original(*args, **kwargs)

        monkeypatch.setattr(owner, method, counted)
    kept = render_antialiased(renderer, scene, camera, settings, 3)
    assert calls == {"render_cube_map": 1, "build": 1}
    assert kept.counts["samples"] == 3
    # The same samples, each a complete frame.
    fresh = np.mean([renderer.render(scene, jittered_camera(camera, *offset), settings).image
                     for offset in sample_offsets(3)], axis=0)
    assert calls == {"render_cube_map": 4, "build": 4}
    np.testing.assert_allclose(kept.image, fresh, rtol=1e-5, atol=1e-6)


def test_a_kept_world_is_rebuilt_when_the_geometry_or_the_eye_moved(renderer, monkeypatch):
    camera = cameras()["persp"]
    settings = RenderSettings(mode="HYBRID", **SMALL)
    renderer.render(floor_scene(mirror=True), camera, settings)
    built = []
    original = renderer.lbvh.builder.build
    monkeypatch.setattr(renderer.lbvh.builder, "build", lambda *a, **k: built.append(1) or original(*a, **k))
    scene = floor_scene(mirror=True)
    renderer.render(scene, camera, settings)
    assert len(built) == 1
    renderer.render(scene, camera, settings, reuse_world=True)
    assert len(built) == 1  # same scene, same eye: kept
    moved = jittered_camera(camera, 0.25, 0.25)
    renderer.render(scene, moved, settings, reuse_world=True)
    assert len(built) == 1  # the eye did not move, only the image
    elsewhere = Camera(matrix_world=look_at((1.5, -5.0, 3.0), (0.5, 0.0, 0.0)), width=32, height=20)
    renderer.render(scene, elsewhere, settings, reuse_world=True)
    assert len(built) == 2
    scene.geometry.triangles[:, :, 2] += 0.5  # edited in place: the same scene object
    renderer.render(scene, elsewhere, settings, reuse_world=True)
    assert len(built) == 3


def test_a_final_render_whose_wave_queues_overflowed_renders_its_samples_again(gl):
    from hybrid_engine.frame.renderer import Renderer
    from hybrid_engine.gpu import variants
    import test_tracer as scenes

    make_scene, make_camera = scenes.SCENES["glass_ball"]
    scene, camera = make_scene(), make_camera()
    settings = scenes.settings("HYBRID", max_depth=4, near_size=6.0, ao_distance=1.0)
    renderer = Renderer(gl)
    variants.set_override("trace=gpu")
    try:
        expected = render_antialiased(renderer, scene, camera, settings, 3).image
        waves = renderer.tracer._waves
        wanted = waves.overflowed()
        assert waves.overflows == 0 and wanted[0] > 0
        waves.set_capacity(wanted[0] // 3, wanted[1] // 3)
        passes = []
        real_render = renderer.render
        renderer.render = lambda *a, **kw: passes.append(kw["sample"]) or real_render(*a, **kw)
        again = render_antialiased(renderer, scene, camera, settings, 3).image
        assert waves.overflows > 0
        assert passes[:4] == [0, 1, 2, 0]  # started over once the queues had grown
        assert len(passes) == 3 * (waves.overflows + 1)
        np.testing.assert_array_equal(again, expected)
    finally:
        variants.set_override(None)
        renderer.release()
