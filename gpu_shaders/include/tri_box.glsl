// Exact triangle/box overlap by the separating axis theorem (Akenine-Moeller, "Fast 3D
// Triangle-Box Overlap Testing", JGT 6(1), 2001): 13 candidate axes -- the 3 box normals, the
// triangle normal and the 9 cross products of box axes with triangle edges. The near-cube
// culler (paper §3.3) uses it for triangles of objects that straddle the cube, so that a
// triangle crossing the cube with all vertices (and its centroid) outside is still kept.
//
// A triangle with a non-finite coordinate never overlaps (it could not be traced anyway).
#ifndef HYBRID_TRI_BOX_GLSL
#define HYBRID_TRI_BOX_GLSL

#include "float_order.glsl"

// Project the triangle (p0, p1, p2, already relative to the box centre) and the box on an
// axis; true when the projections are disjoint (the axis separates them).
bool tri_box_separated(vec3 axis, vec3 p0, vec3 p1, vec3 p2, vec3 half_size) {
    float d0 = dot(p0, axis);
    float d1 = dot(p1, axis);
    float d2 = dot(p2, axis);
    float radius = dot(half_size, abs(axis));
    return min(d0, min(d1, d2)) > radius || max(d0, max(d1, d2)) < -radius;
}

bool tri_box_overlap(vec3 v0, vec3 v1, vec3 v2, vec3 center, vec3 half_size) {
    if (!(all_finite(v0) && all_finite(v1) && all_finite(v2))) {
        return false;
    }
    vec3 p0 = v0 - center;
    vec3 p1 = v1 - center;
    vec3 p2 = v2 - center;
    // Box normals: the triangle's bounding box against the box.
    vec3 lo = min(p0, min(p1, p2));
    vec3 hi = max(p0, max(p1, p2));
    if (any(greaterThan(lo, half_size)) || any(lessThan(hi, -half_size))) {
        return false;
    }
    vec3 e0 = p1 - p0;
    vec3 e1 = p2 - p1;
    vec3 e2 = p0 - p2;
    // Triangle normal.
    if (tri_box_separated(cross(e0, e1), p0, p1, p2, half_size)) {
        return false;
    }
    // Box axis x edge: a zero cross product (edge parallel to the axis) projects everything
    // to 0 and never separates, which is the correct answer for that axis.
    vec3 edges[3] = vec3[3](e0, e1, e2);
    for (int k = 0; k < 3; ++k) {
        vec3 e = edges[k];
        if (tri_box_separated(vec3(0.0, -e.z, e.y), p0, p1, p2, half_size)
            || tri_box_separated(vec3(e.z, 0.0, -e.x), p0, p1, p2, half_size)
            || tri_box_separated(vec3(-e.y, e.x, 0.0), p0, p1, p2, half_size)) {
            return false;
        }
    }
    return true;
}

#endif
