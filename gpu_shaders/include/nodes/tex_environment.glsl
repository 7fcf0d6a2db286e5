// SPDX-License-Identifier: GPL-3.0-or-later
// Environment Texture's projections: a direction to the image's (u, v), as Blender maps an
// environment image onto the sphere of directions.
//   projection 0 (EQUIRECTANGULAR): longitude and latitude, u = 0.5 - atan2(y, x) / 2 pi,
//     v = 0.5 + atan2(z, hypot(x, y)) / pi (hybrid_engine/scene/data.py Sky);
//   projection 1 (MIRROR_BALL): a photograph of a mirror sphere seen along +Y: the direction
//     is reflected at the sphere's normal n = normalize(dir - (0, 1, 0)), which lies at
//     u = (n.x + 1) / 2, v = (n.z + 1) / 2 of the picture.
// The direction need not be unit length (a Mapping or a Texture Coordinate may scale it).
#ifndef HYBRID_NODE_TEX_ENVIRONMENT_GLSL
#define HYBRID_NODE_TEX_ENVIRONMENT_GLSL

vec2 node_environment_uv(vec3 dir, int projection) {
    float len2 = dot(dir, dir);
    vec3 d = len2 > 0.0 ? dir * inversesqrt(len2) : vec3(0.0, 0.0, 1.0);
    if (projection == 1) {
        vec3 n = d - vec3(0.0, 1.0, 0.0);
        float l2 = dot(n, n);
        n = l2 > 0.0 ? n * inversesqrt(l2) : vec3(0.0, -1.0, 0.0);
        return vec2(0.5 * (n.x + 1.0), 0.5 * (n.z + 1.0));
    }
    const float pi = 3.14159265358979;
    return vec2(0.5 - atan(d.y, d.x) / (2.0 * pi), 0.5 + atan(d.z, length(d.xy)) / pi);
}

#endif
