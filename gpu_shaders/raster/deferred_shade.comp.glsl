// SPDX-License-Identifier: GPL-3.0-or-later
// Deferred shading of primary hits (paper §3.5 and the first half of step 4 of §3).
//
// Reads the primary G-buffer and writes the RASTER image: emission + diffuse lobe lit by all
// lights with shadow maps; the mirror and glass lobes look up the sky in the reflected /
// refracted direction (the classic environment-map approximation, used only in RASTER mode;
// the hybrid tracer replaces these lobes with traced rays). Background pixels get the sky.
//
// Bindings: u_depth (DEPTH32F), u_normal_material (RGBA32F), u_albedo (RGBA16F) read;
//   SSBO 0 materials, 1 lights, 2 shadow slots read; image unit 0 (RGBA32F) written.
// Workgroup 8x8: square tiles keep neighbouring pixels (and their G-buffer rows) together.
#include "scene_layout.glsl"
#include "sky.glsl"
#include "lighting.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(std430, binding = 0) readonly buffer MaterialBuffer { Material materials[]; };
layout(rgba32f, binding = 0) writeonly uniform image2D u_output;

uniform sampler2D u_depth;
uniform sampler2D u_normal_material;
uniform sampler2D u_albedo;
uniform mat4 u_inv_view_proj;
uniform vec3 u_camera_position;
uniform vec3 u_camera_forward;
uniform int u_orthographic;
uniform ivec2 u_size;    // size of the view being shaded
uniform ivec2 u_origin;  // its texel origin inside the G-buffer (cube-map faces share an atlas)

vec3 unproject(vec2 ndc_xy, float ndc_z) {
    vec4 world = u_inv_view_proj * vec4(ndc_xy, ndc_z, 1.0);
    return world.xyz / world.w;
}

float fresnel_dielectric(float cos_i, float eta) {
    // Exact unpolarised Fresnel reflectance; eta = n_transmitted / n_incident.
    float sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.0) return 1.0;  // total internal reflection
    float cos_t = sqrt(1.0 - sin2_t);
    float rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    float rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    return 0.5 * (rs * rs + rp * rp);
}

void main() {
    ivec2 local = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(local, u_size))) return;
    ivec2 pixel = u_origin + local;

    vec2 ndc_xy = (vec2(local) + 0.5) / vec2(u_size) * 2.0 - 1.0;
    vec3 near_point = unproject(ndc_xy, -1.0);
    vec3 view_dir = u_orthographic != 0 ? u_camera_forward : normalize(near_point - u_camera_position);

    vec4 nm = texelFetch(u_normal_material, pixel, 0);
    if (nm.w == 0.0) {
        imageStore(u_output, pixel, vec4(sky_radiance(view_dir), 1.0));
        return;
    }
    float depth = texelFetch(u_depth, pixel, 0).r;
    vec3 p = unproject(ndc_xy, depth * 2.0 - 1.0);
    int material_index = int(abs(nm.w) + 0.5) - 1;
    Material m = materials[material_index];
    vec3 albedo = texelFetch(u_albedo, pixel, 0).rgb;

    vec3 n = nm.xyz;
    bool entering = dot(n, view_dir) < 0.0;
    vec3 n_facing = entering ? n : -n;  // two-sided shading, like Blender

    float reflectivity = m.base_color_refl.a;
    float transmission = m.emission_trans.a;
    float diffuse_weight = max(0.0, 1.0 - reflectivity - transmission);

    vec3 color = m.emission_trans.rgb;
    if (diffuse_weight > 0.0) {
        color += diffuse_weight * albedo / PI * direct_irradiance(p, n_facing);
    }
    vec3 reflected = reflect(view_dir, n_facing);
    if (reflectivity > 0.0) {
        color += reflectivity * albedo * sky_radiance(reflected);
    }
    if (transmission > 0.0) {
        float ior = max(m.params.x, 1.0);
        float eta = entering ? ior : 1.0 / ior;
        float cos_i = clamp(-dot(view_dir, n_facing), 0.0, 1.0);
        float f = fresnel_dielectric(cos_i, eta);
        vec3 refracted = refract(view_dir, n_facing, 1.0 / eta);
        vec3 through = dot(refracted, refracted) > 0.0 ? sky_radiance(refracted) : vec3(0.0);
        color += transmission * (f * sky_radiance(reflected) + (1.0 - f) * albedo * through);
    }
    if (any(isnan(color)) || any(isinf(color))) color = vec3(0.0);
    imageStore(u_output, pixel, vec4(color, 1.0));
}
