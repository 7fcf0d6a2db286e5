// SPDX-License-Identifier: GPL-3.0-or-later
// The surface model shared by the deferred shading of G-buffers (primary camera and cube-map
// faces, paper §3.5) and by the hybrid tracer's hits in the BVH (§3.4), so that a surface
// looks the same whichever structure found it.
//
// A material (scene_layout.glsl) splits into three lobes whose weights sum to 1:
//   mirror  = reflectivity            perfect reflection tinted by the base colour
//   glass   = transmission            clear dielectric of index IOR: Fresnel-weighted mix of
//                                     the reflected ray and the refracted ray (tinted)
//   diffuse = 1 - mirror - glass      Lambertian, lit directly (lighting.glsl, shadow maps)
// plus emission. The local part (emission + diffuse) is `shade_local`; the two specular
// lobes become secondary rays with the weights of `specular_split`.
#include "scene_layout.glsl"
#include "lighting.glsl"

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

float material_reflectivity(Material m) { return clamp(m.base_color_refl.a, 0.0, 1.0); }
float material_transmission(Material m) { return clamp(m.emission_trans.a, 0.0, 1.0); }
float material_diffuse(Material m) {
    return max(0.0, 1.0 - material_reflectivity(m) - material_transmission(m));
}
bool material_is_specular(Material m) {
    return material_reflectivity(m) > 0.0 || material_transmission(m) > 0.0;
}

// Emission plus the diffuse lobe lit by all lights (with shadow maps) at p, n_facing being
// the shading normal turned towards the viewer (two-sided shading, like Blender). `albedo`
// and `emission` are the material's colours with its image textures applied (textures.glsl).
vec3 shade_local_emission(Material m, vec3 albedo, vec3 emission, vec3 p, vec3 n_facing) {
    vec3 color = emission;
    float diffuse_weight = material_diffuse(m);
    if (diffuse_weight > 0.0) {
        color += diffuse_weight * albedo / PI * direct_irradiance(p, n_facing);
    }
    return color;
}

// The same for an untextured emission.
vec3 shade_local(Material m, vec3 albedo, vec3 p, vec3 n_facing) {
    return shade_local_emission(m, albedo, m.emission_trans.rgb, p, n_facing);
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
};

// d turned towards `side` (unit) until it leaves the plane at an elevation of at least
// `min_cos` (the cosine to the plane's normal); unchanged when it already does.
vec3 keep_on_side(vec3 d, vec3 side, float min_cos) {
    float c = dot(d, side);
    if (c >= min_cos) return d;
    return safe_normalize(d + side * (min_cos - c), side);
}

SpecularSplit specular_split_geometric(Material m, vec3 albedo, vec3 view_dir, vec3 n, vec3 g) {
    SpecularSplit s;
    bool known = dot(g, g) > 0.5;
    // The plane normal oriented like the shading normal (outwards, as modelled).
    vec3 g_out = known ? (dot(g, n) >= 0.0 ? g : -g) : n;
    bool entering = dot(g_out, view_dir) < 0.0;
    s.n_facing = entering ? n : -n;
    s.g_facing = entering ? g_out : -g_out;
    // Cycles' threshold: 0.01, or less for a ray arriving almost along the plane.
    float min_cos = min(0.9 * max(-dot(view_dir, s.g_facing), 0.0), 0.01);
    s.reflect_dir = reflect(view_dir, s.n_facing);
    if (known) s.reflect_dir = keep_on_side(s.reflect_dir, s.g_facing, min_cos);
    float reflectivity = material_reflectivity(m);
    float transmission = material_transmission(m);
    s.reflect_weight = reflectivity * albedo;
    s.refract_weight = vec3(0.0);
    s.refract_dir = view_dir;
    if (transmission > 0.0) {
        float ior = max(m.params.x, 1.0);
        float eta = entering ? ior : 1.0 / ior;
        float cos_i = clamp(-dot(view_dir, s.n_facing), 0.0, 1.0);
        float f = fresnel_dielectric(cos_i, eta);
        vec3 refracted = refract(view_dir, s.n_facing, 1.0 / eta);
        s.reflect_weight += vec3(transmission * f);
        if (f < 1.0 && dot(refracted, refracted) > 0.0) {
            s.refract_dir = normalize(refracted);
            if (known) s.refract_dir = keep_on_side(s.refract_dir, -s.g_facing, min_cos);
            s.refract_weight = transmission * (1.0 - f) * albedo;
        }
    }
    return s;
}

// The same where only the shading normal is known.
SpecularSplit specular_split(Material m, vec3 albedo, vec3 view_dir, vec3 n) {
    return specular_split_geometric(m, albedo, view_dir, n, vec3(0.0));
}
