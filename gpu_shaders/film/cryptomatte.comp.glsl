// SPDX-License-Identifier: GPL-3.0-or-later
// Cryptomatte's coverage, accumulated over a view's samples on the GPU
// (passes/film/cryptomatte.py; the Cryptomatte specification's ranked (id, coverage) pairs).
//
// u_slots is an RGBA32F image array whose layers are the passes themselves: kind k's pass p
// is layer k * u_passes + p, its texel two (id, coverage) pairs, so the last step leaves
// exactly what Blender's CryptoObject00, 01, ... passes hold and nothing is converted on
// the host. Without FINALIZE (every sample): the id of the triangle the sample's G-buffer
// shows (u_row, its world row; none where u_normal_material's id is 0, the background,
// which adds nothing) for each kind, and one more
// count for that id in the pixel's ranks: the rank that holds it, else the first empty one
// (an id past the last rank is dropped, as Cycles drops it). u_sample 0 clears the ranks
// first. A count per sample is the box of the samples' jittered positions (antialias.py):
// an edge pixel's ids share its samples, so their coverages are fractional.
// FINALIZE (once, before the read-back): the ranks sorted by coverage, largest first, and
// the counts divided by the samples (u_samples), as Cycles' film sorts and scales them.
//
// Kinds (u_kinds[k]): 0 object, 1 material, 2 asset. Objects are found by their first world
// row (ObjectRows, ascending, u_objects of them): the last one whose first row is at or
// before the pixel's row. ObjectIds holds per object (object id, asset id), MaterialIds
// per material its id, TriangleMaterials per world row its material.
layout(local_size_x = 8, local_size_y = 8) in;

layout(rgba32f) uniform image2DArray u_slots;

uniform ivec2 u_size;
uniform int u_passes;  // RGBA passes per kind: two ranks each
uniform int u_kind_count;
uniform ivec3 u_kinds;

#ifdef FINALIZE
uniform float u_samples;
#else
uniform isampler2D u_row;             // the primary G-buffer's world row per pixel
uniform sampler2D u_normal_material;  // its signed material id in w: 0 where no surface
uniform int u_sample;
uniform int u_objects;

layout(std430) readonly buffer ObjectRows { int object_rows[]; };
layout(std430) readonly buffer ObjectIds { vec2 object_ids[]; };
layout(std430) readonly buffer MaterialIds { float material_ids[]; };
layout(std430) readonly buffer TriangleMaterials { int triangle_materials[]; };

int object_of(int row) {
    int lo = 0;
    int hi = u_objects - 1;
    while (lo < hi) {  // the last object whose first row <= row
        int mid = (lo + hi + 1) / 2;
        if (object_rows[mid] <= row) {
            lo = mid;
        } else {
            hi = mid - 1;
        }
    }
    return lo;
}
#endif

vec2 rank(ivec2 texel, int kind, int r) {
    vec4 pair = imageLoad(u_slots, ivec3(texel, kind * u_passes + r / 2));
    return (r % 2) == 0 ? pair.xy : pair.zw;
}

void set_rank(ivec2 texel, int kind, int r, vec2 value) {
    ivec3 at = ivec3(texel, kind * u_passes + r / 2);
    vec4 pair = imageLoad(u_slots, at);
    if ((r % 2) == 0) {
        pair.xy = value;
    } else {
        pair.zw = value;
    }
    imageStore(u_slots, at, pair);
}

void main() {
    ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(texel, u_size))) {
        return;
    }
    int ranks = 2 * u_passes;
#ifdef FINALIZE
    for (int k = 0; k < u_kind_count; ++k) {
        // Insertion sort of at most 16 ranks, in registers.
        vec2 sorted[16];
        for (int r = 0; r < ranks; ++r) {
            vec2 item = rank(texel, k, r);
            int at = r;
            while (at > 0 && sorted[at - 1].y < item.y) {
                sorted[at] = sorted[at - 1];
                --at;
            }
            sorted[at] = item;
        }
        for (int p = 0; p < u_passes; ++p) {
            imageStore(u_slots, ivec3(texel, k * u_passes + p),
                       vec4(sorted[2 * p].x, sorted[2 * p].y / u_samples,
                            sorted[2 * p + 1].x, sorted[2 * p + 1].y / u_samples));
        }
    }
#else
    if (u_sample == 0) {
        for (int layer = 0; layer < u_kind_count * u_passes; ++layer) {
            imageStore(u_slots, ivec3(texel, layer), vec4(0.0));
        }
    }
    if (!(abs(texelFetch(u_normal_material, texel, 0).w) > 0.5)) {
        return;
    }
    int row = texelFetch(u_row, texel, 0).r;
    int object = object_of(row);
    for (int k = 0; k < u_kind_count; ++k) {
        int kind = u_kinds[k];
        float id = kind == 0 ? object_ids[object].x
                 : kind == 1 ? material_ids[triangle_materials[row]] : object_ids[object].y;
        for (int r = 0; r < ranks; ++r) {
            vec2 held = rank(texel, k, r);
            if (held.y == 0.0) {
                set_rank(texel, k, r, vec2(id, 1.0));
                break;
            }
            if (held.x == id) {
                set_rank(texel, k, r, vec2(id, held.y + 1.0));
                break;
            }
        }
    }
#endif
}
