// SPDX-License-Identifier: GPL-3.0-or-later
// The surface model shared by the deferred shading of G-buffers (primary camera and cube-map
// faces, paper §3.5) and by the hybrid tracer's hits in the BVH (§3.4), so that a surface
// looks the same whichever structure found it.
//
// A material (scene_layout.glsl, hybrid_engine/scene/materials.py) is the Principled BSDF folded
// into three layers whose weights sum to 1, plus emission:
//   metal   = metallic                 reflection tinted by the base colour
//   glass   = transmission             dielectric of index IOR: exact Fresnel mix of the
//                                      reflected and the refracted ray (tinted)
//   diffuse = 1 - metal - glass        Lambertian under a dielectric specular coat of
//                                      reflectance f0 at normal incidence (Specular IOR
//                                      Level); the coat takes its Fresnel share of the light
// all with one roughness (GGX). A reflection smoother than ROUGH_TRACE_LIMIT, and every
// refraction, becomes a secondary ray (its direction drawn from the GGX lobe per sample,
// exact when the roughness is 0); a rougher reflection looks up the sky prefiltered to its
// roughness (sky.glsl), times the sky's visibility. Diffuse surfaces take the lamps with
// shadow maps (lighting.glsl) and the World's irradiance (world_light.glsl), times the
// sky's visibility; every specular layer takes the lamps' glossy highlights.
#include "scene_layout.glsl"
#include "lighting.glsl"
#include "sky.glsl"
#include "world_light.glsl"
#include "random.glsl"
#include "coat.glsl"

// Exact unpolarised Fresnel reflectance; eta = n_transmitted / n_incident.
float fresnel_dielectric(float cos_i, float eta) {
    float sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.0) return 1.0;  // total internal reflection
    float cos_t = sqrt(1.0 - sin2_t);
    float rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    float rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    return 0.5 * (rs * rs + rp * rp);
}

// v / |v|, or `fallback` when v is zero, tiny, infinite or NaN.
vec3 safe_normalize(vec3 v, vec3 fallback) {
    float len2 = dot(v, v);
    if (!(len2 > 1e-30) || isinf(len2) || isnan(len2)) return fallback;
    return v * inversesqrt(len2);
}

// Reflections this smooth are traced; rougher ones look the prefiltered sky up.
const float ROUGH_TRACE_LIMIT = 0.5;

float material_reflectivity(Material m) { return clamp(m.base_color_refl.a, 0.0, 1.0); }
float material_transmission(Material m) { return clamp(m.emission_trans.a, 0.0, 1.0); }
float material_roughness(Material m) { return clamp(m.params.z, 0.0, 1.0); }
#ifdef NO_COAT  // a measurement switch (benchmarks/picture_cost.py): no dielectric coat
float material_coat_f0(Material m) { return 0.0; }
#else
float material_coat_f0(Material m) { return clamp(m.params.w, 0.0, 1.0); }
#endif
float material_diffuse(Material m) {
    return max(0.0, 1.0 - material_reflectivity(m) - material_transmission(m));
}
bool material_reflection_traced(Material m) { return material_roughness(m) < ROUGH_TRACE_LIMIT; }
// Whether the tracer follows rays from this material at all.
bool material_is_specular(Material m) {
    bool reflects = material_reflectivity(m) > 0.0 || material_coat_f0(m) > 0.0;
    return material_transmission(m) > 0.0 || (reflects && material_reflection_traced(m));
}
// Whether the World's light reaches this material only through a reflection too rough to
// trace (a rough metal: no diffuse layer, no glass). No diffuse ray is gathered for it whose
// sky visibility could hide the sky from that reflection, so the traced World light
// (diffuse_light/diffuse_gather.comp.glsl, the tracer's first-bounce hits) gathers along its
// glossy lobe instead: without that, a rough metal indoors reflects the whole sky.
bool material_glossy_gathered(Material m) {
    return material_diffuse(m) <= 0.0 && material_transmission(m) <= 0.0 && !material_reflection_traced(m)
           && material_reflectivity(m) > 0.0;
}

// A microfacet normal of the GGX lobe of roughness alpha around n, seen from v (unit, towards
// the viewer): Heitz 2018's sampling of the visible normals, from two uniform numbers xi.
vec3 sample_ggx_visible_normal(vec3 n, vec3 v, float alpha, vec2 xi) {
    if (alpha < 1e-4) return n;
    vec3 t, b;
    basis_around(n, t, b);
    vec3 vl = vec3(dot(v, t), dot(v, b), max(dot(v, n), 1e-4));
    vec3 vh = normalize(vec3(alpha * vl.x, alpha * vl.y, vl.z));
    float len2 = vh.x * vh.x + vh.y * vh.y;
    vec3 t1 = len2 > 0.0 ? vec3(-vh.y, vh.x, 0.0) * inversesqrt(len2) : vec3(1.0, 0.0, 0.0);
    vec3 t2 = cross(vh, t1);
    float r = sqrt(xi.x);
    float phi = 2.0 * PI * xi.y;
    float p1 = r * cos(phi);
    float p2 = r * sin(phi);
    float s = 0.5 * (1.0 + vh.z);
    p2 = (1.0 - s) * sqrt(max(0.0, 1.0 - p1 * p1)) + s * p2;
    vec3 nh = p1 * t1 + p2 * t2 + sqrt(max(0.0, 1.0 - p1 * p1 - p2 * p2)) * vh;
    vec3 hl = normalize(vec3(alpha * nh.x, alpha * nh.y, max(nh.z, 0.0)));
    return normalize(hl.x * t + hl.y * b + hl.z * n);
}

// The specular lobes of a hit seen along `view_dir` (unit, towards the surface) with shading
// normal n (unit, as modelled) on a triangle whose plane has unit normal g (either
// orientation; vec3(0) when unknown). Returns the reflected and refracted directions and
// their weights (colour multipliers). refract_weight is zero under total internal reflection.
//
// Interpolated shading normals disagree with the tessellated surface they smooth: near a
// silhouette the mirror direction about n can point into the mesh, and the ray then finds the
// object's own inside (dark speckles on curved mirrors, worst where the mesh is coarse). Like
// production renderers (Cycles' ensure_valid_reflection) the directions are kept on their
// side of the true surface: the reflected ray leaves above the triangle's plane, the
// refracted one below it, each at least a small elevation off it; the side the ray arrives
// on, not the shading normal, says whether it enters or leaves a glass object.
struct SpecularSplit {
    vec3 reflect_dir;
    vec3 reflect_weight;
    vec3 refract_dir;
    vec3 refract_weight;
    vec3 n_facing;  // the shading normal on the viewer's side
    vec3 g_facing;  // the geometric normal on the viewer's side (n_facing when g is unknown)
    float diffuse_weight;  // the diffuse layer's share after its coat took its reflection
    vec3 glossy_local;     // weight of the reflection not traced (too rough): prefiltered sky
    vec3 glossy_dir;       // its direction (the mirror direction about the shading normal)
    vec3 lamp_f0;          // reflectance of all specular layers at normal incidence (lamps)
    float lamp_f90;        // ... and at grazing incidence
};

// d turned towards `side` (unit) until it leaves the plane at an elevation of at least
// `min_cos` (the cosine to the plane's normal); unchanged when it already does.
vec3 keep_on_side(vec3 d, vec3 side, float min_cos) {
    float c = dot(d, side);
    if (c >= min_cos) return d;
    return safe_normalize(d + side * (min_cos - c), side);
}

SpecularSplit specular_split_sampled(Material m, vec3 albedo, vec3 view_dir, vec3 n, vec3 g, vec2 xi) {
    SpecularSplit s;
    bool known = dot(g, g) > 0.5;
    // The plane normal oriented like the shading normal (outwards, as modelled).
    vec3 g_out = known ? (dot(g, n) >= 0.0 ? g : -g) : n;
    bool entering = dot(g_out, view_dir) < 0.0;
    s.n_facing = entering ? n : -n;
    s.g_facing = entering ? g_out : -g_out;
    // Cycles' threshold: 0.01, or less for a ray arriving almost along the plane.
    float min_cos = min(0.9 * max(-dot(view_dir, s.g_facing), 0.0), 0.01);
    float roughness = material_roughness(m);
    // This sample's microfacet normal (the shading normal itself when smooth).
    vec3 h = sample_ggx_visible_normal(s.n_facing, -view_dir, roughness * roughness, xi);
    s.reflect_dir = reflect(view_dir, h);
    if (dot(s.reflect_dir, s.n_facing) <= 0.0) s.reflect_dir = reflect(view_dir, s.n_facing);
    if (known) s.reflect_dir = keep_on_side(s.reflect_dir, s.g_facing, min_cos);
    s.glossy_dir = reflect(view_dir, s.n_facing);
    float reflectivity = material_reflectivity(m);
    float transmission = material_transmission(m);
    float cos_v = clamp(-dot(view_dir, s.n_facing), 0.0, 1.0);
    float f0 = material_coat_f0(m);
    float coat = coat_reflectance(f0, cos_v, roughness);
    float diffuse = material_diffuse(m);
    s.diffuse_weight = diffuse * (1.0 - coat);
    vec3 reflection = reflectivity * albedo + vec3(diffuse * coat);
    s.lamp_f0 = reflectivity * albedo + vec3(diffuse * f0);
    s.lamp_f90 = reflectivity + (f0 > 0.0 ? diffuse : 0.0);
    bool traced = material_reflection_traced(m);
    s.reflect_weight = traced ? reflection : vec3(0.0);
    s.glossy_local = traced ? vec3(0.0) : reflection;
    s.refract_weight = vec3(0.0);
    s.refract_dir = view_dir;
    if (transmission > 0.0) {
        float ior = max(m.params.x, 1.0);
        float eta = entering ? ior : 1.0 / ior;
        float cos_i = clamp(-dot(view_dir, h), 0.0, 1.0);
        float f = fresnel_dielectric(cos_i, eta);
        vec3 refracted = refract(view_dir, h, 1.0 / eta);
        s.reflect_weight += vec3(transmission * f);
        // Lamps light glass from outside only: inside it, its own surface hides them (a
        // shadow map cannot tell, its depth bias lifts the point off that very surface).
        if (entering) {
            float f_normal = (ior - 1.0) / (ior + 1.0);
            s.lamp_f0 += vec3(transmission * f_normal * f_normal);
            s.lamp_f90 += transmission;
        }
        if (f < 1.0 && dot(refracted, refracted) > 0.0) {
            s.refract_dir = normalize(refracted);
            if (known) s.refract_dir = keep_on_side(s.refract_dir, -s.g_facing, min_cos);
            s.refract_weight = transmission * (1.0 - f) * albedo;
        }
    }
    return s;
}

// The smooth (unsampled) split: the mirror and refraction directions about the shading normal.
SpecularSplit specular_split_geometric(Material m, vec3 albedo, vec3 view_dir, vec3 n, vec3 g) {
    return specular_split_sampled(m, albedo, view_dir, n, g, vec2(0.0));
}

// What a surface takes from the World's sky: the diffuse layer lit by `world_irradiance`
// (the sky's irradiance times its visibility, or what the sky rays gathered) and the
// reflections too rough to trace (the prefiltered sky, times `sky_visibility`, the share of
// the sky the point sees; 1 where unknown). Linear in both, so a caller that learns the
// visibility later (the tracer's occlusion rays) can weight this part alone.
vec3 world_light_response(Material m, vec3 albedo, SpecularSplit split, vec3 world_irradiance,
                          float sky_visibility) {
    vec3 color = vec3(0.0);
#ifdef NO_WORLD_LIGHT  // a measurement switch (benchmarks/picture_cost.py): no World light
    return color;
#endif
    if (split.diffuse_weight > 0.0) {
        color += split.diffuse_weight * albedo / PI * world_irradiance;
    }
    if (max(max(split.glossy_local.r, split.glossy_local.g), split.glossy_local.b) > 0.0) {
        color += split.glossy_local * sky_radiance_rough(split.glossy_dir, material_roughness(m)) * sky_visibility;
    }
    return color;
}

// A surface's emission and the light its lamps give it: the diffuse layer lit through
// the shadow maps and the lamps' glossy highlights on every specular layer.
// `highlight_blur` is a roughness the highlights take at least (that of the lobes the
// point is seen through).
vec3 lamp_light_response(Material m, vec3 albedo, vec3 emission, vec3 p, vec3 view_dir, SpecularSplit split,
                         float highlight_blur) {
    vec3 color = emission;
    vec3 n = split.n_facing;
    float highlight_roughness = max(material_roughness(m), highlight_blur);
    DirectLight direct = direct_lighting(p, n, -view_dir, split.lamp_f0, split.lamp_f90, highlight_roughness,
                                         split.diffuse_weight > 0.0, material_light_set(m));  // light linking
    if (split.diffuse_weight > 0.0) {
        color += split.diffuse_weight * albedo / PI * direct.irradiance;
    }
    return color + direct.glossy;
}

// Everything of a surface that is not a secondary ray: emission, the diffuse layer lit by the
// lamps and the World, the lamps' glossy highlights on every specular layer, and the
// reflections too rough to trace (prefiltered sky). `view_dir` points at the surface; `split`
// is its specular_split; `world_irradiance`, `sky_visibility` as world_light_response,
// `highlight_blur` as lamp_light_response. `albedo` and `emission` are the material's
// colours with its image textures applied (textures.glsl).
vec3 shade_surface(Material m, vec3 albedo, vec3 emission, vec3 p, vec3 view_dir, SpecularSplit split,
                   vec3 world_irradiance, float sky_visibility, float highlight_blur) {
    return lamp_light_response(m, albedo, emission, p, view_dir, split, highlight_blur)
           + world_light_response(m, albedo, split, world_irradiance, sky_visibility);
}
