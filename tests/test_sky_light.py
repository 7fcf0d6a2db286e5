# SPDX-License-Identifier: GPL-3.0-or-later
"""The World's irradiance (hybrid_engine/passes/lighting/sky_light.py, gpu_shaders/lighting/) against a
brute-force numpy integral of the same environment, and its recompute-on-change rule."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine.scene.data import Sky
from hybrid_engine.passes.lighting.sky_light import SkyLight

SH_CONSTANTS = (0.282095, 0.488603, 1.092548, 0.315392, 0.546274)


def sh_irradiance(coeffs: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Evaluate nine irradiance coefficients (world_light.glsl's order) at unit normal n."""
    c0, c1, c2, c3, c4 = SH_CONSTANTS
    x, y, z = n
    basis = np.array([c0, c1 * y, c1 * z, c1 * x, c2 * x * y, c2 * y * z, c3 * (3 * z * z - 1), c2 * x * z,
                      c4 * (x * x - y * y)])
    return basis @ coeffs


def brute_force_irradiance(env: np.ndarray, n: np.ndarray, strength: float) -> np.ndarray:
    """The cosine-weighted integral of an equirectangular environment (Blender's mapping)."""
    h, w = env.shape[:2]
    u = (np.arange(w) + 0.5) / w
    v = (np.arange(h) + 0.5) / h
    phi = (0.5 - u) * 2 * np.pi
    lat = (v - 0.5) * np.pi
    lat, phi = np.meshgrid(lat, phi, indexing="ij")
    d = np.stack([np.cos(lat) * np.cos(phi), np.cos(lat) * np.sin(phi), np.sin(lat)], axis=-1)
    d_omega = (2 * np.pi / w) * (np.pi / h) * np.cos(lat)
    cos = np.maximum(d @ n, 0.0)
    return (env * (cos * d_omega)[..., None]).sum(axis=(0, 1)) * strength


@pytest.fixture
def sky_light(gl):
    light = SkyLight(gl)
    yield light
    light.release()


def test_a_uniform_sky_gives_pi_times_its_radiance_in_every_direction(sky_light):
    sky_light.update(Sky(color=(0.5, 0.6, 0.7), strength=2.0))
    for n in np.eye(3).tolist() + [[0, 0, -1], [0.6, 0, 0.8]]:
        np.testing.assert_allclose(sh_irradiance(sky_light.read_sh(), np.array(n)), np.pi * np.array([1.0, 1.2, 1.4]),
                                   rtol=1e-3)


def test_an_environment_map_irradiance_matches_the_brute_force_integral(sky_light):
    rng = np.random.default_rng(7)
    h, w = 64, 128
    lat = ((np.arange(h) + 0.5) / h - 0.5)[:, None] * np.pi
    lon = ((np.arange(w) + 0.5) / w)[None, :] * 2 * np.pi
    # A smooth sky: bright towards the zenith, a warm glow on one side, plus mild noise.
    env = np.empty((h, w, 3), np.float32)
    env[..., 0] = 1.0 + 0.8 * np.sin(lat) + 0.5 * np.cos(lon)
    env[..., 1] = 0.8 + 0.6 * np.sin(lat) + 0.2 * np.sin(lon)
    env[..., 2] = 0.6 + 0.9 * np.sin(lat)
    env = np.clip(env + rng.normal(0, 0.02, env.shape), 0.0, None).astype(np.float32)
    sky_light.update(Sky(color=(0, 0, 0), strength=1.5, environment=env))
    coeffs = sky_light.read_sh()
    for n in ([0, 0, 1], [0, 0, -1], [1, 0, 0], [0, -1, 0], [0.48, 0.6, 0.64]):
        n = np.array(n, float)
        n /= np.linalg.norm(n)
        expected = brute_force_irradiance(env.astype(np.float64), n, 1.5)
        np.testing.assert_allclose(sh_irradiance(coeffs, n), expected, rtol=0.05, atol=0.02 * expected.max())


def test_irradiance_is_recomputed_only_when_the_world_changes(sky_light):
    env = np.ones((8, 16, 3), np.float32)
    sky = Sky(color=(0.1, 0.1, 0.1), environment=env)
    sky_light.update(sky)
    sky_light.update(sky)
    assert sky_light.updates == 1
    sky_light.update(Sky(color=(0.1, 0.1, 0.1), strength=3.0, environment=env))
    assert sky_light.updates == 2
    np.testing.assert_allclose(sh_irradiance(sky_light.read_sh(), np.array([0, 0, 1.0])), [3 * np.pi] * 3, rtol=0.01)
