// LBVH pass 4: parallel hierarchy construction, Karras 2012 "Maximizing parallelism in the
// construction of BVHs, octrees, and k-d trees", Algorithm 1 (the paper's §3.3 cites it).
//
// One invocation per inner node i in [0, N-2]: find the direction and far end of the key range
// that node i covers, then the split inside it by binary search on the common prefix length
// delta. Duplicate Morton codes are handled as Karras §4 suggests: when two keys are equal,
// delta falls back to 32 + the common prefix of their indices, so the keys behave as if they
// were distinct (key, index) concatenations and the tree stays well formed.
//
// Also writes each node's parent link and clears the refit flags, so the bottom-up pass needs
// no separate reset.
//
// Host defines: LOCAL_SIZE, BVH_NODE_BLOCKS, BVH_NODE_BLOCK_SIZE (the last two only for a node
//   array split over storage blocks: bvh_storage.glsl).
// Storage blocks: Keys (read: sorted), BVHNodes (write: child refs, parents; BVHNodes1..3
//   when split), LeafParent (write), RefitFlags (write: 0), BuildCount (read: the leaves N,
//   build_count.glsl).
// The host dispatches at least max(N - 1, 1) invocations (for its upper bound of N, or
//   indirectly the exact number); for N < 2 invocation 0 writes the special root described in
//   bvh_layout.glsl.
#include "build_count.glsl"
#include "dispatch.glsl"
#include "float_order.glsl"
#include "bvh_layout.glsl"

#define BVH_NODES
#define BVH_NODES_ACCESS
#include "bvh_storage.glsl"

layout(local_size_x = LOCAL_SIZE) in;

layout(std430) readonly buffer Keys {
    uint keys[];
};
layout(std430) writeonly buffer LeafParent {
    int leaf_parent[];
};
layout(std430) writeonly buffer RefitFlags {
    uint refit_flags[];
};

uint leaves;  // N, read once per invocation

// Length of the common prefix of key i (passed in, loaded once) and key j, with the index
// tie-break for equal keys; -1 when j lies outside [0, N-1].
int delta(uint key_i, int i, int j) {
    if (j < 0 || j >= int(leaves)) {
        return -1;
    }
    uint diff = key_i ^ keys[j];
    if (diff == 0u) {
        return 32 + (31 - findMSB(uint(i) ^ uint(j)));
    }
    return 31 - findMSB(diff);
}

void main() {
    uint index = flat_invocation_index();
    leaves = build_count();
    if (leaves < 2u) {
        // Degenerate trees: no inner node exists, so node 0 is a stand-in root whose left child
        // is leaf 0 (N = 1) and whose other boxes are empty; the refit fills the left box.
        if (index == 0u) {
            // Node 0 always lies in the first block.
            bvh_nodes[0] = BVHNode(bvh_pack(vec3(FLOAT_MAX), ~0), bvh_pack(vec3(-FLOAT_MAX), ~0),
                               bvh_pack(vec3(FLOAT_MAX), BVH_NO_PARENT),
                               bvh_pack(vec3(-FLOAT_MAX), int(leaves)));
            refit_flags[0] = 0u;
            if (leaves == 1u) {
                leaf_parent[0] = 0;
            }
        }
        return;
    }
    if (index >= leaves - 1u) {
        return;
    }
    int i = int(index);
    uint key_i = keys[i];

    // Direction of the range: towards the neighbour sharing the longer prefix.
    int d = (delta(key_i, i, i + 1) - delta(key_i, i, i - 1)) >= 0 ? 1 : -1;
    // Upper bound for the range length, then its exact other end j by binary search.
    int delta_min = delta(key_i, i, i - d);
    int length_max = 2;
    while (delta(key_i, i, i + length_max * d) > delta_min) {
        length_max *= 2;
    }
    int length = 0;
    for (int step = length_max >> 1; step >= 1; step >>= 1) {
        if (delta(key_i, i, i + (length + step) * d) > delta_min) {
            length += step;
        }
    }
    int j = i + length * d;

    // Split position: the last key sharing more than delta_node bits with key i.
    int delta_node = delta(key_i, i, j);
    // Steps ceil(length / 2^k) for k = 1, 2, ...: shifts, since a CPU driver has no vector
    // integer division and would run one scalar division per lane.
    int split = 0;
    int shift = 1;
    for (;;) {
        int step = (length + (1 << shift) - 1) >> shift;
        if (delta(key_i, i, i + (split + step) * d) > delta_node) {
            split += step;
        }
        if (step <= 1) {
            break;
        }
        ++shift;
    }
    int gamma = i + split * d + min(d, 0);

    int first = min(i, j);
    int last = max(i, j);
    int left = (first == gamma) ? ~gamma : gamma;
    int right = (last == gamma + 1) ? ~(gamma + 1) : gamma + 1;
    bvh_node_set_w(index, BVH_ROW_LEFT_MIN, uint(left));
    bvh_node_set_w(index, BVH_ROW_LEFT_MAX, uint(right));
    bvh_node_set_w(index, BVH_ROW_RIGHT_MAX, uint(last - first + 1));
    if (left < 0) {
        leaf_parent[gamma] = i;
    } else {
        bvh_node_set_w(uint(left), BVH_ROW_RIGHT_MIN, uint(i));
    }
    if (right < 0) {
        leaf_parent[gamma + 1] = i;
    } else {
        bvh_node_set_w(uint(right), BVH_ROW_RIGHT_MIN, uint(i));
    }
    if (i == 0) {
        bvh_nodes[0].right_min.w = uint(BVH_NO_PARENT);
    }
    refit_flags[i] = 0u;
}
