// SPDX-License-Identifier: GPL-3.0-or-later
// The radiance cache's step after each frame's gather (hybrid_engine/passes/diffuse_light/
// radiance_cache.py): every slot folds this frame's deposits into its mean, which holds at
// most u_cap deposits (older ones count less as new ones arrive: a light switched off fades
// from the cache within a few frames), and a slot that received none for u_max_age frames
// is freed for another cell.
//
// Host defines: RADIANCE_CACHE_SLOTS, RADIANCE_PROBES, RADIANCE_FIXED_BITS (radiance_cache.glsl).
// Storage block: RadianceCache. Uniforms: u_cap, u_max_age.
#include "radiance_cache.glsl"

layout(local_size_x = 64) in;
uniform float u_cap;
uniform uint u_max_age;

void main() {
    uint slot = gl_GlobalInvocationID.x;
    if (slot >= uint(RADIANCE_CACHE_SLOTS)) return;
    RadianceSlot s = radiance_slots[slot];
    if (s.key == 0u) return;
    if (s.count > 0u) {
        float held = min(s.mean.a, u_cap);
        float added = float(s.count);
        vec3 sum = radiance_sum(s.low, s.high);
        vec3 mean = (s.mean.rgb * held + sum) / (held + added);
        radiance_slots[slot].mean = any(isinf(mean)) || any(isnan(mean)) ? vec4(0.0) : vec4(mean, held + added);
        radiance_slots[slot].count = 0u;
        radiance_slots[slot].low = uvec4(0u);
        radiance_slots[slot].high = uvec4(0u);
        radiance_slots[slot].age = 0u;
    } else if (s.age + 1u >= u_max_age) {
        radiance_slots[slot].key = 0u;
        radiance_slots[slot].mean = vec4(0.0);
        radiance_slots[slot].age = 0u;
    } else {
        radiance_slots[slot].age = s.age + 1u;
    }
}
