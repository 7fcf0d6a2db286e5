// SPDX-License-Identifier: GPL-3.0-or-later
// Light and shadow linking of emissive objects (hybrid_engine/passes/emitters/emitter_links.py):
// an emitter lights only the receiver sets of its light mask and is shadowed only by the
// blocker sets of its shadow mask, as Cycles links its mesh lights. The masks are per
// material row (the adapter gives a linked object its own rows), so a sampled triangle finds
// them from the material it already reads.
//
// Compiled only under #define EMITTER_LINKING. Needs the Material array `materials`
// (scene_layout.glsl) declared before it. Storage block EmitterLinks: uvec4 per material row,
// xy its light mask (low, high word), zw its shadow mask.
#ifdef EMITTER_LINKING
#ifndef HYBRID_EMITTER_LINKS_GLSL
#define HYBRID_EMITTER_LINKS_GLSL

layout(std430) readonly buffer EmitterLinks { uvec4 emitter_links[]; };

bool link_mask_holds(uvec2 mask, int set) {
    uint word = set < 32 ? mask.x : mask.y;
    return ((word >> uint(set & 31)) & 1u) != 0u;
}

// Whether the emission of material row `emitter` lights the surfaces of receiver set `set`.
bool emission_lights_set(int emitter, int set) {
    return link_mask_holds(emitter_links[emitter].xy, set);
}

// The receiver set of the surfaces of material row `m` (params2.z, light_linking.py).
int row_light_set(int m) {
    return int(materials[m].params2.z + 0.5);
}

#endif  // HYBRID_EMITTER_LINKS_GLSL
#endif  // EMITTER_LINKING
