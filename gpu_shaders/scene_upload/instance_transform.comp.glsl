// SPDX-License-Identifier: GPL-3.0-or-later
// Instances to world space (paper §3.3: the meshes live on the GPU and are transformed there
// every frame). Invocation t makes one world-space triangle of one instance from its mesh's
// object-space data: the corners' positions through the object-to-world matrix, the shading
// normals through the normal matrix (renormalised; zero or non-finite ones become 0, which
// the G-buffer replaces by the geometric normal), the corners' UVs, the material of the
// triangle's slot, and the tracer's UV row (the corners' UVs and sqrt(UV area / world area),
// its texture level). Under a mirroring matrix corners 1 and 2 swap, so the winding stays
// counter-clockwise from outside. A triangle with a non-finite corner collapses to the origin.
// hybrid_engine/scene/meshes.py, scene/geometry.py's world_arrays does the same on the host.
//
// Work comes as segments (instance, first local triangle, count, first output row) with the
// exclusive prefix of their counts; an invocation finds its segment by binary search. The
// outputs are bound from the first row of the chunk being written (hybrid_engine/passes/
// scene_upload/instance_transform.py), so every index fits one storage block.
//
// Host defines: LOCAL_SIZE.
// Storage blocks: MeshPositions, MeshNormals (vec3 as 3 floats), MeshCornerVertices,
//   MeshCornerNormals, MeshSlots, MeshUVs (read), SlotMaterials, InstanceTable, Segments,
//   SegmentStarts (read); WorldPositions, WorldNormals, WorldUVs, WorldMaterials,
//   WorldUVRows (written).
// Uniforms: u_count (invocations), u_segments.
#include "dispatch.glsl"
#include "instance_space.glsl"

layout(local_size_x = LOCAL_SIZE) in;

layout(std430) readonly buffer MeshPositions { float mesh_positions[]; };
layout(std430) readonly buffer MeshNormals { float mesh_normals[]; };
layout(std430) readonly buffer MeshCornerVertices { int corner_vertices[]; };
layout(std430) readonly buffer MeshCornerNormals { int corner_normals[]; };
layout(std430) readonly buffer MeshSlots { int mesh_slots[]; };
layout(std430) readonly buffer MeshUVs { vec2 mesh_uvs[]; };
layout(std430) readonly buffer SlotMaterials { int slot_materials[]; };
layout(std430) readonly buffer InstanceTable { Instance instances[]; };
layout(std430) readonly buffer Segments { uvec4 segments[]; };  // instance, first, count, out row
layout(std430) readonly buffer SegmentStarts { uint segment_starts[]; };

layout(std430) writeonly buffer WorldPositions { float world_positions[]; };
layout(std430) writeonly buffer WorldNormals { float world_normals[]; };
layout(std430) writeonly buffer WorldUVs { vec2 world_uvs[]; };
layout(std430) writeonly buffer WorldMaterials { int world_materials[]; };
layout(std430) writeonly buffer WorldUVRows { vec4 world_uv_rows[]; };  // 2 per triangle

uniform uint u_count;
uniform uint u_segments;

vec3 mesh_position(int index) {
    uint base = uint(index) * 3u;
    return vec3(mesh_positions[base], mesh_positions[base + 1u], mesh_positions[base + 2u]);
}

vec3 mesh_normal(int index) {
    uint base = uint(index) * 3u;
    return vec3(mesh_normals[base], mesh_normals[base + 1u], mesh_normals[base + 2u]);
}

bool finite3(vec3 v) {
    return !any(isnan(v)) && !any(isinf(v));
}

// Unit normal through the normal matrix; 0 when it has no direction (instance_space.glsl).
vec3 world_normal(mat3 normal_matrix, int index) {
    return instance_normal(normal_matrix, mesh_normal(index));
}

vec2 corner_uv(Instance inst, int corner) {
    if (inst.mesh.w < 0) {
        return vec2(0.0);
    }
    vec2 uv = mesh_uvs[inst.mesh.w + corner];
    return (any(isnan(uv)) || any(isinf(uv))) ? vec2(0.0) : uv;
}

void store_corner(uint row, uint c, vec3 p, vec3 n, vec2 uv) {
    uint base = row * 9u + c * 3u;
    world_positions[base] = p.x;
    world_positions[base + 1u] = p.y;
    world_positions[base + 2u] = p.z;
    world_normals[base] = n.x;
    world_normals[base + 1u] = n.y;
    world_normals[base + 2u] = n.z;
    world_uvs[row * 3u + c] = uv;
}

void main() {
    uint t = flat_invocation_index();
    if (t >= u_count) {
        return;
    }
    // Last segment whose start is <= t.
    uint lo = 0u, hi = u_segments;
    while (hi - lo > 1u) {
        uint mid = (lo + hi) / 2u;
        if (segment_starts[mid] <= t) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    uvec4 segment = segments[lo];
    uint offset = t - segment_starts[lo];
    Instance inst = instances[segment.x];
    int local = int(segment.y + offset);  // triangle within its mesh
    int tri = inst.mesh.z + local;
    uint row = segment.w + offset;

    // Corner order: 0, 1, 2, or 0, 2, 1 under a mirroring matrix.
    int c1 = inst.flags.x != 0 ? 2 : 1;
    int c2 = 3 - c1;
    int k0 = tri * 3, k1 = tri * 3 + c1, k2 = tri * 3 + c2;
    vec3 p0 = instance_point(inst, mesh_position(inst.mesh.x + corner_vertices[k0]));
    vec3 p1 = instance_point(inst, mesh_position(inst.mesh.x + corner_vertices[k1]));
    vec3 p2 = instance_point(inst, mesh_position(inst.mesh.x + corner_vertices[k2]));
    mat3 normal_matrix = instance_normal_matrix(inst);
    vec3 n0 = world_normal(normal_matrix, inst.mesh.y + corner_normals[k0]);
    vec3 n1 = world_normal(normal_matrix, inst.mesh.y + corner_normals[k1]);
    vec3 n2 = world_normal(normal_matrix, inst.mesh.y + corner_normals[k2]);
    int uv_base = local * 3;
    vec2 uv0 = corner_uv(inst, uv_base), uv1 = corner_uv(inst, uv_base + c1), uv2 = corner_uv(inst, uv_base + c2);
    bool finite = finite3(p0) && finite3(p1) && finite3(p2);
    if (!finite) {
        p0 = p1 = p2 = vec3(0.0);
    }
    store_corner(row, 0u, p0, n0, uv0);
    store_corner(row, 1u, p1, n1, uv1);
    store_corner(row, 2u, p2, n2, uv2);
    int slot = mesh_slots[tri];
    world_materials[row] = (slot >= 0 && slot < inst.info.w) ? slot_materials[inst.info.z + slot] : 0;

    // The tracer's texture level (uv_per_world of textures.glsl's texture_lod).
    float world_area = length(cross(p1 - p0, p2 - p0));
    vec2 f1 = uv1 - uv0, f2 = uv2 - uv0;
    float uv_area = abs(f1.x * f2.y - f1.y * f2.x);
    float scale = world_area > 0.0 ? sqrt(uv_area / world_area) : 0.0;
    if (isnan(scale) || isinf(scale)) {
        scale = 0.0;
    }
    world_uv_rows[row * 2u] = vec4(uv0, uv1);
    world_uv_rows[row * 2u + 1u] = vec4(uv2, scale, 0.0);
}
