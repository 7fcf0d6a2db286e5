# SPDX-License-Identifier: GPL-3.0-or-later
"""The lighting data of a frame, in one owner: lights, the shadow maps' atlas, sky,
irradiance and the reach of the ambient occlusion.

Every pass that shades a surface (the deferred shading of the primary G-buffer, paper §3.5,
and the tracer's BVH and cube-map hits, §3.4) must light it alike, or a surface would change
its look with the structure that found it. So these passes receive one ``FrameResources``
and bind what it hands over; no pass reaches into another pass's objects for them. :meth:`FrameResources.bindings` is what they bind, by the names
include/lighting.glsl, sky.glsl and world_light.glsl declare.
"""
from __future__ import annotations

import numpy as np

from ...gpu.bindings import Bindings
from ...gpu.dispatch import GrowBuffer, SceneLimitError, bytes_of
from ...scene.data import Lights, Sky
from ...scene.light_linking import is_linked, mask_words
from ...scene.scale import typical_object_size
from ...scene.settings import RenderSettings
from ..frame_context import FrameContext, PassIO
from ..emitters.emitter_links import EmitterLinks
from ..shadow_maps.shadow_atlas import ShadowAtlas
from ..shadow_maps.shadow_depth import ShadowMaps
from .lights import LIGHT_DTYPE, lamps_key, pack_lights
from .sky_light import SkyLight

# Rows of the LightBuffer uniform block (include/lighting.glsl): 64 KiB of 64-byte lights.
MAX_LIGHTS = 1024


class FrameResources:
    """Lights, shadow atlas and World light on the shared context, kept across frames."""

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.lights = GrowBuffer(ctx, "scene lights", LIGHT_DTYPE.itemsize)
        # The uniform block's whole size (lighting.glsl): a block reads what it declares.
        self.lights.ensure(MAX_LIGHTS * LIGHT_DTYPE.itemsize)
        self.shadows: ShadowAtlas | None = None  # the shadow maps' atlas of this frame
        self.sky = SkyLight(ctx)
        self.light_count = 0
        # How often the lamps changed (the passes that keep light across frames compare it
        # with sky.updates, the World's count), and the lamps they were last.
        self.lamp_updates = 0
        self._lamps: bytes | None = None
        self.shadow_bias = 0.0
        self.shadow_bias_texels = 0.0
        self.shadow_normal_offset = 0.0
        self.ao_distance = 0.0
        self.diffuse_rays = False  # diffuse light gathered by paths (passes/diffuse_light/)
        # The length the stochastic estimates' position keys are measured in (random.glsl's
        # u_random_unit): the scene's typical object size, so that the noise of one scene is
        # one pattern whether it is modelled in millimetres or kilometres.
        self.random_unit = 1.0
        # Light linking (scene/light_linking.py): the lamps' receiver masks, made and bound
        # only for a scene whose lamps are linked, so that others compile nothing new.
        self.linked = False
        self._links = None
        # The emissive objects' linking (passes/emitters/emitter_links.py): every pass that
        # gathers or sees their light (the diffuse paths' next-event estimate, the tracer's
        # hits) binds it with the lamps', only for a scene whose emitters are linked.
        self.emitter_links = EmitterLinks(ctx)

    def update_lights(self, lights: Lights, shadows: ShadowMaps, settings: RenderSettings,
                      linked: bool = False) -> None:
        """This frame's lights with their shadow slots (laid out in ``shadows.atlas``), and
        the settings of the lighting (shadow bias, ambient-occlusion reach). ``linked``: some
        lamp lights less than every object (light_linking.is_linked)."""
        if len(lights) > MAX_LIGHTS:
            raise SceneLimitError(f"the scene has {len(lights)} lamps; Hybrid RT renders at most {MAX_LIGHTS}: "
                                  "hide some, or light with emissive meshes or the World")
        self.lights.upload(bytes_of(pack_lights(lights, shadows.per_light)))
        lamps = lamps_key(lights)
        if lamps != self._lamps:
            self._lamps = lamps
            self.lamp_updates += 1
        self.linked = linked
        if linked:
            if self._links is None:
                self._links = self.ctx.buffer(reserve=MAX_LIGHTS * 16)  # the whole block, as above
            rows = np.zeros((MAX_LIGHTS, 4), np.uint32)
            rows[:len(lights), :2] = mask_words(lights.light_mask)
            rows[:len(lights), 2:] = mask_words(lights.shadow_mask)
            self._links.write(rows.tobytes())
        self.shadows = shadows.atlas
        self.light_count = len(lights)
        self.shadow_bias = float(settings.shadow_bias)
        self.shadow_bias_texels = float(settings.shadow_bias_texels)
        self.shadow_normal_offset = float(settings.shadow_normal_offset)
        self.ao_distance = float(settings.ao_distance)
        self.diffuse_rays = settings.traces_diffuse

    @property
    def defines(self) -> dict:
        """What the shaders that light a surface need defined: ``LIGHT_LINKING`` (the lamp
        loop's set test, include/lighting.glsl) only when the scene's lamps are linked,
        ``EMITTER_LINKING`` (include/emitter_links.glsl) only when its emitters are."""
        return {**({"LIGHT_LINKING": 1} if self.linked else {}), **self.emitter_links.defines}

    @property
    def occludes(self) -> bool:
        """Whether a pass estimates the sky's visibility (screen_ao.py, or the diffuse paths)."""
        return self.ao_distance > 0.0 or self.diffuse_rays

    def update_sky(self, sky: Sky) -> None:
        """The World (recomputed only when it changed, sky_light.py)."""
        self.sky.update(sky)

    def bindings(self) -> Bindings:
        """The lighting's storage blocks, samplers and uniforms, for every shading pass."""
        if self.shadows is None:
            raise RuntimeError("FrameResources.update_lights must run before the lighting is bound")
        self.shadows.ensure_bindable()
        links = {"LightLinkBuffer": self._links} if self.linked else {}
        links.update(self.emitter_links.bindings().storage)
        return Bindings(
            storage={"LightBuffer": self.lights.buffer, "ShadowSlotBuffer": self.shadows.slot_buffer,
                     "SkyIrradiance": self.sky.sh_buffer, **links},
            textures={"u_shadow_atlas": self.shadows.static, "u_shadow_dynamic": self.shadows.dynamic,
                      "u_sky_env": self.sky.texture()},
            uniforms={**self.sky.uniforms(), "u_light_count": self.light_count, "u_shadow_bias": self.shadow_bias,
                      "u_shadow_bias_texels": self.shadow_bias_texels,
                      "u_shadow_normal_offset": self.shadow_normal_offset,
                      "u_ao_distance": self.ao_distance, "u_sky_visibility_known": int(self.occludes),
                      "u_ambient_from_rays": int(self.diffuse_rays), "u_random_unit": self.random_unit})

    def release(self) -> None:
        self.lights.release()
        self.sky.release()
        self.emitter_links.release()
        if self._links is not None:
            self._links.release()
            self._links = None


class LightingPass:
    """The lighting resources of a frame: the lamps with the slots the shadow pass laid out,
    and the World's light (paper §3.5); every shading pass binds them."""

    name = "lighting"

    def __init__(self, resources: FrameResources) -> None:
        self.resources = resources

    def io(self, settings: RenderSettings) -> PassIO:
        return PassIO(reads=("scene", "shadow_maps"), writes=("lighting",))

    def run(self, frame: FrameContext) -> None:
        scene = frame.read("scene")
        self.resources.update_lights(scene.lights, frame.read("shadow_maps"), frame.settings,
                                     is_linked(scene.materials, scene.lights))
        self.resources.emitter_links.update(scene.materials)
        self.resources.update_sky(scene.sky)
        self.resources.random_unit = typical_object_size(scene)
        frame.write("lighting", self.resources)
