// SPDX-License-Identifier: GPL-3.0-or-later
// Sky Texture's models (Blender 5.0 ``sky_type``: 0 SINGLE_SCATTERING, 1 MULTIPLE_SCATTERING,
// 2 PREETHAM, 3 HOSEK_WILKIE), evaluated per direction where the World is baked
// (lighting/world_bake.comp.glsl), never per frame. Hosek-Wilkie's parameters for the node's
// sun come with the node's words (hybrid_engine/scene/sky_hosek.py computes them from the
// published dataset).
//
// The two scattering models integrate the light the atmosphere scatters towards the viewer,
// as Blender does into its 512 x 256 image; here the direction is evaluated at once (the
// bake is the image). Their sun disc is not drawn here: its light is a sun lamp
// (hybrid_engine/scene/sky_sun.py), which a few texels of a bake could not integrate.
// The sun stands at elevation e and rotation r as Cycles places it: towards
// (cos e sin r, cos e cos r, sin e).
//
// Preetham, Shirley and Smits, "A Practical Analytic Model for Daylight" (SIGGRAPH 1999):
// the luminance Y and chromaticity x, y of a direction at angle theta from the zenith and
// gamma from the sun are each the zenith's value times the Perez distribution
//     F(theta, gamma) = (1 + A exp(B / cos theta)) (1 + C exp(D gamma) + E cos^2 gamma)
// over F(0, theta_sun), with A..E linear in the turbidity T (the paper's appendix) and the
// zenith values fitted to T and theta_sun. Directions below the horizon take the horizon's
// value (theta is clamped just above it), and Y (kcd/m^2 in the paper) is scaled by
// NODE_SKY_PREETHAM_SCALE into Blender's radiance units. xyY goes to XYZ and then to linear
// Rec.709, the scene's working space.
#ifndef HYBRID_NODE_TEX_SKY_GLSL
#define HYBRID_NODE_TEX_SKY_GLSL

#define NODE_SKY_PREETHAM_SCALE 0.06

vec3 node_sky_xyz_to_rgb(vec3 xyz);

#ifdef NODE_SKY_SCATTERING
// Compiled in only for a World with a scattering Sky Texture (world_bake.py defines it):
// their spectral loops would cost every other World's bake registers and compile time.
#include "include/nodes/sky_atmosphere.glsl"

// The Multiple Scattering models' transmittance tables, one block of SKY_LUT_H rows per node
// (lighting/sky_transmittance.comp.glsl; world_bake.py binds it).
uniform sampler2D u_sky_transmittance;
#endif

vec3 node_sky_xyz_to_rgb(vec3 xyz) {
    return max(vec3(dot(vec3(3.2404542, -1.5371385, -0.4985314), xyz),
                    dot(vec3(-0.9692660, 1.8760108, 0.0415560), xyz),
                    dot(vec3(0.0556434, -0.2040259, 1.0572252), xyz)), vec3(0.0));
}

#ifdef NODE_SKY_SCATTERING
#include "include/nodes/sky_single.glsl"
#endif

// Where the sun stands (elevation, rotation as the node gives them; see the header).
vec3 node_sky_sun(float elevation, float rotation) {
    return vec3(cos(elevation) * sin(rotation), cos(elevation) * cos(rotation), sin(elevation));
}

float node_sky_perez(float a, float b, float c, float d, float e, float theta, float gamma) {
    float cg = cos(gamma);
    return (1.0 + a * exp(b / cos(theta))) * (1.0 + c * exp(d * gamma) + e * cg * cg);
}

vec3 node_sky_preetham(vec3 dir, vec3 sun, float turbidity) {
    float t = turbidity;
    vec3 s = dot(sun, sun) > 0.0 ? normalize(sun) : vec3(0.0, 0.0, 1.0);
    vec3 d = dot(dir, dir) > 0.0 ? normalize(dir) : vec3(0.0, 0.0, 1.0);
    float theta_s = acos(clamp(s.z, -1.0, 1.0));
    float theta = min(acos(clamp(d.z, -1.0, 1.0)), 1.5707963 - 0.001);
    float gamma = acos(clamp(dot(d, s), -1.0, 1.0));

    // Zenith luminance and chromaticity (paper, appendix A.2).
    float chi = (4.0 / 9.0 - t / 120.0) * (3.14159265 - 2.0 * theta_s);
    float yz = ((4.0453 * t - 4.9710) * tan(chi) - 0.2155 * t + 2.4192) * NODE_SKY_PREETHAM_SCALE;
    vec4 th = vec4(theta_s * theta_s * theta_s, theta_s * theta_s, theta_s, 1.0);
    vec3 tt = vec3(t * t, t, 1.0);
    float xz = dot(tt, vec3(dot(th, vec4(0.00166, -0.00375, 0.00209, 0.0)),
                            dot(th, vec4(-0.02903, 0.06377, -0.03202, 0.00394)),
                            dot(th, vec4(0.11693, -0.21196, 0.06052, 0.25886))));
    float yzc = dot(tt, vec3(dot(th, vec4(0.00275, -0.00610, 0.00317, 0.0)),
                             dot(th, vec4(-0.04214, 0.08970, -0.04153, 0.00516)),
                             dot(th, vec4(0.15346, -0.26756, 0.06670, 0.26688))));

    // Perez coefficients (appendix A.2), each row A..E for Y, x, y.
    float ya = 0.1787 * t - 1.4630, yb = -0.3554 * t + 0.4275, yc = -0.0227 * t + 5.3251,
          yd = 0.1206 * t - 2.5771, ye = -0.0670 * t + 0.3703;
    float xa = -0.0193 * t - 0.2592, xb = -0.0665 * t + 0.0008, xc = -0.0004 * t + 0.2125,
          xd = -0.0641 * t - 0.8989, xe = -0.0033 * t + 0.0452;
    float ca = -0.0167 * t - 0.2608, cb = -0.0950 * t + 0.0092, cc = -0.0079 * t + 0.2102,
          cd = -0.0441 * t - 1.6537, ce = -0.0109 * t + 0.0529;

    float big_y = yz * node_sky_perez(ya, yb, yc, yd, ye, theta, gamma) / node_sky_perez(ya, yb, yc, yd, ye, 0.0, theta_s);
    float x = xz * node_sky_perez(xa, xb, xc, xd, xe, theta, gamma) / node_sky_perez(xa, xb, xc, xd, xe, 0.0, theta_s);
    float y = yzc * node_sky_perez(ca, cb, cc, cd, ce, theta, gamma) / node_sky_perez(ca, cb, cc, cd, ce, 0.0, theta_s);

    vec3 xyz = y > 0.0 ? vec3(x * big_y / y, big_y, (1.0 - x - y) * big_y / y) : vec3(0.0);
    return node_sky_xyz_to_rgb(xyz);
}

#ifdef NODE_SKY_SCATTERING
// Transmittance from the table block at row ``row``, bilinear between exact corners: texel
// x of the block holds cos = 2 x / (W - 1) - 1, so the filtered read at texel centre
// coordinates is the model's own interpolation, clamped to the block's edges.
vec4 node_sky_ms_table(int row, float cos_zenith, float altitude) {
    vec2 texel = vec2(float(SKY_LUT_W - 1) * clamp(cos_zenith * 0.5 + 0.5, 0.0, 1.0),
                      float(row) + float(SKY_LUT_H - 1) * clamp(altitude, 0.0, 1.0));
    return textureLod(u_sky_transmittance, (texel + 0.5) / vec2(textureSize(u_sky_transmittance, 0)), 0.0);
}

// Light that reaches a point at zenith cosine ``cos_sun`` of the sun by more than one
// scattering: the ground's reflection (albedo 0.3, lit through the atmosphere, seen over
// the solid angle the planet fills) and the model's fit of the atmosphere's own.
// ``ground_up``: the transmittance straight up from the ground (the same at every step).
vec4 node_sky_ms_secondary(int row, float cos_sun, float altitude, float radius, vec4 ground_up) {
    float planet = 6.2831853 * (1.0 - sqrt(max(1.0 - (SKY_EARTH_KM / radius) * (SKY_EARTH_KM / radius), 0.0)));
    vec4 up_to_sample = ground_up / node_sky_ms_table(row, 1.0, altitude);
    vec4 ground = (0.25 / 3.14159265) * planet * (0.3 / 3.14159265) * node_sky_ms_table(row, cos_sun, 0.0)
                  * up_to_sample * cos_sun;
    vec4 atmosphere = 0.02 * vec4(0.217, 0.347, 0.594, 1.0) / (1.0 + 5.0 * exp(-17.92 * cos_sun));
    return atmosphere + ground;
}

// Multiple Scattering: in-scattering along the view ray from ``altitude_m`` up to the shell
// or the ground, 64 segments, each integrated analytically over its own extinction
// (Hillaire, "Physically Based Sky, Atmosphere and Cloud Rendering in Frostbite", 2016).
vec3 node_sky_multiple_scattering(vec3 dir, vec3 sun, float altitude_m, vec3 density, int row) {
    vec3 origin = vec3(0.0, 0.0, SKY_EARTH_KM + clamp(altitude_m, 1.0, 99999.0) / 1000.0);
    float to_shell = sky_sphere_distance(origin, dir, SKY_EARTH_KM + SKY_SHELL_KM);
    float to_ground = sky_sphere_distance(origin, dir, SKY_EARTH_KM);
    float dt = (to_ground < 0.0 ? to_shell : to_ground) / 64.0;
    float mu = dot(dir, sun);
    float molecular_phase = 3.0 / (16.0 * 3.14159265) * (1.0 + mu * mu);
    float hg = 1.0 + 0.64 - 1.6 * mu;  // Henyey-Greenstein, g = 0.8, forward towards the sun
    float aerosol_phase = 0.25 / 3.14159265 * (1.0 - 0.64) / (hg * sqrt(hg));
    vec4 radiance = vec4(0.0);
    vec4 throughput = vec4(1.0);
    vec4 ground_up = node_sky_ms_table(row, 1.0, 0.0);
    for (int i = 0; i < 64; i++) {
        vec3 x = origin + dir * ((float(i) + 0.5) * dt);
        float radius = length(x);
        float h = max(radius - SKY_EARTH_KM, 0.0);
        float cos_sun = dot(x / radius, sun);
        vec4 extinction, molecular, aerosol;
        sky_ms_coefficients(h, density, extinction, molecular, aerosol);
        vec4 to_sun = node_sky_ms_table(row, cos_sun, h / SKY_SHELL_KM);
        vec4 secondary = node_sky_ms_secondary(row, cos_sun, h / SKY_SHELL_KM, radius, ground_up);
        vec4 source = SKY_SUN_IRRADIANCE * (molecular * (molecular_phase * to_sun + secondary)
                                            + aerosol * (aerosol_phase * to_sun + secondary));
        vec4 step_t = exp(-dt * extinction);
        radiance += throughput * (source - source * step_t) / max(extinction, vec4(1e-7));
        throughput *= step_t;
    }
    return node_sky_xyz_to_rgb(SKY_SPECTRAL_TO_XYZ * radiance);
}
#endif

#ifdef NODE_SKY_HOSEK
// Compiled in only for a World with a Hosek-Wilkie node (world_bake.py defines it).
// Hosek-Wilkie (sky_hosek.py), the three XYZ channels at once: p[0..8] the parameters A..I
// (the dataset's order: A, B, C, D, E, F, G, I, H) of X, Y and Z, p[9] their L_M. gamma is
// measured from the sun; theta is clamped just above the horizon, as Cycles does.
vec3 node_sky_hosek(vec3 dir, vec3 sun, vec3 p[10]) {
    vec3 s = dot(sun, sun) > 0.0 ? normalize(sun) : vec3(0.0, 0.0, 1.0);
    vec3 d = dot(dir, dir) > 0.0 ? normalize(dir) : vec3(0.0, 0.0, 1.0);
    float gamma = acos(clamp(dot(d, s), -1.0, 1.0));
    float cos_theta = cos(min(acos(clamp(d.z, -1.0, 1.0)), 1.5707963 - 0.001));
    float cos_gamma = cos(gamma);
    vec3 mie = (1.0 + cos_gamma * cos_gamma) / pow(1.0 + p[8] * p[8] - 2.0 * p[8] * cos_gamma, vec3(1.5));
    vec3 xyz = (1.0 + p[0] * exp(p[1] / (cos_theta + 0.01)))
               * (p[2] + p[3] * exp(p[4] * gamma) + p[5] * cos_gamma * cos_gamma + p[6] * mie + p[7] * sqrt(cos_theta))
               * p[9];
    return node_sky_xyz_to_rgb(xyz) * (6.2831853 / 683.0);  // Cycles' scale into radiance
}
#endif

// ``legacy_sun`` and ``turbidity`` drive Preetham; ``sun_at`` (elevation, rotation, altitude
// in metres), ``density`` (air, aerosol, ozone) and the table ``row`` the scattering models.
// (Hosek-Wilkie is node_sky_hosek, called with its parameters by the interpreter.)
vec3 node_tex_sky(int model, vec3 dir, vec3 legacy_sun, float turbidity, vec3 sun_at, vec3 density, int row) {
    if (model == 2) return node_sky_preetham(dir, legacy_sun, turbidity);
#ifdef NODE_SKY_SCATTERING
    if (model != 0 && model != 1) return vec3(0.0);
    vec3 d = dot(dir, dir) > 0.0 ? normalize(dir) : vec3(0.0, 0.0, 1.0);
    vec3 sun = node_sky_sun(sun_at.x, sun_at.y);
    if (model == 1) return node_sky_multiple_scattering(d, sun, sun_at.z, density, row);
    return node_sky_single_scattering(d, sun, sun_at.z, density);
#else
    return vec3(0.0);
#endif
}

#endif
