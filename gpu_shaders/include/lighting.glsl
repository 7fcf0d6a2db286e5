// SPDX-License-Identifier: GPL-3.0-or-later
// Direct lighting from Blender's lamps with shadow maps (paper §3.5), shared by the deferred
// shading and the tracer's hits.
//
// Units follow Blender: a point or spot lamp of power P watts is an isotropic emitter of
// intensity P / (4 pi) W/sr; a sun of strength S gives irradiance S on a surface facing it;
// an area lamp of power P is a Lambertian emitter of intensity P cos(theta) / pi. Outgoing
// diffuse radiance is albedo / pi * irradiance.
//
// Lamps have a size (Light.position.w: point and spot radius, area half-size, sun angular
// diameter in radians), which softens shadows (percentage-closer soft shadows, Fernando
// 2005: a blocker search gives the penumbra's width, a rotated disc filter of that width
// the visibility) and widens glossy highlights (a sphere light's roughness widening, Karis
// 2013).
#include "scene_layout.glsl"
#include "random.glsl"

// Uniform blocks, not storage blocks: every pixel and hit reads them at indices that few
// lanes disagree on, which a GPU serves from its constant cache and llvmpipe as gathers,
// where a storage-block read is a loop over the SIMD lanes; the lamp loop of the deferred
// pass and of every traced hit runs that read once per lamp. Their sizes are MAX_LIGHTS and
// MAX_SHADOW_SLOTS of hybrid_engine/passes/lighting/resources.py, 64 KiB and 48 KiB, within
// every desktop driver's 64 KiB block limit.
layout(std140) uniform LightBuffer { Light lights[1024]; };
layout(std140) uniform ShadowSlotBuffer { ShadowSlot shadow_slots[512]; };

// LIGHT_LINKING defined (FrameResources.defines: some lamp lights less than every object,
// hybrid_engine/scene/light_linking.py): light_links[i].xy is lamp i's 64-bit mask of the
// receiver sets it lights (low word, high word), and a surface's set is its material's
// (params2.z). Without it no lamp is skipped and the block is not declared.
#ifdef LIGHT_LINKING
layout(std140) uniform LightLinkBuffer { uvec4 light_links[1024]; };

bool lamp_lights_set(int i, int receiver_set) {
    uint word = receiver_set < 32 ? light_links[i].x : light_links[i].y;
    return ((word >> uint(receiver_set & 31)) & 1u) != 0u;
}
#endif

// The receiver set of the objects that wear material m (0: the default set).
int material_light_set(Material m) {
    return int(m.params2.z + 0.5);
}

uniform sampler2D u_shadow_atlas;    // objects at rest (hybrid_engine/passes/shadow_maps/shadow_cache.py)
uniform sampler2D u_shadow_dynamic;  // moving objects: same slots, the nearer depth wins
uniform int u_light_count;
uniform float u_shadow_bias;         // scene units, added to the texel bias (0 by default)
uniform float u_shadow_bias_texels;  // the bias in shadow-map texels at the receiver
uniform float u_shadow_normal_offset; // texels times the sine of the angle to the lamp
uniform int u_sample;                // sample index of this view (random.glsl)

int cube_face(vec3 d) {
    vec3 a = abs(d);
    if (a.x >= a.y && a.x >= a.z) return d.x >= 0.0 ? 0 : 1;
    if (a.y >= a.z) return d.y >= 0.0 ? 2 : 3;
    return d.z >= 0.0 ? 4 : 5;
}

// 16 points spread evenly over the unit disc (Vogel's golden-angle spiral: point i at radius
// sqrt((i + 0.5) / 16), angle 2.39996 i): the filter taps, as uniform over the disc as the
// lamp they stand for. Any prefix of the spiral covers the disc evenly too.
const vec2 DISC16[16] = vec2[16](
    vec2(0.176777, 0.000000), vec2(-0.225772, 0.206826), vec2(0.034558, -0.393771),
    vec2(0.284571, 0.371173), vec2(-0.522223, -0.092374), vec2(0.494695, -0.314685),
    vec2(-0.165466, 0.615525), vec2(-0.315561, -0.607594), vec2(0.684642, 0.250030),
    vec2(-0.712256, 0.294009), vec2(0.343355, -0.733729), vec2(0.253730, 0.808932),
    vec2(-0.764746, -0.443186), vec2(0.897134, -0.197232), vec2(-0.547507, 0.778772),
    vec2(-0.126487, -0.976090));
#define SHADOW_MAX_FILTER_TEXELS 48.0
// Taps of the blocker search and of the penumbra filter (powers of two up to 16); each
// sample rotates them, so accumulated samples smooth the penumbra. HARD_SHADOWS defined:
// every lookup is the single hard test.
#ifndef SHADOW_SEARCH_TAPS
#define SHADOW_SEARCH_TAPS 4
#endif
#ifndef SHADOW_FILTER_TAPS
#define SHADOW_FILTER_TAPS 8
#endif

float shadow_depth_at(ShadowSlot slot, vec2 texel_f) {
    int size = slot.rect.z;
    ivec2 texel = clamp(ivec2(texel_f), ivec2(0), ivec2(size - 1));
    ivec2 at = slot.rect.xy + texel;
    return min(texelFetch(u_shadow_atlas, at, 0).r, texelFetch(u_shadow_dynamic, at, 0).r);
}

// Distance along the slot's view axis of a stored depth (window depth in [0, 1]).
float shadow_linear_depth(ShadowSlot slot, float window_depth) {
    float near = slot.texel.z, far = slot.texel.w;
    if (slot.texel.y > 0.5) {
        float z_ndc = window_depth * 2.0 - 1.0;
        return 2.0 * near * far / max(far + near - z_ndc * (far - near), 1e-30);
    }
    return near + window_depth * (far - near);
}

// A sun's slots are its cascades, finest first, then its map of the whole scene
// (hybrid_engine/passes/shadow_maps/sun_cascades.py): the finest slot from `from` on that holds p with room for
// the widest filter around it, else the scene map (the last).
int sun_shadow_slot(int from, int last, vec3 p) {
    for (int i = from; i < last; ++i) {
        ShadowSlot slot = shadow_slots[i];
        vec3 ndc = (slot.view_proj * vec4(p, 1.0)).xyz;  // orthographic: w = 1
        float inner = 1.0 - 2.0 * (SHADOW_MAX_FILTER_TEXELS + 2.0) / float(slot.rect.z);
        if (all(lessThanEqual(abs(ndc.xy), vec2(inner))) && abs(ndc.z) <= 1.0) return i;
    }
    return last;
}

// Where p falls in one shadow slot: the texel, its depth there (window and distance along
// the slot's axis), the world size of a texel there and the receiver-plane slope.
struct ShadowProbe {
    int index;
    bool inside;
    vec2 texel_f;
    float receiver;
    float d_receiver;
    float texel_world;
    float slope;
};

// Normal-offset bias: the lookup point moves off the surface by the bias, in shadow texels
// (their world size grows with distance for perspective slots), plus the normal offset,
// texels times the sine of the surface's angle to the lamp, a quarter of the bias towards
// the lamp. Texels, not scene units: the offset keeps its proportion to the objects at any
// scene scale and removes acne at any map resolution without detaching contact shadows.
ShadowProbe shadow_probe(int index, Light light, vec3 p, vec3 n, vec3 to_light) {
    ShadowProbe probe;
    probe.index = index;
    ShadowSlot slot = shadow_slots[index];
    bool perspective = slot.texel.y > 0.5;
    probe.texel_world = slot.texel.x * (perspective ? distance(p, light.position.xyz) : 1.0);
    float sin_angle = sqrt(max(0.0, 1.0 - dot(n, to_light) * dot(n, to_light)));
    float bias = u_shadow_bias + u_shadow_bias_texels * probe.texel_world;
    vec3 offset = n * (bias + u_shadow_normal_offset * probe.texel_world * sin_angle) + to_light * (0.25 * bias);
    vec4 q = slot.view_proj * vec4(p + offset, 1.0);
    vec3 ndc = q.xyz / max(q.w, 1e-30);
    probe.inside = q.w > 0.0 && all(lessThanEqual(abs(ndc.xy), vec2(1.0))) && ndc.z <= 1.0;
    probe.texel_f = (ndc.xy * 0.5 + 0.5) * float(slot.rect.z);
    probe.receiver = ndc.z * 0.5 + 0.5;
    probe.d_receiver = shadow_linear_depth(slot, probe.receiver);
    // The receiver's own surface, tilted against the light, rises towards it across the
    // filter: a tap r texels away finds it up to r texels times the tilt's slope nearer.
    // Taps compare distances along the light (linear depths) with that much slack, or a lit
    // slope would shadow itself in speckles (receiver-plane depth bias).
    float cos_light = max(dot(n, to_light), 0.1);
    probe.slope = probe.texel_world * sqrt(max(0.0, 1.0 - cos_light * cos_light)) / cos_light;
    return probe;
}

// An area lamp's shape (scene_layout.glsl): its x and y axes (unit, perpendicular to its
// direction), half-sizes along them, and whether it is a disk or ellipse. The x axis is
// stored as an angle in the same basis hybrid_engine/scene/data.py's area_basis builds
// from the direction (Duff et al. 2017).
struct AreaShape {
    vec3 u;
    vec3 v;
    vec2 half_size;
    bool elliptic;
};

AreaShape area_shape(Light light) {
    vec3 n = light.direction.xyz;
    float sign_z = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (sign_z + n.z);
    float b = n.x * n.y * a;
    vec3 t1 = vec3(1.0 + sign_z * n.x * n.x * a, sign_z * b, -sign_z * n.x);
    vec3 t2 = vec3(b, sign_z + n.y * n.y * a, -n.y);
    AreaShape shape;
    shape.u = cos(light.color.w) * t1 + sin(light.color.w) * t2;
    shape.v = cross(n, shape.u);
    shape.half_size = max(vec2(light.position.w, light.direction.w), vec2(0.0));
    shape.elliptic = light.info.w != 0;
    return shape;
}

// Shadow-map texels per metre moved along world direction w at p, in slot's map: the
// derivative of its projection (perspective divide included).
vec2 shadow_texels_per_metre(ShadowSlot slot, vec3 p, vec3 w) {
    vec4 h = slot.view_proj * vec4(p, 1.0);
    vec4 dh = slot.view_proj * vec4(w, 0.0);
    return (dh.xy * h.w - h.xy * dh.w) / max(h.w * h.w, 1e-30) * (0.5 * float(slot.rect.z));
}

// An area lamp's axis w of half-size `half_extent` (metres at p) in texels of slot's map.
vec2 area_axis_texels(ShadowSlot slot, vec3 p, vec3 w, float half_extent) {
    return shadow_texels_per_metre(slot, p, w) * half_extent;
}

// Both axes shrunk alike so that the longer spans at most a quarter of the slot (and at
// least SHADOW_MAX_FILTER_TEXELS): a large lamp near its blocker casts a penumbra wider than
// a sun's filter ever needs, and there is no coarser map to move to; the sparse taps are
// rotated by every sample, so the accumulated image smooths them. Past that, the footprint
// keeps the lamp's proportions.
void fit_filter(inout vec2 axis_u, inout vec2 axis_v, ShadowSlot slot) {
    float limit = max(SHADOW_MAX_FILTER_TEXELS, 0.25 * float(slot.rect.z));
    float widest = max(length(axis_u), length(axis_v));
    float fit = widest > limit ? limit / widest : 1.0;
    axis_u *= fit;
    axis_v *= fit;
}

// Filter tap i of n over an area lamp's shape, as a point of [-1, 1]^2 (a rectangle: a 2D
// Hammersley set shifted by this sample's offset, so samples tile the square) or of the unit
// disc (an ellipse: the rotated spiral).
vec2 area_tap(int i, int n, bool elliptic, mat2 rot, vec2 shift) {
    if (elliptic) return rot * DISC16[i * (16 / n)];
    vec2 h = vec2((float(i) + 0.5) / float(n), float(bitfieldReverse(uint(i))) * 2.3283064e-10);
    return fract(h + shift) * 2.0 - 1.0;
}

// 1 when lit, 0 when a shadow map says an occluder lies between p and the light; in between
// in the penumbra of a lamp of size Light.position.w (with `soft`; hard otherwise). A sun's
// penumbra may be wider than the finest cascade's filter reaches: the blocker search and
// the filter each take the finest slot where their width fits SHADOW_MAX_FILTER_TEXELS.
float shadow_visibility(Light light, vec3 p, vec3 n, vec3 to_light, bool soft) {
    int first = light.info.y;
    if (first < 0) return 1.0;
    bool sun = light.info.x == LIGHT_SUN;
    int last = sun ? first + light.info.z - 1 : first;
    int finest = sun ? sun_shadow_slot(first, last, p) : first + (light.info.z == 6 ? cube_face(p - light.position.xyz) : 0);
    ShadowProbe probe = shadow_probe(finest, light, p, n, to_light);
    if (!probe.inside) return 1.0;
    bool area = light.info.x == LIGHT_AREA;
    AreaShape shape;
    if (area) shape = area_shape(light);
    float lamp = area ? max(shape.half_size.x, shape.half_size.y) : light.position.w;
    if (!(lamp > 0.0) || !soft) {
        return probe.receiver <= shadow_depth_at(shadow_slots[finest], probe.texel_f) + 1e-5 ? 1.0 : 0.0;
    }
    bool perspective = shadow_slots[finest].texel.y > 0.5;
    // The filter's rotation and an area lamp's shift, keyed by where p lies in the scene's
    // own units (random.glsl), not by its float bits: one scene draws the same numbers at
    // the same points whether it is modelled in millimetres or kilometres.
    uvec3 at = position_key(p);
    uint at_key = at.x ^ pcg_hash(at.y ^ pcg_hash(at.z));
    float angle = float(u_sample) * 2.39996323 + 6.2831853 * random2(uvec4(at_key, 0u, uint(finest), 7u)).x;
    mat2 rot = mat2(cos(angle), sin(angle), -sin(angle), cos(angle));
    // Blocker search over the widest penumbra a blocker could cast: for a sun, one at the
    // map's near plane; for a lamp, one half-way to it.
    ShadowProbe search_at = probe;
    float widest = perspective ? 2.0 * lamp : 2.0 * tan(0.5 * lamp) * (probe.d_receiver - shadow_slots[finest].texel.z);
    while (sun && search_at.index < last && widest > SHADOW_MAX_FILTER_TEXELS * search_at.texel_world) {
        search_at = shadow_probe(sun_shadow_slot(search_at.index + 1, last, p), light, p, n, to_light);
        widest = 2.0 * tan(0.5 * lamp) * (search_at.d_receiver - shadow_slots[search_at.index].texel.z);
    }
    ShadowSlot slot = shadow_slots[search_at.index];
    float search = clamp(widest / search_at.texel_world, 1.0, SHADOW_MAX_FILTER_TEXELS);
    // An area lamp searches (and filters, below) over its own shape: its two axes as the map
    // shows them at p, for a blocker half-way to the lamp.
    vec2 axis_u = vec2(0.0), axis_v = vec2(0.0), shift = vec2(0.0);
    if (area) {
        shift = random2(uvec4(at_key, 1u, uint(u_sample), 11u));
        axis_u = area_axis_texels(slot, p, shape.u, shape.half_size.x);
        axis_v = area_axis_texels(slot, p, shape.v, shape.half_size.y);
        fit_filter(axis_u, axis_v, slot);
    }
    // A small blocker under a long lamp covers little of the search footprint: a search
    // that misses it would call the point lit, so area lamps search with every tap.
    int search_taps = area ? 16 : SHADOW_SEARCH_TAPS;
    float blockers = 0.0, blocker_depth = 0.0;
    for (int i = 0; i < search_taps; ++i) {
        vec2 tap;
        if (area) {
            vec2 unit = area_tap(i, search_taps, shape.elliptic, rot, shift);
            tap = axis_u * unit.x + axis_v * unit.y;
        } else {
            tap = rot * DISC16[i * (16 / SHADOW_SEARCH_TAPS)] * search;
        }
        float d = shadow_linear_depth(slot, shadow_depth_at(slot, search_at.texel_f + tap));
        if (d < search_at.d_receiver - search_at.texel_world - length(tap) * search_at.slope) {
            blockers += 1.0;
            blocker_depth += d;
        }
    }
    if (blockers == 0.0) return 1.0;
    if (blockers == float(search_taps)) return 0.0;  // every tap blocked: the umbra
    // World width of the penumbra: the sun's angular diameter times the receiver-to-blocker
    // distance, or the lamp's diameter scaled by that distance over the blocker's from it.
    float d_gap = search_at.d_receiver - blocker_depth / blockers;
    float penumbra_world = perspective ? 2.0 * lamp * d_gap / max(search_at.d_receiver - d_gap, 1e-6)
                                       : 2.0 * tan(0.5 * lamp) * d_gap;
    ShadowProbe filter_at = probe;
    while (sun && filter_at.index < search_at.index
           && 0.5 * penumbra_world > SHADOW_MAX_FILTER_TEXELS * filter_at.texel_world) {
        filter_at = shadow_probe(sun_shadow_slot(filter_at.index + 1, last, p), light, p, n, to_light);
    }
    slot = shadow_slots[filter_at.index];
    float radius = clamp(0.5 * penumbra_world / filter_at.texel_world, 0.5, SHADOW_MAX_FILTER_TEXELS);
    // An area lamp's penumbra has its shape: the taps span its two axes, each scaled by
    // the receiver's gap to the blocker over the blocker's distance from the lamp.
    if (area) {
        float scale = d_gap / max(search_at.d_receiver - d_gap, 1e-6);
        axis_u = area_axis_texels(slot, p, shape.u, shape.half_size.x * scale);
        axis_v = area_axis_texels(slot, p, shape.v, shape.half_size.y * scale);
        fit_filter(axis_u, axis_v, slot);
    }
    float lit = 0.0;
    for (int i = 0; i < SHADOW_FILTER_TAPS; ++i) {
        vec2 tap = DISC16[i * (16 / SHADOW_FILTER_TAPS)] * radius;
        if (area) {
            vec2 unit = area_tap(i, SHADOW_FILTER_TAPS, shape.elliptic, rot, shift);
            tap = axis_u * unit.x + axis_v * unit.y;
        }
        if (!area) tap = rot * tap;
        float d = shadow_linear_depth(slot, shadow_depth_at(slot, filter_at.texel_f + tap));
        lit += d >= filter_at.d_receiver - filter_at.texel_world - length(tap) * filter_at.slope ? 1.0 : 0.0;
    }
    return lit / float(SHADOW_FILTER_TAPS);
}

// The glossy response of a lamp seen from p towards `l`, the lamp's point nearest the
// mirror direction (representative point, Karis 2013): GGX distribution with Smith's
// height-correlated visibility for roughness alpha (no less than LAMP_LOBE_MIN_ALPHA, which
// softens the edge by a fraction of a degree), scaled by (alpha / (alpha + spread))^2,
// where spread is the lamp's angular radius over two. The lobe keeps about the energy of a
// lobe widened by the lamp's size, but its core has the lamp's shape: a mirror shows a
// sphere lamp as a sharp-edged disc of about the lamp's radiance and nothing around it, as
// Cycles does, instead of a bright core with a wide GGX glow. A lamp of no size in a
// mirror shows nothing (as in Cycles).
#define LAMP_LOBE_MIN_ALPHA 0.01
float ggx_lamp(vec3 n, vec3 v, vec3 l, float alpha, float spread) {
    if (alpha + spread < 1e-3) return 0.0;
    vec3 h = normalize(v + l);
    float n_h = max(dot(n, h), 0.0);
    float n_v = max(dot(n, v), 1e-4);
    float n_l = max(dot(n, l), 1e-4);
    float a = clamp(alpha, LAMP_LOBE_MIN_ALPHA, 1.0);  // the lobe's floor keeps its peak finite
    float wide = clamp(alpha + spread, a, 1.0);
    float a2 = a * a;
    float denom = n_h * n_h * (a2 - 1.0) + 1.0;
    float d = a2 / (PI * denom * denom);
    float vis = 0.5 / (n_l * sqrt(n_v * n_v * (1.0 - a2) + a2) + n_v * sqrt(n_l * n_l * (1.0 - a2) + a2));
    float keep = a / wide;
    return d * vis * keep * keep;
}

// The point of a lamp nearest the mirror direction r, as a unit direction from p: of a
// sphere of radius `radius` around `delta` (the lamp's centre from p) for lamps with a
// position, of the sun's disc of angular diameter `angle` around `to_light` for a sun.
vec3 lamp_nearest_direction(vec3 r, vec3 delta, float radius) {
    vec3 to_ray = dot(delta, r) * r - delta;
    float off = length(to_ray);
    return normalize(delta + (off > 0.0 ? to_ray * min(radius / off, 1.0) : vec3(0.0)));
}

// The point of an area lamp (centre `delta` from p, emitting along `n_l`) nearest the
// mirror direction r, as a unit direction from p: where r meets the lamp's plane, clamped
// to its rectangle or ellipse; a ray that never meets the plane takes the edge point
// towards which it leans. A mirror thus shows the lamp's own shape, as in Cycles.
vec3 area_nearest_direction(vec3 r, vec3 delta, vec3 n_l, AreaShape shape) {
    float denom = dot(r, n_l);
    float t = denom < -1e-6 ? dot(delta, n_l) / denom : -1.0;
    vec3 q = t > 0.0 ? t * r - delta : (r - denom * n_l) * 1e6 * max(shape.half_size.x, shape.half_size.y);
    vec2 xy = vec2(dot(q, shape.u), dot(q, shape.v));
    if (shape.elliptic) {
        vec2 unit = xy / max(shape.half_size, vec2(1e-12));
        float len = length(unit);
        xy = len > 1.0 ? xy / len : xy;
    } else {
        xy = clamp(xy, -shape.half_size, shape.half_size);
    }
    return normalize(delta + xy.x * shape.u + xy.y * shape.v);
}

vec3 sun_nearest_direction(vec3 r, vec3 to_light, float angle) {
    float cos_r = dot(r, to_light);
    float cos_s = cos(0.5 * angle);
    if (cos_r >= cos_s) return r;
    vec3 across = r - cos_r * to_light;
    float len = length(across);
    return len > 0.0 ? normalize(cos_s * to_light + sin(0.5 * angle) * across / len) : to_light;
}

// Light arriving at p (normal n facing the viewer, unit v towards the viewer) from all
// lamps, with shadows: `irradiance` for the diffuse lobe (when `diffuse`), and the lamps'
// glossy reflection (already times the BRDF) for a specular layer of reflectance f0 at
// normal incidence, rising to `f90` at grazing (Schlick), and roughness `roughness`.
struct DirectLight {
    vec3 irradiance;
    vec3 glossy;
};

// `receiver_set`: the surface's light-linking set (material_light_set); lamps that do not
// light it are skipped (LIGHT_LINKING only).
DirectLight direct_lighting(vec3 p, vec3 n, vec3 v, vec3 f0, float f90, float roughness, bool diffuse,
                            int receiver_set) {
    DirectLight result;
    result.irradiance = vec3(0.0);
    result.glossy = vec3(0.0);
    bool glossy = max(max(f0.r, f0.g), max(f0.b, f90)) > 0.0;
#ifdef NO_LAMP_HIGHLIGHTS  // a measurement switch (benchmarks/picture_cost.py)
    glossy = false;
#endif
    if (!diffuse && !glossy) return result;
    float alpha = roughness * roughness;
    vec3 mirror = reflect(-v, n);
    for (int i = 0; i < u_light_count; ++i) {
#ifdef LIGHT_LINKING
        if (!lamp_lights_set(i, receiver_set)) continue;
#endif
        Light light = lights[i];
        int kind = light.info.x;
        vec3 to_light, to_highlight;
        float dist2 = 1.0;
        float spread;
        if (kind == LIGHT_SUN) {
            to_light = -light.direction.xyz;
            spread = 0.5 * tan(0.5 * light.position.w);
            to_highlight = glossy ? sun_nearest_direction(mirror, to_light, light.position.w) : to_light;
        } else if (kind == LIGHT_AREA) {
            vec3 delta = light.position.xyz - p;
            dist2 = max(dot(delta, delta), 1e-12);
            to_light = delta * inversesqrt(dist2);
            AreaShape shape = area_shape(light);
            // The lobe widens by the radius of the disc of the lamp's area.
            float area = 4.0 * shape.half_size.x * shape.half_size.y * (shape.elliptic ? 0.25 * PI : 1.0);
            spread = 0.5 * sqrt(area / PI) * inversesqrt(dist2);
            to_highlight = glossy ? area_nearest_direction(mirror, delta, light.direction.xyz, shape) : to_light;
        } else {
            vec3 delta = light.position.xyz - p;
            dist2 = max(dot(delta, delta), 1e-12);
            to_light = delta * inversesqrt(dist2);
            spread = 0.5 * light.position.w * inversesqrt(dist2);
            to_highlight = glossy ? lamp_nearest_direction(mirror, delta, light.position.w) : to_light;
        }
        float cos_surface = dot(n, to_light);
        if (cos_surface <= 0.0) continue;
        // A smooth surface shows a lamp of no size nowhere: skip the shadow test for it.
        float lobe = glossy ? ggx_lamp(n, v, to_highlight, alpha, spread) : 0.0;
        if (!diffuse && lobe == 0.0) continue;
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
        // Highlights alone (a mirror) take the hard test: their lobe already blurs the edge.
#ifdef HARD_SHADOWS
        e *= shadow_visibility(light, p, n, to_light, false);
#else
        e *= shadow_visibility(light, p, n, to_light, diffuse);
#endif
        result.irradiance += e;
        if (lobe > 0.0) {
            float v_h = clamp(dot(v, normalize(v + to_highlight)), 0.0, 1.0);
            vec3 fresnel = f0 + (vec3(f90) - f0) * pow(1.0 - v_h, 5.0);
            result.glossy += e * fresnel * lobe;
        }
    }
    return result;
}

// Every lamp's light, for callers without a linked surface (the default set).
DirectLight direct_lighting(vec3 p, vec3 n, vec3 v, vec3 f0, float f90, float roughness, bool diffuse) {
    return direct_lighting(p, n, v, f0, f90, roughness, diffuse, 0);
}
