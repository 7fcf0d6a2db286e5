// SPDX-License-Identifier: GPL-3.0-or-later
// Surface motion, fragment stage: where the fragment is the surface the primary G-buffer
// shows, the surface's point of last frame and the moved instance's entry + 1, and the
// rotation that takes the surface's normal now to its normal then (a quaternion: the
// G-buffer's normal, with its normal map, turns as the interpolated normal turned);
// nothing where the fragment lies behind the stored surface. The same matrix draws the same
// rows, so the surface's own fragment lands on the stored depth up to rounding: the
// tolerance is a few units in the last place, and a twentieth of the depth's slope across
// the pixel for a rounding of the vertices (the instanced raster transforms them in its own
// shader). A whole pixel's slope would let a face seen nearly edge-on pass behind whatever
// hides it. The G-buffer's depth is read, not tested against, so no depth target is needed.
flat in int v_entry;
in vec3 v_previous;
in vec3 v_normal;
in vec3 v_previous_normal;

uniform sampler2D u_depth;

layout(location = 0) out vec4 out_previous;
layout(location = 1) out vec4 out_turn;

// The shortest rotation taking unit vector a to unit vector b, as a quaternion (xyz, w);
// opposite vectors (no shortest one) keep the normal as it is.
vec4 turn_between(vec3 a, vec3 b) {
    float w = 1.0 + dot(a, b);
    if (!(w > 1e-6)) return vec4(0.0, 0.0, 0.0, 1.0);
    return normalize(vec4(cross(a, b), w));
}

void main() {
    float slope = fwidth(gl_FragCoord.z);  // before the discard: derivatives need every lane
    float stored = texelFetch(u_depth, ivec2(gl_FragCoord.xy), 0).r;
    if (v_entry < 0 || abs(gl_FragCoord.z - stored) > 1e-6 + 0.05 * slope) discard;
    out_previous = vec4(v_previous, float(v_entry + 1));
    out_turn = turn_between(normalize(v_normal), normalize(v_previous_normal));
}
