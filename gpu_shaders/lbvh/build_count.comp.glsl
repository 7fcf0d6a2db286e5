// LBVH pass 0: the build's element count from where an earlier pass left it on the GPU (the
// near-cube cull's kept count, paper §3.3), and the indirect dispatch arguments of the
// hierarchy (max(N - 1, 1) invocations) and refit (N invocations) passes, so that no host
// read sits between the cull and the build.
//
// The count is clamped to the capacity the host sized the build's buffers for. The cull's
// count never exceeds it (the capacity is the number of elements it tested), so the clamp
// only guards the buffers.
//
// Host defines: LOCAL_SIZE (of the hierarchy and refit passes).
// Storage blocks: SourceCount (read: uint words), BuildCountOut (write: uint[7]: the count,
//   then (x, y, 1) groups of the hierarchy and (x, y, 1) of the refit, split over x and y as
//   hybrid_engine/gpu/dispatch.py grid_for does).
// Uniforms: u_source_at (index of the count in SourceCount), u_capacity, u_max_groups_x.
layout(local_size_x = 1) in;

layout(std430) readonly buffer SourceCount {
    uint source_words[];
};
layout(std430) writeonly buffer BuildCountOut {
    uint out_words[7];
};

uniform uint u_source_at;
uniform uint u_capacity;
uniform uint u_max_groups_x;

uvec2 grid(uint invocations) {
    uint groups = (invocations + uint(LOCAL_SIZE) - 1u) / uint(LOCAL_SIZE);
    if (groups == 0u) {
        return uvec2(0u, 1u);
    }
    uint x = min(groups, u_max_groups_x);
    return uvec2(x, (groups + x - 1u) / x);
}

void main() {
    uint count = min(source_words[u_source_at], u_capacity);
    uvec2 hierarchy = grid(max(count, 2u) - 1u);
    uvec2 refit = grid(count);
    out_words[0] = count;
    out_words[1] = hierarchy.x;
    out_words[2] = hierarchy.y;
    out_words[3] = 1u;
    out_words[4] = refit.x;
    out_words[5] = refit.y;
    out_words[6] = 1u;
}
