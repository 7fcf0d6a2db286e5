# SPDX-License-Identifier: GPL-3.0-or-later
"""Renderer modes (hybrid_engine/frame/renderer.py): every mode renders, reports its passes and
counts, and switching modes on one Renderer keeps each mode's result intact."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine import Camera, Geometry, Lights, MaterialTable, MODES, RenderSettings, SceneData, Sky
from hybrid_engine.scene.camera import look_at
from hybrid_engine.frame.renderer import MODE_STEPS, RenderCancelled
from scenes_analytic import quad, uv_sphere

SMALL = dict(cube_resolution=32, shadow_resolution=128, near_size=2.0)


def scene():
    ball, normals = uv_sphere((0, 0, 0), 1.0, 16, 8)
    mats = MaterialTable.from_rows([dict(base_color=(0.9, 0.9, 0.9), reflectivity=1.0),
                                    dict(base_color=(0.6, 0.6, 0.6))])
    return SceneData(Geometry.from_objects([(ball, normals, 0), (quad((0, 0, -1), (5, 0, 0), (0, 5, 0)), None, 1)]),
                     mats, Lights.from_rows([dict(kind="SUN", direction=(0, 0.3, -1), color=(2, 2, 2))]),
                     Sky(color=(0.2, 0.3, 0.5)))


CAMERA = Camera(matrix_world=look_at((0, -4, 1), (0, 0, 0)), width=24, height=16)


def test_every_mode_has_a_pass_list():
    assert set(MODE_STEPS) == set(MODES)


@pytest.mark.parametrize("mode", MODES)
def test_each_mode_renders_and_times_exactly_its_passes(renderer, mode):
    result = renderer.render(scene(), CAMERA, RenderSettings(mode=mode, **SMALL), timing=True)
    assert result.mode == mode
    assert result.image.shape == (16, 24, 4) and np.isfinite(result.image).all()
    assert tuple(result.passes) == MODE_STEPS[mode]
    assert result.counts["triangles_total"] == scene().geometry.triangle_count
    if mode in ("HYBRID", "FULL_BVH"):
        assert result.counts["rays_traced_bounce_1"] > 0


def test_switching_modes_on_one_renderer_gives_the_same_images_as_fresh_frames(renderer):
    first = {m: renderer.render(scene(), CAMERA, RenderSettings(mode=m, **SMALL)).image for m in MODES}
    for mode in reversed(MODES):
        again = renderer.render(scene(), CAMERA, RenderSettings(mode=mode, **SMALL)).image
        np.testing.assert_array_equal(again, first[mode], err_msg=mode)
    # RASTER's mirror sees the sky, the traced modes see the floor too: they differ.
    assert not np.array_equal(first["RASTER"], first["FULL_BVH"])


def test_cancel_before_the_trace_pass_leaves_the_renderer_usable(renderer):
    calls = []

    def cancel():
        calls.append(1)
        return len(calls) > MODE_STEPS["HYBRID"].index("trace")  # stop before the trace pass

    with pytest.raises(RenderCancelled, match="trace"):
        renderer.render(scene(), CAMERA, RenderSettings(mode="HYBRID", **SMALL), cancel=cancel)
    assert np.isfinite(renderer.render(scene(), CAMERA, RenderSettings(mode="HYBRID", **SMALL)).image).all()


def test_every_pass_of_a_frame_ends_with_a_full_memory_barrier(renderer, monkeypatch):
    """Passes hand images and buffers over in whatever way the next one reads them; on a GPU
    whose caches are not coherent only a full barrier makes them visible (gpu/dispatch.py
    pass_barrier). Without it, RASTER images on an NVIDIA GPU changed with the mode rendered
    before them: llvmpipe cannot show that, so the barrier's presence is what is tested."""
    import moderngl

    from hybrid_engine.frame import renderer as renderer_module

    bits = []
    monkeypatch.setattr(renderer_module, "pass_barrier",
                        lambda ctx: (bits.append(moderngl.ALL_BARRIER_BITS), ctx.memory_barrier()))
    result = renderer.render(scene(), CAMERA, RenderSettings(mode="HYBRID", **SMALL), timing=True)
    ran = [name for name in result.passes if name != "readback"]
    assert len(bits) >= len(ran) >= len(MODE_STEPS["HYBRID"]) - 1  # several passes may share a step
