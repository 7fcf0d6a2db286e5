// SPDX-License-Identifier: GPL-3.0-or-later
// Blender's Single Scattering sky (its "Nishita" model: Nishita et al., "Display of the Earth
// Taking into Account Atmospheric Scattering", SIGGRAPH 1993): sunlight scattered once
// towards the viewer by air (Rayleigh) and aerosols (Mie, Cornette-Shanks phase, g = 0.76),
// attenuated on the way in and out by both and by ozone. Spectral: 21 wavelengths from 380
// to 780 nm, summed against the CIE 1931 2-degree colour matching functions into XYZ.
// Earth radius 6360 km, atmosphere to 6420 km; densities fall exponentially (8 km air,
// 1.2 km aerosol scale heights), ozone is a tent from 10 to 40 km peaking at 25 km. The
// artist's Air, Aerosol and Ozone multiply the three densities.
// The view ray is cut into 32 segments; the optical depth from each towards the sun uses an
// 8-point Gauss-Laguerre rule (the density along such a ray decays roughly exponentially):
// nodes x_i / 25 and weights w_i e^{x_i} / 25 of the 8-point rule, so the last node still
// lies inside the atmosphere.
// Below the horizon the sky fades to black as Cycles fades it: the horizon's colour times
// (1 + 2.5 z)^3, black under z = -0.4.
#ifndef HYBRID_SKY_SINGLE_GLSL
#define HYBRID_SKY_SINGLE_GLSL

#define SKY1_EARTH 6360e3
#define SKY1_TOP 6420e3
#define SKY1_MIE 2e-5
#define SKY1_G 0.76

// Solar irradiance at the top of the atmosphere (W m^-2 nm^-1), Rayleigh scattering and
// ozone absorption (m^-1) at 380, 400, ..., 780 nm.
const float SKY1_IRRADIANCE[21] = float[21](
    1.45756829855592995315, 1.56596305559738380175, 1.65148449067670455293, 1.71496242737209314555,
    1.75797983805020541226, 1.78256407885924539336, 1.79095108475838560302, 1.78541550133410664714,
    1.76815554864306845317, 1.74122069647250410362, 1.70647127164943679389, 1.66556087452739887134,
    1.61993437242451854274, 1.57083597368892080581, 1.51932335059305478886, 1.46628494965214395407,
    1.41245852740172450623, 1.35844961970384092709, 1.30474913844739281998, 1.25174963272610817455,
    1.19975998755420620867);
const float SKY1_RAYLEIGH[21] = float[21](
    5.424820087636473e-5, 4.418549866505454e-5, 3.635151910165377e-5, 3.017929012024763e-5,
    2.526320226989157e-5, 2.130859310621843e-5, 1.809838025320633e-5, 1.547057129129042e-5,
    1.330284977336850e-5, 1.150184784075764e-5, 9.99557429990163e-6, 8.72799973630707e-6,
    7.65513700977967e-6, 6.74217203751443e-6, 5.96134125832052e-6, 5.29034598065810e-6,
    4.71115687557433e-6, 4.20910481110487e-6, 3.77218381260133e-6, 3.39051255477280e-6,
    3.05591531679811e-6);
const float SKY1_OZONE[21] = float[21](
    3.25126849861e-9, 5.85395365047e-9, 1.977191155085e-8, 7.309568762914e-8, 2.0084561514287e-7,
    4.0383958096161e-7, 6.3551335912363e-7, 9.6707041180970e-7, 1.54797400424410e-6, 2.09038647223331e-6,
    2.46128056164565e-6, 2.73551299461512e-6, 2.15125863128643e-6, 1.59051840791988e-6, 1.12356197979857e-6,
    7.3527551487574e-7, 4.6450130357806e-7, 3.3096079921048e-7, 2.2512612292678e-7, 1.4879129266490e-7,
    1.6828623364192e-7);
// CIE 1931 2-degree colour matching functions x, y, z at the same wavelengths.
const vec3 SKY1_CMF[21] = vec3[21](
    vec3(0.00136800000, 0.00003900000, 0.00645000100), vec3(0.01431000000, 0.00039600000, 0.06785001000),
    vec3(0.13438000000, 0.00400000000, 0.64560000000), vec3(0.34828000000, 0.02300000000, 1.74706000000),
    vec3(0.29080000000, 0.06000000000, 1.66920000000), vec3(0.09564000000, 0.13902000000, 0.81295010000),
    vec3(0.00490000000, 0.32300000000, 0.27200000000), vec3(0.06327000000, 0.71000000000, 0.07824999000),
    vec3(0.29040000000, 0.95400000000, 0.02030000000), vec3(0.59450000000, 0.99500000000, 0.00390000000),
    vec3(0.91630000000, 0.87000000000, 0.00165000100), vec3(1.06220000000, 0.63100000000, 0.00080000000),
    vec3(0.85444990000, 0.38100000000, 0.00019000000), vec3(0.44790000000, 0.17500000000, 0.00002000000),
    vec3(0.16490000000, 0.06100000000, 0.00000000000), vec3(0.04677000000, 0.01700000000, 0.00000000000),
    vec3(0.01135916000, 0.00410200000, 0.00000000000), vec3(0.00289932700, 0.00104700000, 0.00000000000),
    vec3(0.00069007860, 0.00024920000, 0.00000000000), vec3(0.00016615050, 0.00006000000, 0.00000000000),
    vec3(0.00004150994, 0.00001499000, 0.00000000000));
const float SKY1_NODES[8] = float[8](0.0068111853, 0.0361480711, 0.0900434652, 0.1706680068,
                                     0.2818362161, 0.4303406404, 0.6296271457, 0.9145252695);
const float SKY1_WEIGHTS[8] = float[8](0.0175089364, 0.0413547739, 0.0667883906, 0.0950769881,
                                       0.1283416365, 0.1707430204, 0.2327233347, 0.3562490486);

// Air, aerosol and ozone densities (relative to sea level) at height h metres.
vec3 sky1_density(float h) {
    return vec3(exp(-h / 8e3), exp(-h / 1.2e3), max(0.0, 1.0 - abs(h - 25000.0) / 15000.0));
}

// Distance from ``p`` (inside the atmosphere) along ``dir`` to its top.
float sky1_to_top(vec3 p, vec3 dir) {
    float b = dot(dir, p);
    float c = dot(p, p) - SKY1_TOP * SKY1_TOP;
    return -b + sqrt(max(b * b - c, 0.0));
}

// Optical depth factors (air, aerosol, ozone) from ``p`` along ``dir`` to the top.
vec3 sky1_optical_depth(vec3 p, vec3 dir) {
    float length_m = sky1_to_top(p, dir);
    vec3 depth = vec3(0.0);
    for (int i = 0; i < 8; i++) {
        depth += sky1_density(length(p + SKY1_NODES[i] * length_m * dir) - SKY1_EARTH) * SKY1_WEIGHTS[i];
    }
    return depth * length_m;
}

// XYZ radiance towards ``dir`` (above the horizon) from ``altitude`` metres.
vec3 sky1_scattered(vec3 dir, vec3 sun, float altitude, vec3 scale) {
    vec3 origin = vec3(0.0, 0.0, SKY1_EARTH + altitude);
    float segment = sky1_to_top(origin, dir) / 32.0;
    float mu = dot(dir, sun);
    float rayleigh_phase = 0.1875 / 3.14159265 * (1.0 + mu * mu);
    float mie_phase = 3.0 * (1.0 - SKY1_G * SKY1_G) * (1.0 + mu * mu)
                      / (8.0 * 3.14159265 * (2.0 + SKY1_G * SKY1_G) * pow(1.0 + SKY1_G * SKY1_G - 2.0 * SKY1_G * mu, 1.5));
    float spectrum[21];
    for (int w = 0; w < 21; w++) spectrum[w] = 0.0;
    vec3 depth = vec3(0.0);
    for (int i = 0; i < 32; i++) {
        vec3 p = origin + (float(i) + 0.5) * segment * dir;
        vec3 density = scale * sky1_density(length(p) - SKY1_EARTH);
        depth += segment * density;
        // The Earth shadows points whose way to the sun crosses it.
        float b = dot(sun, p);
        bool shadowed = sun.z < 0.0 && b * b - (dot(p, p) - SKY1_EARTH * SKY1_EARTH) >= 0.0;
        if (shadowed) continue;
        vec3 total = depth + scale * sky1_optical_depth(p, sun);
        for (int w = 0; w < 21; w++) {
            float attenuation = exp(-(total.x * SKY1_RAYLEIGH[w] + total.y * 1.11 * SKY1_MIE + total.z * SKY1_OZONE[w]));
            spectrum[w] += attenuation * (rayleigh_phase * density.x * SKY1_RAYLEIGH[w] + mie_phase * density.y * SKY1_MIE)
                           * SKY1_IRRADIANCE[w] * segment;
        }
    }
    vec3 xyz = vec3(0.0);
    for (int w = 0; w < 21; w++) xyz += SKY1_CMF[w] * spectrum[w];
    return xyz * 20.0;  // the wavelengths' spacing, nm
}

// ``altitude_m`` in metres, ``density`` the artist's (air, aerosol, ozone) multipliers.
vec3 node_sky_single_scattering(vec3 dir, vec3 sun, float altitude_m, vec3 density) {
    float altitude = clamp(altitude_m, 1.0, 59999.0);
    if (dir.z < -0.4) return vec3(0.0);
    if (dir.z >= 0.0) {
        return node_sky_xyz_to_rgb(sky1_scattered(dir, sun, altitude, density));
    }
    // The horizon's colour (Cycles reads its image's row just above it), faded.
    float horizon = 4.02e-4;
    vec3 flat_dir = vec3(normalize(dir.xy) * cos(horizon), sin(horizon));
    return node_sky_xyz_to_rgb(sky1_scattered(flat_dir, sun, altitude, density)) * pow(1.0 + dir.z * 2.5, 3.0);
}

#endif
