# SPDX-License-Identifier: GPL-3.0-or-later
"""hybrid_engine/passes/shadow_maps/shadow_cache.py: static and dynamic shadow layers. Splitting the maps must
never change an image (the lookup's min over both layers is one map of all objects), and an
animation must re-render only the layer of what moved."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine import RenderSettings
from hybrid_engine.frame.renderer import Renderer
from hybrid_engine.scene.changes import GeometryDelta
from benchmarks.scenes.chess import build_chess
from hybrid_engine.passes.shadow_maps.shadow_cache import PROMOTE_AFTER_FRAMES, ShadowCache, changed_objects, snapped_bounds

RANGES = np.array([[0, 10], [10, 5], [15, 0], [15, 20]], np.int32)


def delta(sequence: int, *ranges: tuple[int, int], full: bool = False) -> GeometryDelta:
    return GeometryDelta(full=full, ranges=tuple(ranges), changed_triangles=sum(c for _, c in ranges),
                         sequence=sequence)


def test_snapped_bounds_contain_the_bounds_and_ignore_small_moves(rng):
    for _ in range(50):
        lo = rng.uniform(-100, 100, 3)
        hi = lo + rng.uniform(0.1, 50, 3)
        slo, shi = snapped_bounds(lo, hi)
        extent = np.max(hi - lo)
        assert (slo <= lo).all() and (shi >= hi).all()
        assert (lo - slo).max() <= extent / 32 and (shi - hi).max() <= extent / 32
    lo, hi = np.array([-60.0, -60.0, -0.2]), np.array([60.0, 60.0, 2.1])
    moved = snapped_bounds(lo, hi + np.array([0.0, 0.0, 0.3]))  # a piece lifted a little
    np.testing.assert_array_equal(snapped_bounds(lo, hi)[1], moved[1])


def test_snapped_bounds_pass_empty_bounds_through():
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    slo, shi = snapped_bounds(lo, hi)
    assert np.isinf(slo).all() and np.isinf(shi).all()


def test_changed_objects_are_those_whose_ranges_overlap_the_delta():
    np.testing.assert_array_equal(changed_objects(RANGES, delta(1, (12, 1))), [False, True, False, False])
    np.testing.assert_array_equal(changed_objects(RANGES, delta(1, (9, 7))), [True, True, False, True])
    np.testing.assert_array_equal(changed_objects(RANGES, delta(1)), [False] * 4)
    np.testing.assert_array_equal(changed_objects(RANGES, delta(1, (0, 35), full=True)), [True] * 4)


def test_plan_demotes_a_moving_object_once_then_renders_only_the_dynamic_layer():
    cache = ShadowCache()
    first = cache.plan(RANGES, delta(1, (0, 35), full=True), key=("k",))
    assert first.render_static and first.render_dynamic and first.static_mask.all()
    still = cache.plan(RANGES, delta(2), key=("k",))
    assert not still.anything
    moved = cache.plan(RANGES, delta(3, (12, 1)), key=("k",))
    assert moved.render_static and moved.render_dynamic  # demotion re-renders the rest once
    np.testing.assert_array_equal(moved.static_mask, [True, False, True, True])
    again = cache.plan(RANGES, delta(4, (12, 1)), key=("k",))
    assert not again.render_static and again.render_dynamic
    rest = cache.plan(RANGES, delta(5), key=("k",))
    assert not rest.anything


def test_a_large_object_moving_every_frame_leaves_the_static_layer_alone():
    """Three quarters of the triangles moving (one large object) re-render the dynamic layer
    only, after the one demotion."""
    cache = ShadowCache()
    ranges = np.array([[0, 100], [100, 900], [1000, 200]], np.int32)
    plans = []
    for frame in range(4):
        # The large object moves every frame after the first.
        delta = (GeometryDelta(full=False, ranges=((100, 900),), changed_triangles=900, sequence=frame + 1)
                 if frame else GeometryDelta.everything(1200, sequence=1))
        plans.append(cache.plan(ranges, delta, key=("k",)))
    assert plans[1].render_static and plans[1].static_mask.tolist() == [True, False, True]
    for plan in plans[2:]:
        assert plan.render_dynamic and not plan.render_static


def test_plan_promotes_an_object_after_it_rested():
    cache = ShadowCache()
    cache.plan(RANGES, delta(1, (0, 35), full=True), key=())
    cache.plan(RANGES, delta(2, (12, 1)), key=())
    plans = [cache.plan(RANGES, delta(3 + i), key=()) for i in range(PROMOTE_AFTER_FRAMES)]
    assert not any(p.anything for p in plans[:-1])
    assert plans[-1].render_static and plans[-1].static_mask.all()


def test_a_new_key_re_renders_both_layers_and_keeps_what_moves_in_the_dynamic_one():
    """A sun cascade's matrix changes under a moving camera while a piece moves: both layers
    are drawn once, the moving piece in the dynamic one, and the next frame with the same
    key draws the dynamic layer alone (not the static one again, as a reset would)."""
    cache = ShadowCache()
    cache.plan(RANGES, delta(1, (0, 35), full=True), key=("a",))
    cache.plan(RANGES, delta(2, (12, 1)), key=("a",))  # object 1 moves: demoted
    plan = cache.plan(RANGES, delta(3, (12, 1)), key=("b",))
    assert plan.render_static and plan.render_dynamic
    assert plan.static_mask.tolist() == [True, False, True, True]
    plan = cache.plan(RANGES, delta(4, (12, 1)), key=("b",))
    assert not plan.render_static and plan.render_dynamic


@pytest.mark.parametrize("change", ["missed_delta", "layout"])
def test_plan_re_renders_both_layers_when_it_cannot_trust_its_state(change):
    cache = ShadowCache()
    cache.plan(RANGES, delta(1, (0, 35), full=True), key=("a",))
    cache.plan(RANGES, delta(2, (12, 1)), key=("a",))
    ranges, key, sequence = RANGES, ("a",), 3
    if change == "missed_delta":
        sequence = 4  # frame 3's delta went to an upload whose frame was cancelled
    else:
        ranges = RANGES[:3]
    plan = cache.plan(ranges, delta(sequence), key=key)
    assert plan.render_static and plan.render_dynamic and plan.static_mask.all()


def test_an_animation_renders_only_the_moving_objects_shadows_and_matches_fresh_renders(gl):
    # The sun's cascades follow the moving camera (test_sun_cascades.py): off here.
    settings = RenderSettings(mode="RASTER", shadow_resolution=256, shadow_cascades=0)
    frames = [build_chess(0.02, frame, 64, 36) for frame in range(4)]
    renderer = Renderer(gl)
    try:
        results = [renderer.render(scene, camera, settings) for scene, camera in frames]
    finally:
        renderer.release()
    static_rendered = [r.counts["shadow_static_rendered"] for r in results]
    assert static_rendered[:2] == [1, 1]  # everything, then everything but what moved
    assert static_rendered[2:] == [0, 0]  # the same pieces keep moving: dynamic layer only
    submitted = [r.counts["shadow_triangles_submitted"] for r in results]
    assert 0 < submitted[3] < 0.75 * submitted[0]  # at this detail the pieces outweigh the boards
    scene, camera = frames[3]
    fresh = Renderer(gl)
    try:
        expected = fresh.render(scene, camera, settings)
    finally:
        fresh.release()
    assert expected.counts["shadow_static_rendered"] == 1
    np.testing.assert_array_equal(results[3].image, expected.image)
