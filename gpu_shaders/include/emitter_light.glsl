// SPDX-License-Identifier: GPL-3.0-or-later
// Emissive surfaces as lights, by next-event estimation: a diffuse gather adds, at each
// vertex, the light of one point drawn on the scene's emissive triangles, seen through one
// shadow ray, instead of waiting for its cosine paths to hit a small bright emitter by
// chance (the fireflies such hits make, and the slow convergence). The table and its CDF
// are built every frame on the GPU (hybrid_engine/passes/emitters/emitter_table.py).
//
// Compiled only under #define EMITTER_LIGHT, by kernels that include trace_ray.glsl first
// (the shadow ray is a trace_ray; materials, TriangleMaterials, TriangleUVBuffer and
// u_textures are its blocks). The host binds EmitterTable.bindings():
//   storage blocks EmitterTriangles (Emitter[count], emitter_layout.glsl),
//                  EmitterCdf (uint[count + 1]: the exclusive prefix of the integer weights,
//                  the total at [count]);
//   uniform u_emitter_count (0: no emitter; emitter_irradiance returns 0 and traces nothing).
//
// Emission is two-sided, as Cycles' Emission shader (and lamp_light_response, which adds a
// surface's emission whichever side it is seen from): |cos| at the light.
//
// With EMITTER_LINKING (some emissive object has a receiver or blocker collection,
// hybrid_engine/passes/emitters/emitter_links.py) the host also binds EmitterLinks
// (emitter_links.glsl): an emitter adds nothing to a surface whose receiver set its light
// mask lacks, and its shadow ray passes through the surfaces that are not its blockers.
#ifdef EMITTER_LIGHT
#ifndef HYBRID_EMITTER_LIGHT_GLSL
#define HYBRID_EMITTER_LIGHT_GLSL
#ifdef TRACE_SHADING_ONLY
#error "emitter_light.glsl traces shadow rays: it needs trace_ray.glsl's tracing (no TRACE_SHADING_ONLY)"
#endif
#include "emitter_layout.glsl"
#include "emitter_links.glsl"

layout(std430) readonly buffer EmitterTriangles { Emitter emitters[]; };
layout(std430) readonly buffer EmitterCdf { uint emitter_cdf[]; };
uniform int u_emitter_count;

// Shadow rays this invocation traced toward emitters (a kernel may count them).
uint emitter_shadow_rays = 0u;

// Surfaces that are not an emitter's blockers a shadow ray passes through before it gives up
// and lets the light through (EMITTER_LINKING): Cycles skips every one, a bounded loop skips
// as many as a scene's linking plausibly stacks between a surface and a light.
#define EMITTER_SKIPPED_HITS 8

// Whether hit h of a shadow ray towards point q of an emitter is the emitter itself: a
// cube-map march takes a hit a little behind its surface (cube_max_hit_overshoot), and the
// light's own texel found at the end of the ray is the light, not a blocker.
bool emitter_hit_is_light(Hit h, vec3 q) {
    return h.kind == HIT_CUBE && distance(h.position, q) <= cube_max_hit_overshoot() * distance(q, u_cube_center);
}

// The emitter whose CDF interval holds u in [0, 1) (binary search of the exclusive prefix:
// the last entry not above u x total, so a zero-weight emitter is never picked) and the
// probability of picking it (its weight over the total); -1 when nothing emits.
int emitter_pick(float u, out float probability) {
    probability = 0.0;
    if (u_emitter_count <= 0) return -1;
    uint count = uint(u_emitter_count);
    uint total = emitter_cdf[count];
    if (total == 0u) return -1;
    uint target = min(uint(u * float(total)), total - 1u);
    uint lo = 0u;
    uint hi = count - 1u;
    while (lo < hi) {
        uint mid = (lo + hi + 1u) >> 1u;
        if (emitter_cdf[mid] <= target) lo = mid; else hi = mid - 1u;
    }
    probability = float(emitter_cdf[lo + 1u] - emitter_cdf[lo]) / float(total);
    return int(lo);
}

// One-sample estimate of the irradiance the emissive triangles give the surface at p (unit
// shading normal n_facing and geometric normal g_facing, both on the side the light is
// gathered for): an emitter picked by power (xi.x), a uniform point on it (xi.yz), its
// emission there (the emission texture read at the point's UV), and a shadow ray from p to
// it: L_e cos_p |cos_l| / (d^2 pdf_area), pdf_area = P(pick) / area. What lies in between
// lets through its transmission, as occlusion_seen (trace_ray.glsl) has glass do. Not
// divided by pi, not multiplied by albedo: an irradiance, as sky_irradiance's.
// `receiver_set`: the surface's light-linking set (its material's, light_linking.py), read
// only with EMITTER_LINKING. `bounce`: the path vertex p is (0: the point the camera sees),
// whose shadow ray a blocker's Light Path sees at Ray Depth bounce + 1.
vec3 emitter_irradiance(vec3 p, vec3 n_facing, vec3 g_facing, vec3 xi, int receiver_set, int bounce) {
    float probability;
    int picked = emitter_pick(xi.x, probability);
    if (picked < 0 || !(probability > 0.0)) return vec3(0.0);
    Emitter e = emitters[picked];
    int tri = floatBitsToInt(e.corner.w);
    int row = tri_materials[tri];
#ifdef EMITTER_LINKING
    // Light linking: an emitter that does not light this surface adds nothing. It is still
    // picked by its power (one table serves every receiver set), which keeps the estimate
    // unbiased and only adds noise where much of the power is linked elsewhere.
    if (!emission_lights_set(row, receiver_set)) return vec3(0.0);
#endif
    // Uniform on the triangle (the square-root warp of two numbers).
    float su = sqrt(xi.y);
    vec2 bary = vec2(su * (1.0 - xi.z), su * xi.z);
    vec3 q = e.corner.xyz + bary.x * e.edge1.xyz + bary.y * e.edge2.xyz;
    vec3 to_light = q - p;
    float d2 = dot(to_light, to_light);
    if (!(d2 > 1e-12)) return vec3(0.0);
    float d = sqrt(d2);
    vec3 w = to_light / d;
    float cos_p = dot(n_facing, w);
    // Below the shading normal, or below the true surface (light through the surface itself).
    if (cos_p <= 0.0 || dot(g_facing, w) <= 0.0) return vec3(0.0);
    vec3 cross_edges = cross(e.edge1.xyz, e.edge2.xyz);
    float twice_area = length(cross_edges);
    if (!(twice_area > 0.0)) return vec3(0.0);
    float cos_l = abs(dot(cross_edges, w)) / twice_area;
    if (!(cos_l > 0.0)) return vec3(0.0);
    Material m = materials[row];
    vec2 uv = vec2(0.0);
    if (m.textures.y >= 0) {
        TriangleUV tuv = tri_uvs[tri];
        uv = (1.0 - bary.x - bary.y) * tuv.uv01.xy + bary.x * tuv.uv01.zw + bary.y * tuv.uv2_scale.xy;
    }
    vec3 emission = max(material_emission_lod(m, uv, 0.0), vec3(0.0));
    if (!(max(max(emission.r, emission.g), emission.b) > 0.0)) return vec3(0.0);
    // The shadow ray runs from the offset origin to the point itself and stops short of the
    // light's own surface (its offset, and a sliver of the distance for the traversal's
    // rounding at grazing angles).
    vec3 o = offset_origin(p, g_facing);
    vec3 to_point = q - o;
    float reach = length(to_point);
    vec3 shadow_dir = to_point / max(reach, 1e-30);
    reach = (reach - (scene_offset_absolute(RAY_OFFSET_ABSOLUTE) + RAY_OFFSET_RELATIVE * max(max(abs(q.x), abs(q.y)), abs(q.z)))) * (1.0 - 1e-4);
    float seen = 1.0;
    if (reach > 0.0) {
#ifdef EMITTER_LINKING
        // Shadow linking: only the emitter's blockers cast its shadow. The ray goes on past
        // each surface that is not one, as Cycles' shadow rays skip them; one trace_ray call
        // site in the loop (the traversal is most of the kernel's code).
        uvec2 blockers = emitter_links[row].zw;
        bool linked = blockers != uvec2(0xFFFFFFFFu);
        vec3 from = o;
        float left = reach;
        Hit h;
        bool itself;
        for (int k = 0; ; ++k) {
            emitter_shadow_rays += 1u;
            trace_shadow_rays = true;
            trace_shadow_bounce = bounce;
            h = trace_ray(from, shadow_dir, -1, 1.0, left);
            trace_shadow_rays = false;
            trace_shadow_bounce = 1;
            itself = emitter_hit_is_light(h, q);
            if (!linked || h.kind == HIT_SKY || itself
                || link_mask_holds(blockers, int(materials[h.material].params2.w + 0.5))) break;
            from = offset_origin(h.position, shadow_dir);
            left = reach - dot(from - o, shadow_dir);
            // Past the last surface before the light, or past the loop's reach: the light passes.
            if (!(left > 0.0) || k == EMITTER_SKIPPED_HITS - 1) { h.kind = HIT_SKY; break; }
        }
#else
        emitter_shadow_rays += 1u;
        trace_shadow_rays = true;
        trace_shadow_bounce = bounce;
        Hit h = trace_ray(o, shadow_dir, -1, 1.0, reach);
        trace_shadow_rays = false;
        trace_shadow_bounce = 1;
        bool itself = emitter_hit_is_light(h, q);
#endif
        if (h.kind != HIT_SKY && !itself) seen = material_transmission(materials[h.material]);
    }
    if (!(seen > 0.0)) return vec3(0.0);
    float area = 0.5 * twice_area;
    return emission * (seen * cos_p * cos_l * area / (probability * d2));
}

#endif  // HYBRID_EMITTER_LIGHT_GLSL
#endif  // EMITTER_LIGHT
