# SPDX-License-Identifier: GPL-3.0-or-later
"""hybrid_engine/passes/lighting/resources.py and the tables it hands to the shading passes: the lights
and shadow slots are uniform blocks of fixed size (include/lighting.glsl), so the host's
limits must be the blocks' own, and a scene past them fails with a message that says what
to do instead of shading garbage."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine.gpu import shader_loader
from hybrid_engine.passes.lighting.resources import MAX_LIGHTS, FrameResources
from hybrid_engine.gpu.dispatch import SceneLimitError
from hybrid_engine.passes.lighting.lights import LIGHT_DTYPE
from hybrid_engine.scene.data import Lights
from hybrid_engine.scene.settings import RenderSettings
from hybrid_engine.passes.shadow_maps.shadow_depth import ShadowMaps
from hybrid_engine.passes.shadow_maps.shadow_atlas import MAX_SHADOW_SLOTS, SHADOW_SLOT_DTYPE, ShadowAtlas, ShadowView


def test_the_hosts_limits_are_the_sizes_of_the_shaders_uniform_blocks(ctx):
    program = shader_loader.compute(ctx, "shading/deferred_shade.comp.glsl")
    assert program["LightBuffer"].size == MAX_LIGHTS * LIGHT_DTYPE.itemsize
    assert program["ShadowSlotBuffer"].size == MAX_SHADOW_SLOTS * SHADOW_SLOT_DTYPE.itemsize
    resources, atlas = FrameResources(ctx), ShadowAtlas(ctx)
    try:  # each buffer holds its whole block, whatever the scene uses of it
        assert resources.lights.buffer.size >= program["LightBuffer"].size
        atlas.ensure_bindable()
        assert atlas.slot_buffer.size >= program["ShadowSlotBuffer"].size
    finally:
        resources.release()
        atlas.release()


def test_a_scene_with_more_lamps_than_the_table_holds_fails_naming_the_count_and_the_limit(ctx):
    resources, atlas = FrameResources(ctx), ShadowAtlas(ctx)

    def shadows(count: int) -> ShadowMaps:
        return ShadowMaps(atlas, [(-1, 0)] * count, rendered=False, static_rendered=False, submitted=0)

    try:
        lights = Lights.from_rows([{"kind": "POINT", "cast_shadow": False}] * (MAX_LIGHTS + 1))
        with pytest.raises(SceneLimitError, match=rf"{MAX_LIGHTS + 1} lamps.*at most {MAX_LIGHTS}"):
            resources.update_lights(lights, shadows(len(lights)), RenderSettings())
        resources.update_lights(Lights.from_rows([{"kind": "POINT"}] * MAX_LIGHTS), shadows(MAX_LIGHTS),
                                RenderSettings())
    finally:
        resources.release()
        atlas.release()


def test_more_shadow_maps_than_the_slot_table_holds_fail_naming_cast_shadow(ctx):
    atlas = ShadowAtlas(ctx)
    try:
        view = ShadowView(view_proj=np.eye(4), extent=1.0, perspective=False, near=0.1, far=10.0)
        with pytest.raises(SceneLimitError, match=r"Cast Shadow"):
            atlas.layout([view] * (MAX_SHADOW_SLOTS + 1), 1)
    finally:
        atlas.release()


def test_the_lamp_updates_count_a_frame_only_when_a_lamp_changed(ctx):
    # The denoiser and the radiance cache drop the light they keep across frames when this
    # count moves, so an unchanged lamp must not move it, and any changed number must.
    resources, atlas = FrameResources(ctx), ShadowAtlas(ctx)
    shadows = ShadowMaps(atlas, [(-1, 0)], rendered=False, static_rendered=False, submitted=0)
    lamp = {"kind": "POINT", "cast_shadow": False, "color": (1.0, 1.0, 1.0)}
    try:
        counts = []
        for row in (lamp, dict(lamp), {**lamp, "color": (1.0, 0.5, 1.0)}, {**lamp, "color": (1.0, 0.5, 1.0)}):
            resources.update_lights(Lights.from_rows([row]), shadows, RenderSettings())
            counts.append(resources.lamp_updates)
        assert counts == [1, 1, 2, 2]
    finally:
        resources.release()
        atlas.release()
