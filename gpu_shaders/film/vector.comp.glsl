// SPDX-License-Identifier: GPL-3.0-or-later
// Cycles' Vector pass over a view's samples (passes/film/vector.py): this sample's vectors
// and hits are added into the sums (u_restart: the view's first sample starts them), and
// the pass as Cycles' film delivers it is written: the vectors' sum over the count of
// samples that hit (0 where none did: the background).
layout(local_size_x = 8, local_size_y = 8) in;

uniform sampler2D u_sample_vector;  // vector.frag.glsl, location 0
uniform sampler2D u_sample_hit;     // ... location 1
layout(rgba32f) uniform image2D u_sums;
layout(r32f) uniform image2D u_hits;
layout(rgba32f) writeonly uniform image2D u_vector_pass;
uniform ivec2 u_size;
uniform int u_restart;

void main() {
    ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(texel, u_size))) return;
    float hit = texelFetch(u_sample_hit, texel, 0).r;
    vec4 value = hit > 0.0 ? texelFetch(u_sample_vector, texel, 0) : vec4(0.0);
    vec4 sums = value;
    float hits = hit;
    if (u_restart == 0) {
        sums += imageLoad(u_sums, texel);
        hits += imageLoad(u_hits, texel).r;
    }
    imageStore(u_sums, texel, sums);
    imageStore(u_hits, texel, vec4(hits));
    imageStore(u_vector_pass, texel, hits > 0.0 ? sums / hits : vec4(0.0));
}
