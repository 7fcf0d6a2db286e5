// SPDX-License-Identifier: GPL-3.0-or-later
// Screen-space ambient occlusion of the primary G-buffer: the share of the sky each pixel's
// surface sees, for the World's light (include/world_light.glsl). Cosine-distributed points
// within u_ao_distance above the surface are projected into the depth buffer; a point
// hidden behind a stored surface that rises above p's tangent plane within reach of p is
// occluded. Each pixel takes AO_POINTS points, rotated per pixel and per sample (u_sample):
// the shading pass averages neighbouring pixels of the same surface, and accumulated
// samples average the rest.
//
// Bindings: u_depth (DEPTH32F), u_normal_material (RGBA32F) read; image u_visibility
// (RGBA32F, the G-buffer's ambient target: alpha = visibility) written.
#include "scene_layout.glsl"
#include "random.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f) writeonly uniform image2D u_visibility;

uniform sampler2D u_depth;
uniform sampler2D u_normal_material;
uniform mat4 u_inv_view_proj;
uniform mat4 u_view_proj;
uniform vec3 u_camera_position;
uniform vec3 u_camera_forward;
uniform int u_orthographic;
uniform ivec2 u_size;
uniform float u_ao_distance;
uniform int u_sample;

vec3 unproject(vec2 ndc_xy, float ndc_z) {
    vec4 world = u_inv_view_proj * vec4(ndc_xy, ndc_z, 1.0);
    return world.xyz / world.w;
}

#define AO_POINTS 4

// The share of the sky that p (unit normal n facing the viewer) sees, from the depth buffer.
float screen_space_sky_visibility(vec3 p, vec3 n) {
    vec3 t, b;
    basis_around(n, t, b);
    uvec3 at = position_key(p);
    vec2 shift = random2(uvec4(at.x, at.y ^ pcg_hash(at.z), uint(u_sample), 0x41u));
    float camera_dist = u_orthographic != 0 ? 0.0 : distance(p, u_camera_position);
    float occluded = 0.0;
    for (int i = 0; i < AO_POINTS; ++i) {
        // A rotated Fibonacci spiral: cosine-distributed directions, lengths spread over the reach.
        vec2 xi = fract(vec2((float(i) + 0.5) / float(AO_POINTS), float(i) * 0.618034) + shift);
        float r = sqrt(xi.x);
        float phi = 2.0 * PI * xi.y;
        vec3 dir = r * cos(phi) * t + r * sin(phi) * b + sqrt(max(0.0, 1.0 - xi.x)) * n;
        float reach = u_ao_distance * mix(0.15, 1.0, fract(float(i) * 0.38197 + shift.x));
        // Lifted off the surface a little, so that points along the plane never sink into it.
        vec3 q = p + (dir + 0.05 * n) * reach;
        vec4 clip = u_view_proj * vec4(q, 1.0);
        if (clip.w <= 0.0) continue;
        vec3 ndc = clip.xyz / clip.w;
        if (any(greaterThan(abs(ndc.xy), vec2(1.0)))) continue;
        ivec2 texel = clamp(ivec2((ndc.xy * 0.5 + 0.5) * vec2(u_size)), ivec2(0), u_size - 1);
        float stored = texelFetch(u_depth, texel, 0).r;
        if (stored >= ndc.z * 0.5 + 0.5) continue;
        vec3 s = unproject((vec2(texel) + 0.5) / vec2(u_size) * 2.0 - 1.0, stored * 2.0 - 1.0);  // the stored point
        // In front of the point, above p's tangent plane (a texel of the plane p lies on,
        // whose depth differs from q's by the texel's slope, never occludes) and within reach.
        float ahead = u_orthographic != 0 ? dot(q - s, u_camera_forward)
                                          : distance(q, u_camera_position) - distance(s, u_camera_position);
        float height = dot(s - p, n);
        if (ahead > 0.0 && height > 0.05 * reach + 1e-4 * camera_dist && distance(s, p) < 2.0 * u_ao_distance) {
            occluded += 1.0;
        }
    }
    return 1.0 - occluded / float(AO_POINTS);
}

void main() {
    ivec2 local = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(local, u_size))) return;
    ivec2 pixel = local;
    vec4 nm = texelFetch(u_normal_material, pixel, 0);
    float visibility = 1.0;
    if (nm.w != 0.0) {
        vec2 ndc_xy = (vec2(local) + 0.5) / vec2(u_size) * 2.0 - 1.0;
        vec3 p = unproject(ndc_xy, texelFetch(u_depth, pixel, 0).r * 2.0 - 1.0);
        vec3 view_dir = u_orthographic != 0 ? u_camera_forward : normalize(p - u_camera_position);
        vec3 n = normalize(nm.xyz);
        visibility = screen_space_sky_visibility(p, dot(n, view_dir) <= 0.0 ? n : -n);
    }
    imageStore(u_visibility, pixel, vec4(0.0, 0.0, 0.0, visibility));  // a: the visibility
}
