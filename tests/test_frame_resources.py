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
from hybrid_engine.passes.scene_upload.scene_buffers import LIGHT_DTYPE
from hybrid_engine.scene.data import Lights
from hybrid_engine.scene.settings import RenderSettings
from hybrid_engine.passes.lighting.shadow_atlas import MAX_SHADOW_SLOTS, SHADOW_SLOT_DTYPE, ShadowAtlas, ShadowView


def test_the_hosts_limits_are_the_sizes_of_the_shaders_uniform_blocks(ctx):
    program = shader_loader.compute(ctx, "shading/deferred_shade.comp.glsl")
    assert program["LightBuffer"].size == MAX_LIGHTS * LIGHT_DTYPE.itemsize
    assert program["ShadowSlotBuffer"].size == MAX_SHADOW_SLOTS * SHADOW_SLOT_DTYPE.itemsize
    resources = FrameResources(ctx)
    try:  # each buffer holds its whole block, whatever the scene uses of it
        assert resources.lights.buffer.size >= program["LightBuffer"].size
        assert resources.shadows.slot_buffer.size >= program["ShadowSlotBuffer"].size
    finally:
        resources.release()


def test_a_scene_with_more_lamps_than_the_table_holds_fails_naming_the_count_and_the_limit(ctx):
    resources = FrameResources(ctx)
    try:
        lights = Lights.from_rows([{"kind": "POINT", "cast_shadow": False}] * (MAX_LIGHTS + 1))
        with pytest.raises(SceneLimitError, match=rf"{MAX_LIGHTS + 1} lamps.*at most {MAX_LIGHTS}"):
            resources.update_lights(lights, [(-1, 0)] * len(lights), RenderSettings())
        resources.update_lights(Lights.from_rows([{"kind": "POINT"}] * MAX_LIGHTS), [(-1, 0)] * MAX_LIGHTS,
                                RenderSettings())
    finally:
        resources.release()


def test_more_shadow_maps_than_the_slot_table_holds_fail_naming_cast_shadow(ctx):
    atlas = ShadowAtlas(ctx)
    try:
        view = ShadowView(view_proj=np.eye(4), extent=1.0, perspective=False, near=0.1, far=10.0)
        with pytest.raises(SceneLimitError, match=r"Cast Shadow"):
            atlas.layout([view] * (MAX_SHADOW_SLOTS + 1), 1)
    finally:
        atlas.release()
