// SPDX-License-Identifier: GPL-3.0-or-later
// Exclusive prefix sum across the LOCAL_SIZE invocations of one workgroup, in shared memory.
//
//   WORKGROUP_SCAN_TYPE workgroup_exclusive_scan(WORKGROUP_SCAN_TYPE value,
//                                                out WORKGROUP_SCAN_TYPE total)
//
// Every invocation of the group must call it (it holds barriers, so it belongs in uniform
// control flow); it returns the sum of the values of the lower lanes and gives the group's sum
// in ``total``. Hillis-Steele steps (log2(LOCAL_SIZE) of them): on a GPU the group's lanes run
// in lock step and a step costs one shared read and write, cheaper than the twice as many
// barriers of the work-efficient tree for 256 values. WORKGROUP_SCAN_TYPE (default uint) may be
// a uvec2/uvec4 of packed counters that cannot overflow into each other.
// Needs LOCAL_SIZE (the x workgroup size) defined by the host.
#ifndef HYBRID_WORKGROUP_SCAN_GLSL
#define HYBRID_WORKGROUP_SCAN_GLSL

#ifndef WORKGROUP_SCAN_TYPE
#define WORKGROUP_SCAN_TYPE uint
#endif

shared WORKGROUP_SCAN_TYPE workgroup_scan_cells[LOCAL_SIZE];

WORKGROUP_SCAN_TYPE workgroup_exclusive_scan(WORKGROUP_SCAN_TYPE value, out WORKGROUP_SCAN_TYPE total) {
    uint lane = gl_LocalInvocationID.x;
    workgroup_scan_cells[lane] = value;
    barrier();
    for (uint offset = 1u; offset < uint(LOCAL_SIZE); offset <<= 1u) {
        WORKGROUP_SCAN_TYPE lower = WORKGROUP_SCAN_TYPE(0u);
        if (lane >= offset) {
            lower = workgroup_scan_cells[lane - offset];
        }
        barrier();
        workgroup_scan_cells[lane] += lower;
        barrier();
    }
    WORKGROUP_SCAN_TYPE inclusive = workgroup_scan_cells[lane];
    total = workgroup_scan_cells[uint(LOCAL_SIZE) - 1u];
    // The cells may be reused by the next call only once every lane has read its own.
    barrier();
    return inclusive - value;
}

#endif
