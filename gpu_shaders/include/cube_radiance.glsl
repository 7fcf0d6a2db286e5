// SPDX-License-Identifier: GPL-3.0-or-later
// The lit cube map (hybrid_engine/passes/cube_light/): the diffuse, view-independent light of
// every texel of the G-buffer cube map (paper §3.2), shaded once per frame, and its mip chain
// per face. This file reads it: where a world point falls in the map, and the light stored
// there at a level.
//
// Layout. The radiance atlas has the cube map's layout with faces padded to a power of two
// (u_cube_radiance_res, as the hit-interval pyramid's): face f, row r (1: the back layer,
// cube_map.py) of level L covers texels [f P_L, (f + 1) P_L) x [r P_L, (r + 1) P_L), P_L =
// u_cube_radiance_res >> L, the map's texel (x, y) of the face at (x >> L, y >> L). Level 0
// holds rgb = radiance, a = the texel's distance from the map's centre (0: nothing stored);
// level L > 0 the box average of rgb and of the coverage (a texel of level 0 covers when its
// a > 0): rgb is premultiplied by coverage there, and a read divides by it, so that a
// blurred surface is not darkened by the empty texels (sky) around it.
//
// Needs cube_march.glsl (its uniforms: u_face_view_proj, u_cube_res, u_cube_depth, the near
// and far planes), included first: the shader loader includes a file once per program, where
// it first appears, even inside a disabled #if. Uniforms: u_cube_radiance (RGBA16F, mipmapped), u_cube_radiance_res,
// u_cube_radiance_levels.
#ifndef HYBRID_CUBE_RADIANCE_GLSL
#define HYBRID_CUBE_RADIANCE_GLSL

uniform sampler2D u_cube_radiance;
uniform int u_cube_radiance_res;
uniform int u_cube_radiance_levels;

// The angle one texel of the map subtends at a face's centre (radians).
float cube_texel_angle() {
    return 2.0 * CUBE_TAN_HALF_FOV / float(u_cube_res);
}

// Where point p, seen from a map centred at `center`, falls: its face (the major axis of
// p - center; the 90.2-degree faces contain it) and its texel within the face, and the depth
// along the face's axis. The face matrices are the current map's; a map of another centre
// (the previous frame's) has the same matrices up to its translation, so p is moved by the
// difference of the centres.
void cube_locate(vec3 p, vec3 center, out int face, out ivec2 local, out float axial) {
    local = ivec2(0);
    vec3 d = p - center;
    vec3 a = abs(d);
    face = a.x >= a.y && a.x >= a.z ? (d.x >= 0.0 ? 0 : 1) : a.y >= a.z ? (d.y >= 0.0 ? 2 : 3) : (d.z >= 0.0 ? 4 : 5);
    vec4 clip = u_face_view_proj[face] * vec4(d + u_cube_center, 1.0);
    vec2 ndc = clip.xy / max(clip.w, 1e-30);
    local = clamp(ivec2(floor((ndc * 0.5 + 0.5) * float(u_cube_res))), ivec2(0), ivec2(u_cube_res - 1));
    axial = clip.w;
}

// The row (0 front, 1 back layer) of the current map that holds a surface at axial depth
// `axial` on face texel `local`: the back layer where it holds a surface nearer that depth
// than the front one (CUBE_BACK_LAYER; always 0 without).
int cube_layer_of(int face, ivec2 local, float axial) {
#if CUBE_BACK_LAYER
    ivec2 front = ivec2(face * u_cube_res, 0) + local;
    ivec2 back = front + ivec2(0, u_cube_res);
    if (texelFetch(u_cube_normal_material, back, 0).w == 0.0) return 0;
    float s_front = cube_linear_depth(texelFetch(u_cube_depth, front, 0).r * 2.0 - 1.0);
    float s_back = cube_linear_depth(texelFetch(u_cube_depth, back, 0).r * 2.0 - 1.0);
    return axial > 0.5 * (s_front + s_back) ? 1 : 0;
#else
    return 0;
#endif
}

// Radiance premultiplied by coverage (rgb) and the coverage (a) of one texel of `level`.
vec4 cube_radiance_texel(sampler2D atlas, int face, int row, ivec2 cell, int level) {
    int size = u_cube_radiance_res >> level;
    vec4 v = texelFetch(atlas, ivec2(face, row) * size + clamp(cell, ivec2(0), ivec2(size - 1)), level);
    return level == 0 ? vec4(v.rgb, v.a > 0.0 ? 1.0 : 0.0) : v;
}

// Bilinear within the face at `level` around the level-0 texel `local` (premultiplied, as
// cube_radiance_texel); level 0 is the texel itself.
vec4 cube_radiance_bilinear(sampler2D atlas, int face, int row, ivec2 local, int level) {
    if (level == 0) return cube_radiance_texel(atlas, face, row, local, 0);
    vec2 at = (vec2(local) + 0.5) / float(1 << level) - 0.5;
    ivec2 c = ivec2(floor(at));
    vec2 f = at - vec2(c);
    vec4 v00 = cube_radiance_texel(atlas, face, row, c, level);
    vec4 v10 = cube_radiance_texel(atlas, face, row, c + ivec2(1, 0), level);
    vec4 v01 = cube_radiance_texel(atlas, face, row, c + ivec2(0, 1), level);
    vec4 v11 = cube_radiance_texel(atlas, face, row, c + ivec2(1, 1), level);
    return mix(mix(v00, v10, f.x), mix(v01, v11, f.x), f.y);
}

// The stored radiance around level-0 texel `local` of (face, row) at fractional `level`
// (linear between the two levels around it): the average over the surfaces there.
vec3 cube_radiance_at_level(int face, int row, ivec2 local, float level) {
    float l = clamp(level, 0.0, float(u_cube_radiance_levels - 1));
    int lo = int(l);
    vec4 v = cube_radiance_bilinear(u_cube_radiance, face, row, local, lo);
    if (l > float(lo)) v = mix(v, cube_radiance_bilinear(u_cube_radiance, face, row, local, lo + 1), l - float(lo));
    return v.a > 1e-6 ? v.rgb / v.a : vec3(0.0);
}

// The mip level whose texels span a cone of `cone` radians seen from the map's centre.
float cube_radiance_level(float cone) {
    return log2(max(cone / cube_texel_angle(), 1.0));
}

#endif
