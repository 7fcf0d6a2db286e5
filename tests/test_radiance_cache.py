# SPDX-License-Identifier: GPL-3.0-or-later
"""The diffuse paths' world-space radiance cache (passes/diffuse_light/radiance_cache.py):
where a pixel's history is short, its paths count the light many paths left around their
first bounce instead of their own continuation."""
from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.light_noise import camera_at, room
from hybrid_engine.gpu import shader_loader
from hybrid_engine.passes.diffuse_light import radiance_cache
from hybrid_engine.scene.camera import Camera, look_at
from hybrid_engine.scene.data import Lights, MaterialTable, SceneData, Sky
from hybrid_engine.scene.geometry import Geometry
from hybrid_engine.scene.settings import RenderSettings

W, H = 64, 48
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def settings(**kw) -> RenderSettings:
    return RenderSettings(mode="HYBRID", near_size=2.0, shadow_resolution=512, **kw)


def start_over(renderer, scene, camera) -> None:
    """A frame without the denoiser: its history, and the cache with it, start over."""
    renderer.render(scene, camera, settings(), timing=False)


def gathered(renderer, scene, camera, frames: int, **kw) -> list[np.ndarray]:
    """The diffuse gather's raw irradiance (the G-buffer's ``ambient``, before the denoiser)
    of ``frames`` consecutive denoised frames of one view, as luminance."""
    start_over(renderer, scene, camera)
    out = []
    for i in range(frames):
        renderer.render(scene, camera, settings(**kw), sample=i, reuse_world=i > 0, denoise=True, timing=False)
        ambient = np.frombuffer(renderer.gbuffer.primary.ambient.read(), np.float32).reshape(H, W, 4)
        out.append(ambient[..., :3] @ LUMINANCE)
    return out


@pytest.fixture(scope="module")
def bounce_lit():
    """benchmarks/light_noise.py's room (half of the view lit by the walls alone), its view,
    and its settled irradiance: the mean of 32 frames of 8 paths a pixel, after 16."""
    return room(), camera_at(0.0, W, H)


@pytest.fixture(scope="module")
def truth(renderer, bounce_lit):
    scene, camera = bounce_lit
    frames = gathered(renderer, scene, camera, 48, diffuse_rays=8, radiance_cache=False)
    return np.mean(frames[16:], axis=0)


def test_a_bounce_lit_rooms_first_frames_gather_closer_to_the_settled_light_with_the_cache(renderer, bounce_lit,
                                                                                         truth, monkeypatch):
    # Most of the room's light has bounced more than once, and one path of four bounces per
    # pixel carries the noise of each; a cell's mean of the continuations of many paths
    # does not. The first frame fills the cells and has nothing to count: the mean of frames
    # 1-7, whose error per pixel also holds the first bounce's noise (which surface a path
    # meets, and its lamp light), which the cells leave as it is (the short paths, off here,
    # sample it more: below).
    monkeypatch.setattr(radiance_cache, "SHORT_PATHS", 0)
    monkeypatch.setattr(radiance_cache, "SHORT_FLOOR", 0)
    scene, camera = bounce_lit
    lit = truth > 0.05 * truth.mean()
    errors = {}
    for cache in (False, True):
        frames = gathered(renderer, scene, camera, 8, radiance_cache=cache)
        mean = np.mean(frames[1:], axis=0)
        errors[cache] = float(np.sqrt(np.mean(((mean - truth) / truth)[lit] ** 2)))
    assert errors[True] < 0.9 * errors[False], errors


def test_short_paths_sample_the_first_bounce_more_and_count_the_cells_by_the_same_weight(renderer, bounce_lit,
                                                                                      truth, monkeypatch):
    # What the cells leave is the first bounce's noise (which surface a path meets). A pixel
    # that counts them fully traces short paths beside its own, each ending on the cell where
    # it bounces: several first bounces for the rays of about one whole path. They count the
    # cells by the pixel's weight as its own paths do (the own paths' continuations stand in
    # for the rest), so the light they converge to is the same. Frames 2-7 (the first frame
    # fills the cells, the second is the first to count them).
    scene, camera = bounce_lit
    lit = truth > 0.05 * truth.mean()
    errors, means = {}, {}
    for short in (False, True):
        if not short:
            monkeypatch.setattr(radiance_cache, "SHORT_PATHS", 0)
            monkeypatch.setattr(radiance_cache, "SHORT_FLOOR", 0)
        frames = gathered(renderer, scene, camera, 8, radiance_cache=True)
        monkeypatch.undo()
        mean = np.mean(frames[2:], axis=0)
        errors[short] = float(np.sqrt(np.mean(((mean - truth) / truth)[lit] ** 2)))
        means[short] = float(mean[lit].mean())
    assert radiance_cache.SHORT_PATHS > 0
    assert errors[True] < 0.8 * errors[False], errors
    assert abs(means[True] / means[False] - 1.0) < 0.02, means


def short_paths_of(frames: float, enclosed: float = 1.0) -> float:
    """The short paths a pixel whose history holds ``frames`` frames traces, of which
    ``enclosed`` of the first rays do not escape, before rounding (diffuse_gather.comp.glsl
    pixel_paths)."""
    weight = max(1.0 - frames / radiance_cache.HISTORY_FRAMES, 0.0)
    return weight * enclosed * max(radiance_cache.SHORT_PATHS / (frames + 1.0), radiance_cache.SHORT_FLOOR)


def first_bounce_rays(renderer, scene, camera, frames: int) -> list[float]:
    """The diffuse gather's first rays per pixel in each of ``frames`` denoised frames of a
    still view."""
    start_over(renderer, scene, camera)
    counts = []
    for i in range(frames):
        result = renderer.render(scene, camera, settings(), sample=i, reuse_world=i > 0, denoise=True, timing=False)
        counts.append(int(dict(result.counts)["gather_rays_traced_bounce_1"]) / (W * H))
    return counts


def test_short_paths_are_most_where_the_history_is_new_and_gone_once_the_cells_weigh_little(renderer, bounce_lit):
    # Every pixel of the room's view sees a wall, and its first rays meet the room. The first
    # frame (no history) fills the cells and traces no short path; the second, with one
    # frame of history, traces SHORT_PATHS / 2 of them beside its own (times the weight
    # 31 / 32, rounded); they fall as one over the frames plus one to SHORT_FLOOR, which
    # the falling weight then takes to nothing.
    scene, camera = bounce_lit
    last = next(n for n in range(1, 64) if short_paths_of(n) < 0.5)
    counts = first_bounce_rays(renderer, scene, camera, last + 2)
    own = 1  # Diffuse Rays; twice in the first frame, as many as the history's extra paths after
    short = [short_paths_of(n) for n in range(last + 2)]
    assert radiance_cache.SHORT_PATHS >= 8 and radiance_cache.SHORT_FLOOR >= 1 and last > 16
    assert counts[0] == 2 * own
    # A few pixels a frame whose first ray found a crack to the sky trace one fewer (a
    # rounding at exactly one half may go either way in float32).
    assert abs(counts[1] - own - round(short[1])) < 0.01, counts
    assert all(math.floor(k) - 0.01 <= c - own <= math.ceil(k) for c, k in zip(counts[1:], short[1:])), counts
    assert all(a >= b for a, b in zip(counts[1:], counts[2:])), counts
    assert counts[last - 1] > own + 0.9 and counts[last + 1] == own, counts


def rays_at_rest(renderer, scene, slide: int, rest: int, step: float = 0.02) -> list[float]:
    """The diffuse gather's first rays per pixel in each of ``rest`` samples of a still view
    that a camera comes to after ``slide`` redraws sliding sideways by ``step`` (each
    redraw of a moving view is its film's first sample, as the viewport's are)."""
    start_over(renderer, scene, camera_at(0.0, W, H))
    for f in range(slide):
        renderer.render(scene, camera_at(f * step, W, H), settings(), sample=0, accumulate=True, denoise=True,
                        timing=False)
    camera, counts = camera_at((slide - 1) * step, W, H), []
    for i in range(rest):
        result = renderer.render(scene, camera, settings(), sample=i, reuse_world=i > 0, accumulate=True,
                                 denoise=True, timing=False)
        counts.append(int(dict(result.counts)["gather_rays_traced_bounce_1"]) / (W * H))
    return counts


def test_a_view_that_comes_to_rest_after_a_slide_traces_short_paths_as_a_new_history_does(renderer, bounce_lit,
                                                                                       monkeypatch):
    # A slide long enough that the pixels' histories outgrow the cells' weight: its last
    # frames trace Diffuse Rays alone. At rest, the history counts REST_FRAMES frames from
    # the film's second sample on (passes/denoise/denoise.py), so the gather, which reads
    # the length the frame before left, traces the short paths of that history again from
    # the third; counted at its length, it traces none.
    from hybrid_engine.passes.denoise import denoise

    scene, _ = bounce_lit
    slide = int(radiance_cache.HISTORY_FRAMES) + 4
    own = 1  # Diffuse Rays
    extra = round(short_paths_of(denoise.REST_FRAMES + 1))
    assert extra >= 1
    resting = rays_at_rest(renderer, scene, slide, 4)
    monkeypatch.setattr(denoise, "REST_FRAMES", int(denoise.MAX_LENGTH))
    counted_whole = rays_at_rest(renderer, scene, slide, 4)
    # A few pixels enter the view at its edge each redraw of the slide and start over.
    assert resting[0] < own + 0.2 and resting[1] < own + 0.2, resting
    assert resting[2] > own + extra - 0.1 and resting[3] > own + extra - 0.1, resting
    assert max(counted_whole) < own + 0.2, counted_whole


def open_floor() -> SceneData:
    """A grey floor under a white sky: every first ray of the gather escapes."""
    floor = np.array([[(-50, -50, 0), (50, -50, 0), (50, 50, 0)], [(-50, -50, 0), (50, 50, 0), (-50, 50, 0)]],
                     np.float32)
    return SceneData(Geometry.from_objects([(floor, None, 0)]),
                     MaterialTable.from_rows([dict(base_color=(0.5, 0.5, 0.5), specular=0.0, roughness=1.0)]),
                     Lights.from_rows([]), Sky(color=(1.0, 1.0, 1.0)))


def test_a_pixel_traces_short_paths_by_the_share_of_its_first_rays_that_meet_a_surface(renderer, bounce_lit):
    # Where a first ray escapes, a short path would be a whole path, and the sky's smooth
    # light leaves little first-bounce noise to sample: an open floor's pixels trace none,
    # where the room's trace SHORT_PATHS / 2 in the same frame of their history.
    camera = Camera(matrix_world=look_at(np.array([0.0, -4.0, 3.0]), np.zeros(3)), width=W, height=H)
    floor = first_bounce_rays(renderer, open_floor(), camera, 3)
    room_counts = first_bounce_rays(renderer, *bounce_lit, 3)
    assert round(short_paths_of(1)) >= 4
    assert floor == [2.0, 1.0, 1.0], floor
    assert room_counts[1] > 1.0 + round(short_paths_of(1)) - 0.01, room_counts


def test_a_frames_short_paths_cover_the_hemisphere_evenly(renderer, bounce_lit, truth, monkeypatch):
    # Their first directions are consecutive points of a lattice, as the frames of a pixel's
    # own paths are: which surfaces the first bounce meets is averaged better than by as
    # many independent directions (SHORT_PATHS_INDEPENDENT, a measurement switch), in one
    # frame (the second: 16 short paths here) and over frames 2-7 of the raw gather; the
    # light they converge to is the same. Each error is the mean over four sets of the
    # gather's numbers (gather_seed): one set's ratio strays by some 0.02 from another's.
    from hybrid_engine.frame.renderer import Renderer

    monkeypatch.setattr(radiance_cache, "SHORT_PATHS", 32)
    monkeypatch.setattr(radiance_cache, "SHORT_FLOOR", 8)
    scene, camera = bounce_lit
    lit = truth > 0.05 * truth.mean()

    def error(gather: np.ndarray) -> float:
        return float(np.sqrt(np.mean(((gather - truth) / truth)[lit] ** 2)))

    errors, means = {}, {}
    for independent in (False, True):
        runs = []
        for seed in range(4):
            with shader_loader.compiled_with({"SHORT_PATHS_INDEPENDENT": 1} if independent else {}):
                variant = Renderer(renderer.ctx, gather_seed=seed)
                try:
                    frames = gathered(variant, scene, camera, 8, radiance_cache=True)
                finally:
                    variant.release()
            mean = np.mean(frames[2:], axis=0)
            runs.append((error(frames[1]), error(mean), float(mean[lit].mean())))
        errors[independent] = tuple(float(np.mean([run[i] for run in runs])) for i in (0, 1))
        means[independent] = float(np.mean([run[2] for run in runs]))
    assert errors[False][0] < 0.95 * errors[True][0], errors
    assert errors[False][1] < 0.95 * errors[True][1], errors
    assert abs(means[False] / means[True] - 1.0) < 0.02, means


def test_paths_whose_pixels_do_not_count_the_cells_bring_back_exactly_their_own_light(renderer, bounce_lit,
                                                                                     monkeypatch):
    # Every path leaves its continuation in a cell; a pixel whose history is long enough
    # (here: every one) counts its own paths, bit for bit as without the cache.
    scene, camera = bounce_lit
    monkeypatch.setattr(radiance_cache, "HISTORY_FRAMES", 0.0)
    with_cache = gathered(renderer, scene, camera, 4, radiance_cache=True)
    cells, deposits = renderer.diffuse_light.cache.read()
    without = gathered(renderer, scene, camera, 4, radiance_cache=False)
    assert len(cells) > 100 and deposits.sum() > 0
    for a, b in zip(with_cache, without):
        np.testing.assert_array_equal(a, b)


def test_a_pixel_counts_the_cells_only_while_its_history_is_short(renderer, bounce_lit, monkeypatch):
    # Past HISTORY_FRAMES the temporal blend averages that many frames of independent paths,
    # where a cell's slowly changing mean would keep its error: the frames are then the
    # plain paths' again (the same numbers, the same fed-back light bar the history's).
    scene, camera = bounce_lit
    monkeypatch.setattr(radiance_cache, "HISTORY_FRAMES", 4.0)
    frames = 8
    on = gathered(renderer, scene, camera, frames, radiance_cache=True)
    off = gathered(renderer, scene, camera, frames, radiance_cache=False)
    assert np.abs(on[2] - off[2]).max() > 1e-3  # counted: another estimate
    late = np.abs(on[-1] - off[-1])
    # The same paths; only last frame's light where they end differs a little.
    assert np.median(late) < 1e-3 * np.median(off[-1]) + 1e-7, np.median(late)


def test_undenoised_frames_take_no_light_from_the_cells(renderer, bounce_lit):
    scene, camera = bounce_lit
    gathered(renderer, scene, camera, 4, radiance_cache=True)  # cells filled
    plain = [renderer.render(scene, camera, settings(radiance_cache=cache), sample=1, timing=False).image
             for cache in (True, False)]
    np.testing.assert_array_equal(plain[0], plain[1])


def test_a_lamp_switched_off_empties_the_cells_at_once(renderer, bounce_lit):
    # The cells would go on giving the lamp's light to the pixels that count them (those
    # whose history is short: what the camera uncovers) for as many frames as they hold.
    # The frame of the switch empties them; the next holds its paths alone, which bring
    # back the light fed back from the last frame (the denoiser's history): it dies away.
    scene, camera = bounce_lit
    gathered(renderer, scene, camera, 6, radiance_cache=True)  # five frames fill the cells
    lit, lit_deposits = renderer.diffuse_light.cache.read()
    dark_scene = SceneData(scene.geometry, scene.materials, Lights.from_rows([]), scene.sky)
    dark_frame = lambda i: renderer.render(dark_scene, camera, settings(), sample=i, reuse_world=True,  # noqa: E731
                                           denoise=True, timing=False)
    dark_frame(6)
    assert len(renderer.diffuse_light.cache.read()[0]) == 0
    dark_frame(7)
    dark, deposits = renderer.diffuse_light.cache.read()
    assert lit.max() > 0.1
    assert 0 < deposits.sum() < 0.3 * lit_deposits.sum(), (deposits.sum(), lit_deposits.sum())
    assert dark.max() < 0.2 * lit.max(), (dark.max(), lit.max())


def test_a_material_edit_empties_the_cells_and_an_unchanged_table_keeps_them(renderer, bounce_lit):
    # The cells hold light that bounced off the materials as they were: a wall painted
    # darker would go on lending its old bounce to the pixels that count them. A table
    # rebuilt with the same values (as Blender's sync rebuilds it) keeps them.
    scene, camera = bounce_lit

    def frame(materials: MaterialTable, i: int) -> None:
        renderer.render(SceneData(scene.geometry, materials, scene.lights, scene.sky), camera, settings(),
                        sample=i, reuse_world=True, denoise=True, timing=False)

    gathered(renderer, scene, camera, 6, radiance_cache=True)  # five frames fill the cells
    bright, bright_deposits = renderer.diffuse_light.cache.read()
    frame(MaterialTable.from_rows([dict(base_color=(0.8, 0.8, 0.8), specular=0.0, roughness=1.0)]), 6)
    kept, kept_deposits = renderer.diffuse_light.cache.read()
    assert len(kept) >= len(bright) and kept_deposits.sum() > bright_deposits.sum()
    darker = MaterialTable.from_rows([dict(base_color=(0.2, 0.2, 0.2), specular=0.0, roughness=1.0)])
    frame(darker, 7)
    assert len(renderer.diffuse_light.cache.read()[0]) == 0
    frame(darker, 8)
    dark, _ = renderer.diffuse_light.cache.read()
    luminance = lambda cells: float((cells @ LUMINANCE).mean())  # noqa: E731
    assert luminance(dark) < 0.5 * luminance(bright), (luminance(dark), luminance(bright))
