// SPDX-License-Identifier: GPL-3.0-or-later
// Per-triangle culling of raster draws, step 1: which triangles of a view's draw list can
// produce a fragment. Used for the six G-buffer cube-map faces (paper §3.2), whose draws are
// dominated by triangles that produce none: a distant detailed object covers far fewer
// texels of a face than it has triangles, so most of its triangles fall between texel
// centres, and those of its far side face away. The rasterizer would set each of them up
// only to discard it; here one test per triangle drops it first (the "small primitive" and
// back-face tests of GPU-driven pipelines), and only the survivors are drawn.
//
// A triangle is dropped (and only then) when the GL would rasterize nothing of it:
//   * all three vertices lie outside the same clip plane (x, y or z of [-w, w]);
//   * all three have w > 0 and the bounding box of the projected triangle, clamped to the
//     view and widened by CULL_PIXEL_EPS, holds no pixel centre (the GL samples at centres;
//     the widening absorbs the rasterizer's fixed-point snapping);
//   * its object is closed and back-face cullable in this view (view_cull/draw.py
//     draw_world: closed, outward wound, wholly beyond the near plane) and its window-space
//     area, signed by the view's front-face winding, is <= 0 -- what glCullFace(GL_BACK)
//     would drop.
// A triangle crossing the camera plane (some w <= 0) is kept: the clipper decides.
//
// Work list: the host concatenates, view by view, segments (first triangle, count) of the
// objects each view draws; each view's work starts at a multiple of 32 items so that a
// 32-item chunk never spans two views. Invocation c tests the items of chunk c in order and
// writes one bit per item (1 = draw) and the chunk's count for the prefix sum.
//
// Paired lists (PAIRED = 1: the cube map's two layers). One test per triangle serves two
// draw lists: the front list as above, and the back list of the back layer (cube_map.py),
// which holds what the same views would draw of the closed objects with front faces culled
// instead: the same clip and pixel tests, the opposite facing. The back layer's own cull
// would transform every triangle of the closed objects a second time.
//
// Host defines: LOCAL_SIZE, MAX_VIEWS, (TriangleIndex unused),
//   TRI_INPUT_BLOCKS, TRI_INPUT_BLOCK_SIZE (triangle_input.glsl), PAIRED (0 or 1).
// Storage blocks: TriangleInput (read; TriangleInput1..3 for a split scene), Segments (read:
//   uvec4[S] = first triangle, count, first work item, view | cullable << 8 | closed << 9
//   (closed: the object belongs in the back list; read when PAIRED); sorted by work item),
//   ChunkMasks (write: uint[C]), ChunkCounts (write: uint[C + 1]); when PAIRED also the back
//   list's BackChunkMasks and BackChunkCounts.
// Uniforms: u_num_chunks (C), u_num_segments (S), u_view_proj[MAX_VIEWS], u_view_size
//   (pixels), u_front_sign (+1: counter-clockwise front faces, -1: clockwise; negated for
//   a view that keeps back faces instead, the cube map's back layer: view_cull.CullView).
#include "dispatch.glsl"
#include "triangle_input.glsl"
#include "view_cull_segments.glsl"

layout(local_size_x = LOCAL_SIZE) in;

layout(std430) writeonly buffer ChunkMasks {
    uint chunk_masks[];
};
layout(std430) writeonly buffer ChunkCounts {
    uint chunk_counts[];
};
#ifndef PAIRED
#define PAIRED 0
#endif
#if PAIRED
layout(std430) writeonly buffer BackChunkMasks {
    uint back_chunk_masks[];
};
layout(std430) writeonly buffer BackChunkCounts {
    uint back_chunk_counts[];
};
#endif

uniform uint u_num_chunks;
uniform mat4 u_view_proj[MAX_VIEWS];
uniform vec2 u_view_size[MAX_VIEWS];
uniform float u_front_sign[MAX_VIEWS];

// Widening of the projected bounding box, in pixels. The GL snaps vertices to a subpixel grid
// (8 bits on llvmpipe and current GPUs: 1/256 pixel); four times that keeps every triangle
// the rasterizer could sample.
const float CULL_PIXEL_EPS = 1.0 / 64.0;

// What the GL may rasterize of a triangle: nothing, or fragments of a face that faces the
// view (CULL_FRONT), of one that faces away from it (CULL_BACK; both only for a cullable
// object), or either (CULL_ANY: its facing is not tested).
const uint CULL_NONE = 0u;
const uint CULL_FRONT = 1u;
const uint CULL_BACK = 2u;
const uint CULL_ANY = 3u;

uint raster_class(uint tri, mat4 m, vec2 size, float front_sign, bool cullable) {
    vec4 c0 = m * vec4(input_vertex(tri, 0u), 1.0);
    vec4 c1 = m * vec4(input_vertex(tri, 1u), 1.0);
    vec4 c2 = m * vec4(input_vertex(tri, 2u), 1.0);
    // Outcodes: outside one clip plane with all three vertices.
    bvec3 below0 = lessThan(c0.xyz, vec3(-c0.w)), below1 = lessThan(c1.xyz, vec3(-c1.w)),
          below2 = lessThan(c2.xyz, vec3(-c2.w));
    bvec3 above0 = greaterThan(c0.xyz, vec3(c0.w)), above1 = greaterThan(c1.xyz, vec3(c1.w)),
          above2 = greaterThan(c2.xyz, vec3(c2.w));
    if (any(bvec3(below0.x && below1.x && below2.x, below0.y && below1.y && below2.y,
                  below0.z && below1.z && below2.z)) ||
        any(bvec3(above0.x && above1.x && above2.x, above0.y && above1.y && above2.y,
                  above0.z && above1.z && above2.z))) {
        return CULL_NONE;
    }
    if (!(c0.w > 0.0 && c1.w > 0.0 && c2.w > 0.0)) {
        return CULL_ANY;  // crosses the camera plane (or is NaN): let the clipper decide
    }
    vec2 s0 = (c0.xy / c0.w * 0.5 + 0.5) * size - 0.5;  // pixel centres at integers
    vec2 s1 = (c1.xy / c1.w * 0.5 + 0.5) * size - 0.5;
    vec2 s2 = (c2.xy / c2.w * 0.5 + 0.5) * size - 0.5;
    vec2 lo = max(min(s0, min(s1, s2)) - CULL_PIXEL_EPS, vec2(0.0));
    vec2 hi = min(max(s0, max(s1, s2)) + CULL_PIXEL_EPS, size - 1.0);
    if (any(greaterThan(ceil(lo), floor(hi)))) {
        return CULL_NONE;  // no pixel centre inside the bounding box
    }
    if (cullable) {
        vec2 e1 = s1 - s0;
        vec2 e2 = s2 - s0;
        float signed_area = (e1.x * e2.y - e1.y * e2.x) * front_sign;
        // Zero (or NaN) area: no side is rasterized.
        return signed_area > 0.0 ? CULL_FRONT : (signed_area < 0.0 ? CULL_BACK : CULL_NONE);
    }
    return CULL_ANY;
}

void main() {
    uint chunk = flat_invocation_index();
    if (chunk >= u_num_chunks) {
        return;
    }
    uint begin = chunk * 32u;
    int seg = segment_of(begin);
    // A chunk never spans two views (header): the view's uniforms are read once per chunk,
    // not per item (a dynamically indexed uniform array is a gather per component on a
    // CPU driver).
    uint view = segments[seg].w & 0xffu;
    mat4 m = u_view_proj[view];
    vec2 size = u_view_size[view];
    float front_sign = u_front_sign[view];
    uint mask = 0u;
    uint back_mask = 0u;
    // The segment of the current item, and the first item of the next one (the segments
    // are read when the walk crosses into them, not per item).
    uvec4 s = segments[seg];
    uint next_start = seg + 1 < int(u_num_segments) ? segments[seg + 1].z : 0xffffffffu;
    for (uint b = 0u; b < 32u; ++b) {
        uint item = begin + b;
        while (item >= next_start) {
            ++seg;
            s = segments[seg];
            next_start = seg + 1 < int(u_num_segments) ? segments[seg + 1].z : 0xffffffffu;
        }
        uint local = item - s.z;
        if (local >= s.y) {
            continue;  // padding between views
        }
        uint sides = raster_class(s.x + local, m, size, front_sign, ((s.w >> 8) & 1u) != 0u);
        if ((sides & CULL_FRONT) != 0u) {
            mask |= 1u << b;
        }
#if PAIRED
        if ((sides & CULL_BACK) != 0u && ((s.w >> 9) & 1u) != 0u) {
            back_mask |= 1u << b;
        }
#endif
    }
    chunk_masks[chunk] = mask;
    chunk_counts[chunk] = uint(bitCount(mask));
#if PAIRED
    back_chunk_masks[chunk] = back_mask;
    back_chunk_counts[chunk] = uint(bitCount(back_mask));
#endif
}
