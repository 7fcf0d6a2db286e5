// SPDX-License-Identifier: GPL-3.0-or-later
// Sky Texture's models (Blender 5.0 ``sky_type``: 0 SINGLE_SCATTERING, 1 MULTIPLE_SCATTERING,
// 2 PREETHAM, 3 HOSEK_WILKIE). Evaluated here: Preetham. The scattering models integrate
// an atmosphere (tables of optical depth per altitude) and Hosek-Wilkie fits a dataset of
// coefficients: neither is evaluated yet, they read black (the adapter names them).
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
    vec3 rgb = vec3(dot(vec3(3.2404542, -1.5371385, -0.4985314), xyz),
                    dot(vec3(-0.9692660, 1.8760108, 0.0415560), xyz),
                    dot(vec3(0.0556434, -0.2040259, 1.0572252), xyz));
    return max(rgb, vec3(0.0));
}

vec3 node_tex_sky(int model, vec3 dir, vec3 sun, float turbidity) {
    if (model == 2) return node_sky_preetham(dir, sun, turbidity);
    return vec3(0.0);
}

#endif
