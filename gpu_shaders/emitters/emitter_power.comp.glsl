// SPDX-License-Identifier: GPL-3.0-or-later
// The emitter table's rows, every frame (hybrid_engine/passes/emitters/emitter_table.py):
// invocation i reads emissive triangle tri_index[i] (a world row the host listed when the
// materials or the triangle set changed) from the instance transform's world-space output,
// and writes its corner, edges, area and power (area x luminance of the material's constant
// emission) into emitters[i]; the largest power goes to EmitterMax (positive floats order as
// their bits), which the weights kernel quantises against. So moving objects move their
// lights without any host work.
//
// Host defines: LOCAL_SIZE, TRI_INPUT_BLOCKS, TRI_INPUT_BLOCK_SIZE (triangle_input.glsl:
//   a split input).
// Storage blocks: TriangleInput (the world positions), TriangleIndex (the emissive rows),
//   TriangleMaterials (int per world row), MaterialBuffer (read); EmitterTriangles (written),
//   EmitterMax (uint, atomic max of the power's bits; zeroed by the host).
// Uniforms: u_count (emitters), u_use_indices (1).
#include "dispatch.glsl"
#include "scene_layout.glsl"
#include "triangle_input.glsl"
#include "emitter_layout.glsl"

layout(local_size_x = LOCAL_SIZE) in;

layout(std430) readonly buffer MaterialBuffer { Material materials[]; };
layout(std430) readonly buffer TriangleMaterials { int tri_materials[]; };
layout(std430) writeonly buffer EmitterTriangles { Emitter emitters[]; };
layout(std430) buffer EmitterMax { uint emitter_max_bits; };

uniform uint u_count;

void main() {
    uint i = flat_invocation_index();
    if (i >= u_count) return;
    uint tri = input_triangle(i);
    vec3 v0 = input_vertex(tri, 0u);
    vec3 e1 = input_vertex(tri, 1u) - v0;
    vec3 e2 = input_vertex(tri, 2u) - v0;
    float area = 0.5 * length(cross(e1, e2));
    float power = area * emitter_luminance(max(materials[tri_materials[tri]].emission_trans.rgb, vec3(0.0)));
    // A collapsed (non-finite) triangle or a non-finite emission is no light.
    if (!(power > 0.0) || isinf(power) || isinf(area)) power = 0.0;
    emitters[i] = Emitter(vec4(v0, intBitsToFloat(int(tri))), vec4(e1, area), vec4(e2, power));
    // Atomics on one word serialise the invocations (on a CPU driver they cost more than the
    // rest of the kernel): only a power above the largest seen so far takes one. A stale
    // read only costs an atomic that changes nothing.
    uint bits = floatBitsToUint(power);
    if (power > 0.0 && bits > emitter_max_bits) atomicMax(emitter_max_bits, bits);
}
