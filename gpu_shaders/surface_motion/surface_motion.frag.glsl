// SPDX-License-Identifier: GPL-3.0-or-later
// Surface motion, fragment stage: the moved instance's entry + 1 where the fragment is the
// surface the primary G-buffer shows, nothing where it lies behind it. The same matrix
// draws the same rows, so the surface's own fragment lands on the stored depth up to
// rounding: the tolerance is a few units in the last place, and a twentieth of the depth's
// slope across the pixel for a rounding of the vertices (the instanced raster transforms
// them in its own shader). A whole pixel's slope would let a face seen nearly edge-on pass
// behind whatever hides it. The G-buffer's depth is read, not tested against, so no depth
// target is needed.
flat in int v_entry;

uniform sampler2D u_depth;

layout(location = 0) out float out_entry;

void main() {
    float slope = fwidth(gl_FragCoord.z);  // before the discard: derivatives need every lane
    float stored = texelFetch(u_depth, ivec2(gl_FragCoord.xy), 0).r;
    if (v_entry < 0 || abs(gl_FragCoord.z - stored) > 1e-6 + 0.05 * slope) discard;
    out_entry = float(v_entry + 1);
}
