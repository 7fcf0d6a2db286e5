// Exclusive prefix sum of n uints in place, total appended at data[n] (stream compaction of the
// near-cube culler: per-chunk kept counts -> output offsets).
//
// Work-efficient (each element read and written once per phase, O(n) in all): one workgroup of
// LOCAL_SIZE invocations; invocation k sums a contiguous block, the block sums are scanned in
// shared memory, then each block is rewritten with its running offset. n is the number of
// chunks (a few thousand at most), so one group is enough and avoids a multi-level scan.
//
// Host defines: LOCAL_SIZE.
// Storage block Data (read/write: uint[n + 1]).
// Uniforms: u_count (n).
layout(local_size_x = LOCAL_SIZE) in;

layout(std430) buffer Data {
    uint data[];
};

uniform uint u_count;

shared uint block_offset[LOCAL_SIZE];

void main() {
    uint lane = gl_LocalInvocationID.x;
    uint per_lane = (u_count + uint(LOCAL_SIZE) - 1u) / uint(LOCAL_SIZE);
    uint begin = min(lane * per_lane, u_count);
    uint end = min(begin + per_lane, u_count);
    uint sum = 0u;
    for (uint i = begin; i < end; ++i) {
        sum += data[i];
    }
    block_offset[lane] = sum;
    barrier();
    if (lane == 0u) {
        uint running = 0u;
        for (uint k = 0u; k < uint(LOCAL_SIZE); ++k) {
            uint value = block_offset[k];
            block_offset[k] = running;
            running += value;
        }
        data[u_count] = running;
    }
    barrier();
    uint running = block_offset[lane];
    for (uint i = begin; i < end; ++i) {
        uint value = data[i];
        data[i] = running;
        running += value;
    }
}
