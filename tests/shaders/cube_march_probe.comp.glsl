// SPDX-License-Identifier: GPL-3.0-or-later
// One cube-map march per ray, results written out: the window through which tests compare
// include/cube_march.glsl (paper §3.4) with an independent numpy march
// (tests/cube_march_reference.py). The tracer calls the same cube_march().
//
// Host defines: LOCAL_SIZE.
// Storage blocks: MaterialBuffer (read; thickness in params.y), Rays (read: vec4 origin with
//   w = t_start, vec4 direction, per ray), Results (write: ivec4 (kind, face, texel.x,
//   texel.y), ivec4 (switches, material, steps, 0), vec4 (position, t), vec4 (normal, 0) per ray).
// Uniforms: u_count (rays), and those of cube_march.glsl.
#include "scene_layout.glsl"
#include "dispatch.glsl"

layout(local_size_x = LOCAL_SIZE) in;

layout(std430) readonly buffer MaterialBuffer { Material materials[]; };

#include "cube_march.glsl"

layout(std430) readonly buffer Rays { vec4 rays[]; };
layout(std430) writeonly buffer Results { vec4 results[]; };

uniform uint u_count;

void main() {
    uint i = flat_invocation_index();
    if (i >= u_count) return;
    vec4 origin = rays[2u * i];
    vec3 dir = normalize(rays[2u * i + 1u].xyz);
    CubeMarch cm = cube_march(origin.xyz, dir, origin.w);
    results[4u * i] = intBitsToFloat(ivec4(cm.kind, cm.face, cm.texel));
    results[4u * i + 1u] = intBitsToFloat(ivec4(cm.switches, cm.material, int(cube_march_steps), 0));
    results[4u * i + 2u] = vec4(cm.position, cm.t);
    results[4u * i + 3u] = vec4(cm.normal, 0.0);
}
