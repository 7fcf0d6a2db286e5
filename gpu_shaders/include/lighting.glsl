// SPDX-License-Identifier: GPL-3.0-or-later
// Direct lighting of a diffuse surface with shadow maps (paper §3.5: the hybrid renderer is a
// deferred renderer, so shadows come from shadow maps rather than shadow rays).
//
// Units follow Blender (checked against Cycles): a sun of strength S gives irradiance S; a
// point or spot light of power P has intensity P / (4 pi) W/sr; an area light of power P is
// approximated as a Lambertian point emitter of intensity P cos(theta) / pi. Outgoing
// diffuse radiance is albedo / pi * irradiance.
#include "scene_layout.glsl"

layout(std430, binding = 1) readonly buffer LightBuffer { Light lights[]; };
layout(std430, binding = 2) readonly buffer ShadowSlotBuffer { ShadowSlot shadow_slots[]; };

uniform sampler2D u_shadow_atlas;    // objects at rest (hybrid_engine/shadow_cache.py)
uniform sampler2D u_shadow_dynamic;  // moving objects: same slots, the nearer depth wins
uniform int u_light_count;
uniform float u_shadow_bias;

int cube_face(vec3 d) {
    vec3 a = abs(d);
    if (a.x >= a.y && a.x >= a.z) return d.x >= 0.0 ? 0 : 1;
    if (a.y >= a.z) return d.y >= 0.0 ? 2 : 3;
    return d.z >= 0.0 ? 4 : 5;
}

// 1 when lit, 0 when a shadow map says an occluder lies between p and the light.
// Normal-offset bias: the lookup point moves off the surface by the bias setting plus
// one and a half shadow texels (their world size grows with distance for perspective
// slots), which removes acne at any map resolution without detaching contact shadows.
float shadow_visibility(Light light, vec3 p, vec3 n, vec3 to_light) {
    int first = light.info.y;
    if (first < 0) return 1.0;
    int slot_index = first;
    if (light.info.z == 6) slot_index += cube_face(p - light.position.xyz);
    ShadowSlot slot = shadow_slots[slot_index];
    float texel_world = slot.texel.x * (slot.texel.y > 0.5 ? distance(p, light.position.xyz) : 1.0);
    float sin_angle = sqrt(max(0.0, 1.0 - dot(n, to_light) * dot(n, to_light)));
    vec3 offset = n * (u_shadow_bias + 1.5 * texel_world * sin_angle + 0.5 * texel_world) + to_light * (0.25 * u_shadow_bias);
    vec4 q = slot.view_proj * vec4(p + offset, 1.0);
    if (q.w <= 0.0) return 1.0;
    vec3 ndc = q.xyz / q.w;
    if (any(greaterThan(abs(ndc.xy), vec2(1.0))) || ndc.z > 1.0) return 1.0;
    int size = slot.rect.z;
    ivec2 texel = clamp(ivec2((ndc.xy * 0.5 + 0.5) * float(size)), ivec2(0), ivec2(size - 1));
    ivec2 at = slot.rect.xy + texel;
    float stored = min(texelFetch(u_shadow_atlas, at, 0).r, texelFetch(u_shadow_dynamic, at, 0).r);
    return (ndc.z * 0.5 + 0.5) <= stored + 1e-5 ? 1.0 : 0.0;
}

// Irradiance arriving at p (normal n, facing the viewer) from all lights, with shadows.
vec3 direct_irradiance(vec3 p, vec3 n) {
    vec3 total = vec3(0.0);
    for (int i = 0; i < u_light_count; ++i) {
        Light light = lights[i];
        int kind = light.info.x;
        vec3 to_light;
        float dist2 = 1.0;
        if (kind == LIGHT_SUN) {
            to_light = -light.direction.xyz;
        } else {
            vec3 delta = light.position.xyz - p;
            dist2 = max(dot(delta, delta), 1e-12);
            to_light = delta * inversesqrt(dist2);
        }
        float cos_surface = dot(n, to_light);
        if (cos_surface <= 0.0) continue;
        vec3 e = light.color.rgb * cos_surface;
        if (kind == LIGHT_SUN) {
            // strength is irradiance on a surface facing the sun
        } else if (kind == LIGHT_AREA) {
            float cos_emit = dot(light.direction.xyz, -to_light);
            if (cos_emit <= 0.0) continue;
            e *= cos_emit / (PI * dist2);
        } else {
            e /= 4.0 * PI * dist2;
            if (kind == LIGHT_SPOT) {
                // Blender's spot mask: smoothstep over the blend region inside the cone.
                float cos_angle = dot(light.direction.xyz, -to_light);
                float cos_half = light.direction.w;
                float blend = max(light.color.w * (1.0 - cos_half), 1e-6);
                e *= smoothstep(0.0, 1.0, (cos_angle - cos_half) / blend);
            }
        }
        if (dot(e, e) == 0.0) continue;
        total += e * shadow_visibility(light, p, n, to_light);
    }
    return total;
}
