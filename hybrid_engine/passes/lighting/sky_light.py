# SPDX-License-Identifier: GPL-3.0-or-later
"""The World as a light: its environment texture and its irradiance on diffuse surfaces.

The sky is the radiance every ray that escapes the scene sees (paper §3.4), and it lights
every diffuse surface too, which the paper's lamp-only shading leaves out: a cube under a
white World and no lamps would render black. The irradiance is the sky projected onto
nine spherical harmonics and convolved with the clamped cosine (Ramamoorthi and Hanrahan,
"An Efficient Representation for Irradiance Environment Maps", 2001): smooth enough that
nine coefficients hold it within a few percent, and cheap enough to evaluate at every hit.

Both are recomputed on the GPU only when the World changes (a different environment
image, colour or strength, or new values in its node graph); a frame with the same World
binds what is there. A World with a node graph is baked into an environment first
(world_bake.py), which then stands where an image would, at strength 1.
"""
from __future__ import annotations

import math

import numpy as np

from ...gpu import shader_loader
from ...gpu.bindings import bind
from ...gpu.dispatch import storage_barrier
from ...scene.data import Sky
from .world_bake import WorldBake

# Width of the latitude-longitude grid the projection integrates over (sky_irradiance.comp.glsl).
SKY_GRID_WIDTH = 128


class SkyLight:
    """The environment texture (mipmapped, for rough reflections) and the irradiance SH."""

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.environment = None  # moderngl texture, or None for a constant colour
        self._dummy = ctx.texture((1, 1), 3, dtype="f4")
        self.sh_buffer = ctx.buffer(reserve=9 * 16)
        self._program = shader_loader.compute(ctx, "lighting/sky_irradiance.comp.glsl")
        self.world_bake: WorldBake | None = None  # made with the first World graph
        self._baked = False  # the environment is world_bake's texture
        self._key: tuple | None = None
        self._env_key: tuple | None = None
        self._uniforms: dict = {}
        self.updates = 0  # how often the irradiance was recomputed (tests, statistics)

    def update(self, sky: Sky) -> None:
        """Make the textures and coefficients match ``sky``; nothing when it is unchanged."""
        if sky.graph is not None:
            if self.world_bake is None:
                self.world_bake = WorldBake(self.ctx)
            self.world_bake.update(sky.graph, sky.images)
            key = ("graph", self.world_bake.bakes)
            if key == self._key:
                return
            self._upload_environment(None)
            self._env_key = None
            self._baked = True
            tex = self.world_bake.texture
            sky = Sky(color=(1.0, 1.0, 1.0), strength=1.0)
        else:
            env = sky.environment
            env_key = None if env is None else (id(env), env.shape)
            key = (env_key, tuple(sky.color), float(sky.strength))
            if key == self._key:
                return
            self._baked = False
            if env_key != self._env_key:
                self._upload_environment(env)
                self._env_key = env_key
            tex = self.environment
        width = tex.size[0] if tex is not None else 1
        levels = 1 + int(math.floor(math.log2(max(tex.size)))) if tex is not None else 1
        self._uniforms = {
            "u_sky_color": tuple(sky.color),
            "u_sky_strength": float(sky.strength),
            "u_sky_has_env": int(tex is not None),
            "u_sky_env_levels": float(levels),
            "u_sky_env_width": float(width),
        }
        self._project(width)
        self._key = key
        self.updates += 1

    def _upload_environment(self, env: np.ndarray | None) -> None:
        if self.environment is not None:
            self.environment.release()
            self.environment = None
        if env is None:
            return
        h, w = env.shape[:2]
        tex = self.ctx.texture((w, h), 3, np.ascontiguousarray(env, np.float32).tobytes(), dtype="f4")
        tex.repeat_x, tex.repeat_y = True, False
        tex.build_mipmaps()
        tex.filter = (self.ctx.LINEAR_MIPMAP_LINEAR, self.ctx.LINEAR)
        self.environment = tex

    def _project(self, width: int) -> None:
        prog = self._program
        grid_lod = max(0.0, math.log2(max(width, 1) / SKY_GRID_WIDTH))
        bind(prog, storage={"SkyIrradianceOut": self.sh_buffer}, textures={"u_sky_env": self.texture()},
             uniforms={**self._uniforms, "u_grid_lod": grid_lod})
        prog.run(1, 1, 1)
        storage_barrier(self.ctx)

    def texture(self):
        """The environment (an image's or the World graph's bake), or a 1x1 placeholder for a
        constant colour (always bindable)."""
        if self._baked and self.world_bake is not None:
            return self.world_bake.texture
        return self.environment if self.environment is not None else self._dummy

    def uniforms(self) -> dict:
        """sky.glsl's uniforms (all but the sampler's unit)."""
        return dict(self._uniforms)

    def read_sh(self) -> np.ndarray:
        """The nine irradiance coefficients as (9, 3) float32 (tests)."""
        return np.frombuffer(self.sh_buffer.read(), np.float32).reshape(9, 4)[:, :3].copy()

    def release(self) -> None:
        if self.world_bake is not None:
            self.world_bake.release()
            self.world_bake = None
        for obj in (self.environment, self._dummy, self.sh_buffer):
            if obj is not None:
                obj.release()
        self.environment = None
