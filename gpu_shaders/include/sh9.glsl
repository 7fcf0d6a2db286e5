// SPDX-License-Identifier: GPL-3.0-or-later
// Spherical harmonics of bands 0..2, shared by the code that projects the sky onto them and the
// code that evaluates its irradiance (world_light.glsl).
// The real SH basis of band 0..2 at unit direction d (the coefficients' order).
void sh9_basis(vec3 d, out float y[9]) {
    y[0] = 0.282095;
    y[1] = 0.488603 * d.y;
    y[2] = 0.488603 * d.z;
    y[3] = 0.488603 * d.x;
    y[4] = 1.092548 * d.x * d.y;
    y[5] = 1.092548 * d.y * d.z;
    y[6] = 0.315392 * (3.0 * d.z * d.z - 1.0);
    y[7] = 1.092548 * d.x * d.z;
    y[8] = 0.546274 * (d.x * d.x - d.y * d.y);
}

