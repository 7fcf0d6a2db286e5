# SPDX-License-Identifier: GPL-3.0-or-later
"""The sun disc of a Sky Texture's scattering models, as a sun lamp.

Blender's Multiple and Single Scattering skies draw the sun as a disc of Sun Size (half a
degree by default) whose radiance is the sunlight that crosses the atmosphere to the viewer
(the spectral transmittance along the sun's direction, over the disc's solid angle), darkened
towards the limb as 1 - 0.6 (1 - sqrt(1 - (r / R)^2)). That disc is most of a clear day's
light on a diffuse surface, and a World bake cannot carry it: its texels are wider than the
disc, so a bake would hold it in one texel or none, and the nine-coefficient irradiance would
smear what it holds. So the disc is not baked (tex_sky.glsl); it becomes a sun lamp of the
same direction, angular size and irradiance (the disc's radiance integrated over its solid
angle, the limb darkening's mean 0.8 included), which lights, shadows and highlights as
every lamp does. Cycles samples the disc as a light too (its "sun guiding").

Only a disc whose light reaches the World unchanged can be a lamp: a Sky Texture whose Color
feeds the surface Background's Color directly, its Vector unlinked, the Background's
Strength a constant (the lamp takes it). ``sun_rows`` returns the lamp rows of such nodes.

The transmittance is computed here on the CPU, as in the sky's own shaders
(include/nodes/sky_atmosphere.glsl, sky_single.glsl): one direction, a few hundred
operations, when the scene is built.
"""
from __future__ import annotations

import math

import numpy as np

from .shader_graph import Link, ShaderGraph

# Multiple Scattering (include/nodes/sky_atmosphere.glsl): 630, 560, 490, 430 nm.
_MS_SUN = np.array([1.679, 1.828, 1.986, 1.307])
_MS_MOLECULAR = np.array([6.605e-3, 1.067e-2, 1.842e-2, 3.156e-2])
_MS_OZONE = np.array([3.472e-25, 3.914e-25, 1.349e-25, 11.03e-27])
_MS_AEROSOL_ABSORPTION = np.array([2.8722e-24, 4.6168e-24, 7.9706e-24, 1.3578e-23])
_MS_AEROSOL_SCATTERING = np.array([1.5908e-22, 1.7711e-22, 2.0942e-22, 2.4033e-22])
_MS_TO_XYZ = np.array([[53.386917738564668, 43.904844466369358, 1.6137278251608962, 20.762668673810577],
                       [22.981337506691025, 71.347795700053394, 18.422960591455485, 2.3614213523314369],
                       [0.0, 0.102506867965741307, 31.742921188390806, 110.48009643252140]])
_EARTH_KM, _SHELL_KM = 6371.0, 100.0

# Single Scattering (include/nodes/sky_single.glsl): 380, 400, ..., 780 nm.
_SS_IRRADIANCE = np.array([
    1.45756829855592995315, 1.56596305559738380175, 1.65148449067670455293, 1.71496242737209314555,
    1.75797983805020541226, 1.78256407885924539336, 1.79095108475838560302, 1.78541550133410664714,
    1.76815554864306845317, 1.74122069647250410362, 1.70647127164943679389, 1.66556087452739887134,
    1.61993437242451854274, 1.57083597368892080581, 1.51932335059305478886, 1.46628494965214395407,
    1.41245852740172450623, 1.35844961970384092709, 1.30474913844739281998, 1.25174963272610817455,
    1.19975998755420620867])
_SS_RAYLEIGH = np.array([
    5.424820087636473e-5, 4.418549866505454e-5, 3.635151910165377e-5, 3.017929012024763e-5,
    2.526320226989157e-5, 2.130859310621843e-5, 1.809838025320633e-5, 1.547057129129042e-5,
    1.330284977336850e-5, 1.150184784075764e-5, 9.99557429990163e-6, 8.72799973630707e-6,
    7.65513700977967e-6, 6.74217203751443e-6, 5.96134125832052e-6, 5.29034598065810e-6,
    4.71115687557433e-6, 4.20910481110487e-6, 3.77218381260133e-6, 3.39051255477280e-6,
    3.05591531679811e-6])
_SS_CMF = np.array([
    (0.00136800000, 0.00003900000, 0.00645000100), (0.01431000000, 0.00039600000, 0.06785001000),
    (0.13438000000, 0.00400000000, 0.64560000000), (0.34828000000, 0.02300000000, 1.74706000000),
    (0.29080000000, 0.06000000000, 1.66920000000), (0.09564000000, 0.13902000000, 0.81295010000),
    (0.00490000000, 0.32300000000, 0.27200000000), (0.06327000000, 0.71000000000, 0.07824999000),
    (0.29040000000, 0.95400000000, 0.02030000000), (0.59450000000, 0.99500000000, 0.00390000000),
    (0.91630000000, 0.87000000000, 0.00165000100), (1.06220000000, 0.63100000000, 0.00080000000),
    (0.85444990000, 0.38100000000, 0.00019000000), (0.44790000000, 0.17500000000, 0.00002000000),
    (0.16490000000, 0.06100000000, 0.00000000000), (0.04677000000, 0.01700000000, 0.00000000000),
    (0.01135916000, 0.00410200000, 0.00000000000), (0.00289932700, 0.00104700000, 0.00000000000),
    (0.00069007860, 0.00024920000, 0.00000000000), (0.00016615050, 0.00006000000, 0.00000000000),
    (0.00004150994, 0.00001499000, 0.00000000000)])
_SS_EARTH, _SS_TOP, _SS_MIE = 6360e3, 6420e3, 2e-5
# The 8-point Gauss-Laguerre rule scaled into the atmosphere (sky_single.glsl).
_LAGUERRE_X, _LAGUERRE_W = np.polynomial.laguerre.laggauss(8)
_SS_NODES, _SS_WEIGHTS = _LAGUERRE_X / 25.0, _LAGUERRE_W * np.exp(_LAGUERRE_X) / 25.0

_XYZ_TO_RGB = np.array([[3.2404542, -1.5371385, -0.4985314],
                        [-0.9692660, 1.8760108, 0.0415560],
                        [0.0556434, -0.2040259, 1.0572252]])
LIMB_MEAN = 0.8  # mean over the disc of 1 - 0.6 (1 - sqrt(1 - rho^2))


def _ms_transmittance(elevation: float, altitude_km: float, density: np.ndarray) -> np.ndarray:
    """Four-wavelength transmittance from ``altitude_km`` to the top along ``elevation``."""
    direction = np.array([-math.cos(elevation), 0.0, math.sin(elevation)])
    origin = np.array([0.0, 0.0, _EARTH_KM + altitude_km])
    b = origin @ direction
    c = origin @ origin - (_EARTH_KM + _SHELL_KM) ** 2
    length = -b + math.sqrt(max(b * b - c, 0.0))
    t = (np.arange(64) + 0.5) * length / 64
    h = np.maximum(np.linalg.norm(origin[None, :] + t[:, None] * direction[None, :], axis=1) - _EARTH_KM, 0.0)
    log_h = np.log(np.maximum(h, 1e-4))
    ozone = 3.78547397e20 * np.exp(-(log_h - 3.22261) ** 2 * 5.55555555 - log_h)
    aerosol = 1.3681e20 * (np.exp(-h / 0.73) + 2e6 / 1.3681e20) * density[1]
    extinction = (_MS_MOLECULAR[None, :] * np.exp(-0.07771971 * h ** 1.16364243)[:, None] * density[0]
                  + (_MS_AEROSOL_SCATTERING + _MS_AEROSOL_ABSORPTION)[None, :] * aerosol[:, None]
                  + _MS_OZONE[None, :] * 334.5 * ozone[:, None] * density[2])
    return np.exp(-extinction.sum(0) * length / 64)


def _ss_transmittance(elevation: float, altitude_m: float, density: np.ndarray) -> np.ndarray:
    """21-wavelength transmittance (air and aerosol; the model leaves ozone out of the disc)."""
    direction = np.array([math.cos(elevation), 0.0, math.sin(elevation)])
    origin = np.array([0.0, 0.0, _SS_EARTH + altitude_m])
    b = origin @ direction
    length = -b + math.sqrt(max(b * b - (origin @ origin - _SS_TOP ** 2), 0.0))
    h = np.linalg.norm(origin[None, :] + (_SS_NODES * length)[:, None] * direction[None, :], axis=1) - _SS_EARTH
    air = (np.exp(-h / 8e3) * _SS_WEIGHTS).sum() * length
    mie = (np.exp(-h / 1.2e3) * _SS_WEIGHTS).sum() * length
    return np.exp(-(_SS_RAYLEIGH * air * density[0] + 1.11 * _SS_MIE * mie * density[1]))


def _rgb(xyz: np.ndarray) -> np.ndarray:
    return np.maximum(_XYZ_TO_RGB @ xyz, 0.0)


def sun_direction(elevation: float, rotation: float) -> np.ndarray:
    """Towards the sun, as Cycles places it (tex_sky.glsl node_sky_sun)."""
    return np.array([math.cos(elevation) * math.sin(rotation), math.cos(elevation) * math.cos(rotation),
                     math.sin(elevation)])


def disc_irradiance(settings: dict) -> np.ndarray:
    """RGB irradiance of the sun disc on a surface facing it (Sun Intensity included): the
    mean of the disc's lowest and highest radiance (Cycles interpolates between the two)
    times the limb darkening's mean, over the disc's solid angle; the part of the disc
    below the horizon (the Earth's edge seen from the altitude) is cut off."""
    model = str(settings.get("sky_type", "MULTIPLE_SCATTERING"))
    size = max(float(settings.get("sun_size", 0.009512044)), 0.0)
    elevation = math.asin(float(np.clip(sun_direction(float(settings.get("sun_elevation", math.radians(15.0))),
                                                      0.0)[2], -1.0, 1.0)))
    altitude = float(settings.get("altitude", 100.0))
    density = np.array([float(settings.get(k, 1.0)) for k in ("air_density", "aerosol_density", "ozone_density")])
    half = 0.5 * size
    if model == "MULTIPLE_SCATTERING":
        altitude_km = min(max(altitude, 1.0), 99999.0) / 1000.0
        horizon = -(math.pi / 2 - math.asin(_EARTH_KM / (_EARTH_KM + altitude / 1000.0)))
        edges = [_rgb(_MS_TO_XYZ @ (_MS_SUN * _ms_transmittance(elevation + s * half, altitude_km, density)))
                 for s in (-1.0, 1.0)]
    elif model == "SINGLE_SCATTERING":
        altitude_m = min(max(altitude, 1.0), 59999.0)
        horizon = 0.0  # the model draws no disc below the horizon
        edges = [_rgb(20.0 * _SS_CMF.T @ (_SS_IRRADIANCE * _ss_transmittance(max(elevation + s * half, 0.0),
                                                                             altitude_m, density)))
                 for s in (-1.0, 1.0)]
    else:
        return np.zeros(3)
    if half <= 0.0:
        return np.zeros(3)
    # The visible fraction of a (small, flat) disc cut by the horizon at height c radii.
    c = float(np.clip((horizon - elevation) / half, -1.0, 1.0))
    visible = (math.acos(c) - c * math.sqrt(1.0 - c * c)) / math.pi
    return 0.5 * (edges[0] + edges[1]) * LIMB_MEAN * visible * float(settings.get("sun_intensity", 1.0))


def sun_rows(graph: ShaderGraph | None) -> list[dict]:
    """Sun lamp rows (data.Lights.from_rows) for the scattering Sky Textures of ``graph`` whose
    disc reaches the World unchanged (see the module docstring); [] for any other graph."""
    if graph is None or graph.surface is None:
        return []
    background = graph.nodes[graph.surface.node]
    color = background.inputs.get("Color")
    strength = background.inputs.get("Strength", 1.0)
    if background.kind != "BACKGROUND" or not isinstance(color, Link) or isinstance(strength, Link):
        return []
    sky = graph.nodes[color.node]
    settings = sky.settings
    if (sky.kind != "TEX_SKY" or color.output != "Color" or isinstance(sky.inputs.get("Vector"), Link)
            or str(settings.get("sky_type")) not in ("MULTIPLE_SCATTERING", "SINGLE_SCATTERING")
            or not settings.get("sun_disc", True)):
        return []
    irradiance = disc_irradiance(settings) * float(strength)
    if not irradiance.any():
        return []
    towards = sun_direction(float(settings.get("sun_elevation", math.radians(15.0))),
                            float(settings.get("sun_rotation", 0.0)))
    return [dict(kind="SUN", direction=tuple(-towards), color=tuple(irradiance),
                 radius=float(settings.get("sun_size", 0.009512044)), cast_shadow=True,
                 name=f"{sky.name or 'Sky Texture'} (sun disc)")]
