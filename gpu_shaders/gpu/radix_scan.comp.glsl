// Radix sort, step 2 of 3 per digit: exclusive prefix sum of the chunk histograms into
// scatter offsets (work-efficient: every counter is read and written twice, O(n) in all).
//
// offset(t, d) = sum over digits d' < d of total(d')  +  sum over chunks t' < t of count(t', d)
// which is what makes the sort stable: chunk order, then order inside a chunk.
//
// One workgroup of RADIX invocations: invocation d scans column d over all chunks (its
// lanes read neighbouring counters), the digit totals are scanned in shared memory, then each
// column gets its digit base added.
//
// Host defines: RADIX_BITS, RADIX (= 1 << RADIX_BITS invocations; 256 for 8-bit digits; a
//   literal because GLSL 4.30 layouts take no constant expressions).
// Storage block Histograms (read/write: counts in, offsets out, chunk-major as radix_count).
// Uniforms: u_num_chunks.
layout(local_size_x = RADIX) in;

layout(std430) buffer Histograms {
    uint histograms[];
};

uniform uint u_num_chunks;

shared uint digit_total[RADIX];

void main() {
    uint digit = gl_LocalInvocationID.x;
    const uint radix = uint(RADIX);
    // Column scan: exclusive prefix over the chunks, per digit.
    uint running = 0u;
    for (uint t = 0u; t < u_num_chunks; ++t) {
        uint index = t * radix + digit;
        uint count = histograms[index];
        histograms[index] = running;
        running += count;
    }
    digit_total[digit] = running;
    barrier();
    // Exclusive scan of the RADIX digit totals: one invocation, RADIX additions, cheaper than
    // log2(RADIX) barrier rounds on a CPU driver.
    if (digit == 0u) {
        uint base = 0u;
        for (uint d = 0u; d < radix; ++d) {
            uint total = digit_total[d];
            digit_total[d] = base;
            base += total;
        }
    }
    barrier();
    uint base = digit_total[digit];
    for (uint t = 0u; t < u_num_chunks; ++t) {
        histograms[t * radix + digit] += base;
    }
}
