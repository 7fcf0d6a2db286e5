// SPDX-License-Identifier: GPL-3.0-or-later
// Cycles' Vector pass, fragment stage: the raster positions of the surface point at the
// frame before, this frame and the frame after (pixels, y up as the render result stores
// rows), written as Cycles' kernel writes them: xy = previous - this, zw = this - next.
// Location 1 marks the texel as hit (the background stays 0): the film averages the
// vectors over the samples that hit, as Cycles divides by its motion weight.
// ALPHA_TEST defined (scenes with alpha): a fragment of a material with alpha is kept with
// the G-buffer's test and numbers (pixel, sample, depth; include/alpha.glsl), so the pixel
// moves with the surface the sample sees, not with a leaf card's hole in front of it.
// With NODE_CLOSURE_ALPHA a material's alpha program gives its coverage (alpha.glsl), seen
// from the camera along the triangle's plane normal.
#ifdef ALPHA_TEST
#ifdef NODE_CLOSURE_ALPHA
#include "scene_layout.glsl"
#include "textures.glsl"
#include "node_program.glsl"
in vec3 v_world;
flat in int v_row;
uniform vec3 u_camera_position;
uniform vec3 u_camera_forward;
uniform int u_orthographic;
#endif
#include "alpha.glsl"
layout(std430) readonly buffer MaterialBuffer { Material materials[]; };
uniform int u_alpha_sample;
in vec2 v_uv;
flat in int v_material;
#endif
in vec4 v_center;
in vec4 v_previous;
in vec4 v_next;

uniform ivec2 u_size;

layout(location = 0) out vec4 out_vector;
layout(location = 1) out float out_hit;

vec2 raster(vec4 clip) {
    return (clip.xy / clip.w * 0.5 + 0.5) * vec2(u_size);
}

void main() {
#ifdef ALPHA_TEST
    vec2 duv_dx = dFdx(v_uv);  // outside any branch (undefined in non-uniform control flow)
    vec2 duv_dy = dFdy(v_uv);
    Material m = materials[v_material];
#ifdef NODE_CLOSURE_ALPHA
    vec3 plane = cross(dFdx(v_world), dFdy(v_world));
#endif
    if (material_has_alpha(m)) {
#ifdef NODE_CLOSURE_ALPHA
        vec3 seen_from = u_orthographic != 0 ? -normalize(u_camera_forward) : normalize(u_camera_position - v_world);
        float alpha = material_fragment_alpha(m, v_uv, duv_dx, duv_dy, v_world, plane, seen_from, v_row, v_material, 0);
#else
        float alpha = material_alpha_grad(m, v_uv, duv_dx, duv_dy);
#endif
        if (!alpha_kept(alpha, uvec4(uvec2(gl_FragCoord.xy), uint(u_alpha_sample), floatBitsToUint(gl_FragCoord.z)))) {
            discard;
        }
    }
#endif
    vec2 center = raster(v_center);
    out_vector = vec4(raster(v_previous) - center, center - raster(v_next));
    out_hit = 1.0;
}
