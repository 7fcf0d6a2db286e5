// Arrays split over several storage blocks (hybrid_engine/gpu/dispatch.py: split_blocks).
//
// A storage block may cover at most GL_MAX_SHADER_STORAGE_BLOCK_SIZE bytes (128 MiB on
// llvmpipe). A larger array is bound as up to 4 consecutive ranges of one buffer, each of
// SIZE items except the last, each a block of its own (TriangleInput, TriangleInput1, ...);
// element i lives in block STORAGE_BLOCK_OF(i, SIZE, BLOCKS) at index i - block * SIZE. The
// block is found with compares against constants rather than a division (a CPU driver has no
// vector integer division), and the shaders select the block's array with an if-chain: blocks of a storage
// block array could only be indexed with dynamically uniform values, and a ray's node is not.
//
// An array that fits one block is compiled without any of this (BLOCKS == 1 is the default
// of every split array), so small scenes pay nothing.
#ifndef HYBRID_STORAGE_BLOCKS_GLSL
#define HYBRID_STORAGE_BLOCKS_GLSL

#define STORAGE_MAX_BLOCKS 4

// Block of element i for blocks of SIZE items (SIZE and BLOCKS are literals; the compares
// beyond BLOCKS fold away).
#define STORAGE_BLOCK_OF(i, SIZE, BLOCKS) \
    (uint((i) >= uint(SIZE)) + \
     ((BLOCKS) > 2 ? uint((i) >= 2u * uint(SIZE)) : 0u) + \
     ((BLOCKS) > 3 ? uint((i) >= 3u * uint(SIZE)) : 0u))

#endif
