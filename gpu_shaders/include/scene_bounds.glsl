// SPDX-License-Identifier: GPL-3.0-or-later
// The bounds of all geometry and where a ray leaves them: the tracer's rays
// (trace_ray.glsl) and the lit cube map's gather rays (cube_light/cube_light_gather.comp.glsl)
// stop their cube-map march there. scene_exit exists where cube_march.glsl (the map's
// centre and its hit overshoot) was included first; box_interval everywhere.
#ifndef HYBRID_SCENE_BOUNDS_GLSL
#define HYBRID_SCENE_BOUNDS_GLSL

uniform int u_scene_bounded; // 1: u_scene_lo/hi bound all geometry (padded); 0: empty scene
uniform vec3 u_scene_lo;
uniform vec3 u_scene_hi;

// The part of a spawned ray's offset off its surface that does not grow with the position's
// magnitude: a share of the scene's size (the diagonal of its padded bounds), so that a scene
// modelled in millimetres keeps its rays off their surfaces in the same proportion as one in
// kilometres; `unbounded` where the scene has no finite geometry.
#define SCENE_OFFSET_SHARE 5e-6
float scene_offset_absolute(float unbounded) {
    return u_scene_bounded != 0 ? SCENE_OFFSET_SHARE * distance(u_scene_lo, u_scene_hi) : unbounded;
}

// [enter, exit] of the ray with the box [lo, hi]; enter > exit: no overlap.
vec2 box_interval(vec3 o, vec3 d, vec3 lo, vec3 hi) {
    vec3 safe = mix(d, vec3(1e-30), lessThan(abs(d), vec3(1e-30)));
    vec3 inv = 1.0 / safe;
    vec3 t0 = (lo - o) * inv;
    vec3 t1 = (hi - o) * inv;
    vec3 tn = min(t0, t1);
    vec3 tf = max(t0, t1);
    return vec2(max(max(tn.x, tn.y), tn.z), min(min(tf.x, tf.y), tf.z));
}

#ifdef CUBE_NO_LIMIT
// Where the ray leaves the bounds of all geometry (-1: it misses them; CUBE_NO_LIMIT: no
// bounds). Past them neither the BVH nor the cube map holds anything to hit, so the march
// stops there instead of walking the faces on to their far planes. The march takes a hit a
// little behind its surface (the depth bias), so the bounds grow away from the map's centre
// by that much (cube_max_hit_overshoot); a ray behind a thick object past them meets a
// stretch of it, not the object itself.
float scene_exit(vec3 o, vec3 d) {
    if (u_scene_bounded == 0) return CUBE_NO_LIMIT;
    float grow = 1.0 + cube_max_hit_overshoot();
    vec3 lo = u_scene_lo - u_cube_center;
    vec3 hi = u_scene_hi - u_cube_center;
    vec2 span = box_interval(o, d, u_cube_center + min(lo, lo * grow), u_cube_center + max(hi, hi * grow));
    return span.y < max(span.x, 0.0) ? -1.0 : span.y;
}

#endif  // CUBE_NO_LIMIT
#endif  // HYBRID_SCENE_BOUNDS_GLSL
