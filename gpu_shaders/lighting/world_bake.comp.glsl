// SPDX-License-Identifier: GPL-3.0-or-later
// The World's node graph baked into the equirectangular environment: one invocation per
// texel runs the graph's program (include/node_program.glsl) for the direction at the
// texel's centre, as Cycles shades the background: a direction-only shading point (its
// position, Generated and Object coordinates are the direction, its normal and Incoming
// face back along it), the Background closure's emission the radiance. Everything that
// reads the sky (sky.glsl: escaping rays, the irradiance, the prefiltered levels) reads
// the result. Runs only when the World changes (hybrid_engine/passes/lighting/world_bake.py).
//
// Storage blocks NodeProgram (the World's words), NodeObjects (a header row with no
// instances); samplers u_world_images, u_textures (unused); image u_target (written).
#define NODE_PROGRAMS 1
#define NODE_WORLD 1
#include "scene_layout.glsl"
#include "node_program.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f) uniform writeonly image2D u_target;

void main() {
    ivec2 size = imageSize(u_target);
    ivec2 at = ivec2(gl_GlobalInvocationID.xy);
    if (at.x >= size.x || at.y >= size.y) return;
    vec2 uv = (vec2(at) + 0.5) / vec2(size);
    float phi = (0.5 - uv.x) * 2.0 * PI;  // inverse of sky.glsl equirect_uv (row 0 = bottom)
    float lat = (uv.y - 0.5) * PI;
    vec3 dir = vec3(cos(lat) * cos(phi), cos(lat) * sin(phi), sin(lat));

    ShadingPoint sp = node_plain_point(dir, -dir, -dir, -dir, vec2(0.0), 0.0, 0, -1, 0);
    NodeClosure c = node_program_run(0, sp);
    imageStore(u_target, at, vec4(c.emission, 1.0));
}
