// SPDX-License-Identifier: GPL-3.0-or-later
// The atmosphere of Blender's Multiple Scattering sky (García Liñán's spectral model, the
// one Blender 5 evaluates; see fgarlin.com "spectral_sky"): a spherical Earth of radius
// 6371 km under a 100 km shell, scattering sampled at four wavelengths (630, 560, 490 and
// 430 nm) that a fitted 4x3 matrix turns into XYZ. Three constituents, each with its own
// altitude profile (h in km) and a density multiplier the artist sets (Air, Aerosol, Ozone):
// - molecules scatter (Rayleigh), their density falling as exp(-0.0778 h^1.164);
// - ozone absorbs, in a log-normal layer peaking near 25 km (334.5 Dobson units on average);
// - aerosols scatter and absorb, an exponential of 0.73 km scale height over a background.
// Pure functions, shared by the transmittance table (lighting/sky_transmittance.comp.glsl)
// and the sky's in-scattering (tex_sky.glsl).
#ifndef HYBRID_SKY_ATMOSPHERE_GLSL
#define HYBRID_SKY_ATMOSPHERE_GLSL

#define SKY_EARTH_KM 6371.0
#define SKY_SHELL_KM 100.0
// The transmittance table: cos(zenith angle) across, normalised altitude up; one block of
// SKY_LUT_H rows per Sky Texture node (world_bake.py stacks them).
#define SKY_LUT_W 256
#define SKY_LUT_H 64
#define SKY_LUT_STEPS 64

const vec4 SKY_SUN_IRRADIANCE = vec4(1.679, 1.828, 1.986, 1.307);
const vec4 SKY_MOLECULAR_SCATTERING = vec4(6.605e-3, 1.067e-2, 1.842e-2, 3.156e-2);  // per km at sea level
// Cross sections (cm^2-scaled as the model fits them) times the number densities below.
const vec4 SKY_OZONE_CROSS_SECTION = vec4(3.472e-25, 3.914e-25, 1.349e-25, 11.03e-27);
const vec4 SKY_AEROSOL_ABSORPTION = vec4(2.8722e-24, 4.6168e-24, 7.9706e-24, 1.3578e-23);
const vec4 SKY_AEROSOL_SCATTERING = vec4(1.5908e-22, 1.7711e-22, 2.0942e-22, 2.4033e-22);
// Columns: the four wavelengths' contributions to X, Y, Z.
const mat4x3 SKY_SPECTRAL_TO_XYZ = mat4x3(
    vec3(53.386917738564668, 22.981337506691025, 0.0),
    vec3(43.904844466369358, 71.347795700053394, 0.102506867965741307),
    vec3(1.6137278251608962, 18.422960591455485, 31.742921188390806),
    vec3(20.762668673810577, 2.3614213523314369, 110.48009643252140));

// Extinction (all four constituents) and the two scattering terms at altitude h km,
// the artist's multipliers in ``density`` (air, aerosol, ozone).
void sky_ms_coefficients(float h, vec3 density, out vec4 extinction, out vec4 molecular, out vec4 aerosol) {
    molecular = SKY_MOLECULAR_SCATTERING * exp(-0.07771971 * pow(h, 1.16364243)) * density.x;
    float log_h = log(max(h, 1e-4));
    float ozone_number = 3.78547397e20 * exp(-(log_h - 3.22261) * (log_h - 3.22261) * 5.55555555 - log_h);
    vec4 ozone = SKY_OZONE_CROSS_SECTION * 334.5 * ozone_number * density.z;
    float aerosol_number = 1.3681e20 * (exp(-h / 0.73) + 2e6 / 1.3681e20) * density.y;
    aerosol = SKY_AEROSOL_SCATTERING * aerosol_number;
    extinction = molecular + aerosol + SKY_AEROSOL_ABSORPTION * aerosol_number + ozone;
}

// Distance along ``dir`` from ``origin`` to a sphere of ``radius`` about the Earth's centre:
// the nearer crossing ahead, the far one from inside, -1 when missed or behind.
float sky_sphere_distance(vec3 origin, vec3 dir, float radius) {
    float b = dot(origin, dir);
    float c = dot(origin, origin) - radius * radius;
    if (c > 0.0 && b > 0.0) return -1.0;
    float d = b * b - c;
    if (d < 0.0) return -1.0;
    return d >= b * b ? -b + sqrt(d) : -b - sqrt(d);
}

// Transmittance to the top of the shell from normalised altitude ``altitude`` towards a
// direction at zenith cosine ``cos_zenith`` (midpoint rule; the Earth does not block:
// a direction below the horizon is attenuated through ground-level air, as the model does).
vec4 sky_ms_transmittance(float cos_zenith, float altitude, vec3 density) {
    vec3 dir = vec3(-sqrt(max(1.0 - cos_zenith * cos_zenith, 0.0)), 0.0, cos_zenith);
    vec3 origin = vec3(0.0, 0.0, mix(SKY_EARTH_KM, SKY_EARTH_KM + SKY_SHELL_KM, altitude));
    float dt = sky_sphere_distance(origin, dir, SKY_EARTH_KM + SKY_SHELL_KM) / float(SKY_LUT_STEPS);
    vec4 depth = vec4(0.0);
    for (int i = 0; i < SKY_LUT_STEPS; i++) {
        vec3 x = origin + dir * ((float(i) + 0.5) * dt);
        vec4 extinction, molecular, aerosol;
        sky_ms_coefficients(max(length(x) - SKY_EARTH_KM, 0.0), density, extinction, molecular, aerosol);
        depth += extinction * dt;
    }
    return exp(-depth);
}

#endif
