// SPDX-License-Identifier: GPL-3.0-or-later
// The emitter table's rows (hybrid_engine/passes/emitters/emitter_table.py EMITTER_DTYPE):
// one per emissive triangle, written every frame by emitters/emitter_power.comp.glsl from the
// world-space triangle, read by emitter_light.glsl to sample a point on it.
#ifndef HYBRID_EMITTER_LAYOUT_GLSL
#define HYBRID_EMITTER_LAYOUT_GLSL

// struct Emitter                                            // total: 48 bytes
//   vec4 corner;  xyz = world corner 0, w = the triangle's world row (int bits): its
//                 material (TriangleMaterials) and UVs (TriangleUVBuffer) are read there
//   vec4 edge1;   xyz = corner 1 - corner 0, w = area (m^2)
//   vec4 edge2;   xyz = corner 2 - corner 0, w = power: area x luminance of the material's
//                 constant emission (the texture's factor only: textures are evaluated at
//                 the sampled point, not here)
struct Emitter {
    vec4 corner;
    vec4 edge1;
    vec4 edge2;
};

// Rec. 709 luminance, as Blender's colour-to-value conversion (textures.glsl).
float emitter_luminance(vec3 rgb) { return dot(rgb, vec3(0.2126, 0.7152, 0.0722)); }

#endif
