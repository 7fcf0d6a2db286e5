// The element count of one LBVH build, read on the GPU (paper §3.3: the BVH is rebuilt every
// frame over what the near-cube cull kept). The cull leaves its kept count in GPU memory; the
// host records the build sized by an upper bound (the capacity: the cull's candidates) and
// never waits to learn the count. lbvh/build_count.comp.glsl (or the host, when it knows the
// count) writes the BuildCount block: the count, then the indirect dispatch arguments of the
// hierarchy and refit passes.
//
// Storage block: BuildCount (read: uint words; word 0 is the count).
#ifndef HYBRID_BUILD_COUNT_GLSL
#define HYBRID_BUILD_COUNT_GLSL

layout(std430) readonly buffer BuildCount {
    uint build_count_words[];
};

uint build_count() {
    return build_count_words[0];
}

#endif
