// SPDX-License-Identifier: GPL-3.0-or-later
// One coarser level of the lit cube map (include/cube_radiance.glsl): each texel the box
// average of its 2 x 2 finer ones, radiance premultiplied by coverage (rgb) and the coverage
// (a). Level 0 holds plain radiance and the distance (a > 0: covered), so the first level
// reads it as coverage 1 or 0. Faces are power-of-two squares: no texel straddles two faces,
// and a rough reflection's read never blends one face's light into another's.
//
// Images: u_finer (read), u_coarser (write), both rgba16f. Uniforms: u_size, this level's
// size in texels; u_from_base, 1 when u_finer is level 0.
layout(local_size_x = 8, local_size_y = 8) in;

layout(rgba16f) readonly uniform image2D u_finer;
layout(rgba16f) writeonly uniform image2D u_coarser;

uniform ivec2 u_size;
uniform int u_from_base;

vec4 premultiplied(ivec2 at) {
    vec4 v = imageLoad(u_finer, at);
    return u_from_base != 0 ? vec4(v.rgb, v.a > 0.0 ? 1.0 : 0.0) : v;
}

void main() {
    ivec2 cell = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(cell, u_size))) return;
    ivec2 child = cell * 2;
    vec4 sum = premultiplied(child) + premultiplied(child + ivec2(1, 0))
             + premultiplied(child + ivec2(0, 1)) + premultiplied(child + ivec2(1, 1));
    imageStore(u_coarser, cell, 0.25 * sum);
}
