// SPDX-License-Identifier: GPL-3.0-or-later
// Primary G-buffer, fragment stage (paper §3.1): like a standard deferred renderer, except
// that the alpha of the normal target holds the material index instead of a specular value.
//
// Outputs (the primary view; the cube faces write locations 1 and 2 differently, below):
//   location 0 (RGBA32F): xyz = world shading normal as modelled (not flipped),
//                         w = material index + 1, negated when the triangle is seen from its
//                         back side (0 = background, cleared by the host)
//   location 1 (RGBA16F): rgb = albedo (base colour times its image texture),
//                         a = first octahedral coordinate of the geometric normal
//   location 2 (RGBA16F): rgb = emission scale (the emission image texture's colour, 1
//                         without one; the shading multiplies the material's emission),
//                         a = second octahedral coordinate of the geometric normal
//   location 3 (RG16F):   the roughness and metallic at the pixel (their images, or the
//                         material's values without)
// The geometric normal (the plane of the triangle, either orientation) lets the tracer keep
// reflected rays above and refracted rays below the true surface: with interpolated shading
// normals on a tessellated surface a mirror direction can point into the mesh, and the ray
// then hits the object's own inside (speckles on curved mirrors). Derivatives of the world
// position give it exactly: two differences of points on one plane lie in that plane.
// Depth: the hardware depth buffer (DEPTH32F); positions are reconstructed from it.
// CUBE_FACE defined (the cube-map faces' variant, cube_map.py CubeFaceTargets):
// * Refractive surfaces are left out, so the faces hold what lies behind them. The map has
//   one layer; a ray refracted at a surface outside the near cube finds the scene behind it
//   there (paper Figure 8: refractive objects in the cube map are thin, refract once and
//   look the cube map up), and rays that meet such an object in the map pass it as a thin
//   clear sheet. The vertex stage drops their triangles (gbuffer.vert.glsl), so that no
//   variant of this shader discards and all keep the early depth test.
// * The textures are not sampled: location 1 (RGBA32F) holds xy = UV, z = UV density (sqrt
//   of UV area per world area, as the UV rows of scene_upload/instance_transform.comp.glsl
//   give BVH triangles), and location 2 (RG16F) the geometric normal's octahedral
//   coordinates. The tracer samples the textures at the few texels its rays hit, with the
//   ray cone's mip level, as at BVH hits (hybrid_trace.comp.glsl), instead of sampling them
//   for all 6 x res^2 texels.
// Samplers: u_textures (textures.glsl), sampled with the UV derivatives of the fragment
// (mipmaps, anisotropic filtering). A normal map bends the shading normal written at
// location 0 (both variants).
// INSTANCED defined (gbuffer.vert.glsl's indexed draws of object-space meshes): the triangle's
// material is read here, at its world row (the instance's first row, v_first_row, plus
// gl_PrimitiveID, the triangle's index in its draw), since its vertices are shared.
// NODE_PROGRAMS defined (GPUScene.defines: some material has a node graph): a material with a
// program (Material.textures2.w >= 0) runs it here (include/node_program.glsl) in the
// primary view: albedo = the closure's base colour, location 2's rgb = the closure's
// emission itself (not a scale: the shading reads it through node_gbuffer_material),
// location 3 (RGBA16F then) = roughness, metallic, transmission, coat, and the normal the
// closure's. The faces' variant stores the triangle's world row in location 1's w (its bits:
// cube_tangent.glsl cube_row_encode), so that a ray's hit in the map can run the program with the object's inputs,
// and location 3 (RGBA16F) the triangle's UV directions (include/cube_tangent.glsl), so that
// the program's tangent-space Normal Map and UV-reading Bump bend the normal there as at a
// BVH hit.
// Uniforms then: u_camera_position, u_camera_forward, u_orthographic (Geometry Incoming).
// The primary view's location 4 (R32I) holds the triangle's world row (passes/surface_motion/
// and passes/film/vector.py find the pixel's instance by it, passes/film/cryptomatte.py its
// ids).
// ALPHA_TEST defined (only for scenes with alpha, MaterialTable.has_alpha; both variants):
// a fragment of a material with alpha is discarded with the probability it is not there
// (alpha.glsl), drawn per pixel, sample (u_alpha_sample) and depth. Opaque scenes compile
// no discard and keep the early depth test.
#include "scene_layout.glsl"
#include "textures.glsl"
#include "octahedral.glsl"
#ifdef NODE_PROGRAMS
#include "node_program.glsl"
#ifdef CUBE_FACE
#include "cube_tangent.glsl"
#else
uniform vec3 u_camera_position;
uniform vec3 u_camera_forward;
uniform int u_orthographic;
#endif
#endif
#ifdef ALPHA_TEST
#include "alpha.glsl"
uniform int u_alpha_sample;
#endif

layout(std430) readonly buffer MaterialBuffer { Material materials[]; };
#ifdef INSTANCED
layout(std430) readonly buffer TriangleMaterials { int triangle_materials[]; };
#endif

in vec3 v_world;
in vec3 v_normal;
in vec2 v_uv;
#ifdef INSTANCED
flat in int v_first_row;
#else
flat in int v_material;
#endif
#if !defined(INSTANCED) && (defined(NODE_PROGRAMS) || !defined(CUBE_FACE))
flat in int v_row;
#endif

layout(location = 0) out vec4 out_normal_material;
layout(location = 1) out vec4 out_albedo;
layout(location = 2) out vec4 out_emission_scale;
#ifndef CUBE_FACE
layout(location = 3) out vec4 out_surface;
layout(location = 4) out int out_row;  // the world row (GBufferTargets.row)
#elif defined(NODE_PROGRAMS)
layout(location = 3) out vec4 out_cube_tangent;  // cube hits' tangent frame (cube_tangent.glsl)
#endif

void main() {
#ifdef INSTANCED
    int material = triangle_materials[v_first_row + gl_PrimitiveID];
#else
    int material = v_material;
#endif
    Material m = materials[material];
#ifndef CUBE_FACE
#ifdef INSTANCED
    out_row = v_first_row + gl_PrimitiveID;
#else
    out_row = v_row;
#endif
#endif
    // Derivatives outside any branch (they are undefined in non-uniform control flow).
    vec3 dp_dx = dFdx(v_world);
    vec3 dp_dy = dFdy(v_world);
    vec3 geometric = cross(dp_dx, dp_dy);
    float geometric_len2 = dot(geometric, geometric);
    vec2 duv_dx = dFdx(v_uv);
    vec2 duv_dy = dFdy(v_uv);
#ifdef ALPHA_TEST
    if (material_has_alpha(m)) {
        // -- closure alpha: the material's alpha program where it has one (alpha.glsl), at the
        // shading normal, seen from the camera (the faces: from the normal's side; no viewer there)
#ifdef NODE_CLOSURE_ALPHA
#ifdef CUBE_FACE
        vec3 facing = node_unit(v_normal, vec3(0.0, 0.0, 1.0));
        vec3 seen_from = gl_FrontFacing ? facing : -facing;
#else
        vec3 seen_from = u_orthographic != 0 ? -normalize(u_camera_forward) : normalize(u_camera_position - v_world);
#endif
#ifdef INSTANCED
        int row = v_first_row + gl_PrimitiveID;
#else
        int row = v_row;
#endif
        float alpha = material_fragment_alpha(m, v_uv, duv_dx, duv_dy, v_world, v_normal, seen_from, row, material, 0);
#else
        float alpha = material_alpha_grad(m, v_uv, duv_dx, duv_dy);
#endif
        // -- end of closure alpha
        if (!alpha_kept(alpha, uvec4(uvec2(gl_FragCoord.xy), uint(u_alpha_sample), floatBitsToUint(gl_FragCoord.z)))) {
            discard;
        }
    }
#endif
    vec3 n = v_normal;
    float len2 = dot(n, n);
    if (!(len2 > 1e-20) || any(isinf(n)) || any(isnan(n))) {
        // Degenerate shading normal: fall back to the geometric normal of the triangle.
        n = geometric_len2 > 0.0 ? geometric * inversesqrt(geometric_len2) : vec3(0.0, 0.0, 1.0);
    } else {
        n *= inversesqrt(len2);
    }
    // A triangle seen edge-on (or too small for float differences) gets the shading normal.
    vec3 g = geometric_len2 > 1e-36 && !any(isnan(geometric)) && !any(isinf(geometric))
           ? geometric * inversesqrt(geometric_len2) : n;
    vec2 g_oct = octahedral_encode(g);
    if (material_has_normal_map(m)) {
        // The UVs' directions on the surface from the same derivatives (a cotangent frame,
        // Schueler 2013): no tangents need storing, and the faces' variant gets them too.
        vec3 dp2_perp = cross(dp_dy, n);
        vec3 dp1_perp = cross(n, dp_dx);
        vec3 t = dp2_perp * duv_dx.x + dp1_perp * duv_dy.x;
        vec3 b = dp2_perp * duv_dx.y + dp1_perp * duv_dy.y;
        n = material_normal_grad(m, n, t, b, v_uv, duv_dx, duv_dy);
    }
    float id = float(material + 1);
    out_normal_material = vec4(n, gl_FrontFacing ? id : -id);
#ifdef CUBE_FACE
    // Locations 1 and 2 in the faces' layout (header): UV and density, geometric normal.
    // UV area over world area of the screen-space footprint: constant over a triangle.
    float uv_area = abs(duv_dx.x * duv_dy.y - duv_dx.y * duv_dy.x);
    float world_area = sqrt(geometric_len2);
    float density = world_area > 0.0 && !isinf(world_area) ? sqrt(uv_area / world_area) : 0.0;
#ifdef NODE_PROGRAMS
    float row_bits = cube_row_encode(v_row);
    // The frame on the axes of the geometric normal as location 2 keeps it (half floats).
    vec3 tangent_u, tangent_v;
    cube_tangent_of_fragment(dp_dx, dp_dy, duv_dx, duv_dy, tangent_u, tangent_v);
    out_cube_tangent = cube_tangent_encode(tangent_u, tangent_v, unpackHalf2x16(packHalf2x16(g_oct)));
#else
    float row_bits = 0.0;
#endif
    out_albedo = vec4(v_uv, isnan(density) || isinf(density) ? 0.0 : density, row_bits);
    out_emission_scale = vec4(g_oct, 0.0, 0.0);
#else
#ifdef NODE_PROGRAMS
    if (material_has_program(m)) {
        ShadingPoint sp;
        sp.position = sp.surface = v_world;
        sp.incoming = u_orthographic != 0 ? -normalize(u_camera_forward) : normalize(u_camera_position - v_world);
        sp.backfacing = !gl_FrontFacing;
        sp.normal = sp.backfacing ? -n : n;
        sp.geometric = dot(g, sp.incoming) < 0.0 ? -g : g;
        sp.uv = v_uv;
        sp.duv_dx = duv_dx;
        sp.duv_dy = duv_dy;
        sp.lod = -1.0;
        // The UVs' directions on the surface (the cotangent frame of the normal map above).
        vec3 dp2_perp = cross(dp_dy, n);
        vec3 dp1_perp = cross(n, dp_dx);
        sp.dp_du = dp2_perp * duv_dx.x + dp1_perp * duv_dy.x;
        sp.dp_dv = dp2_perp * duv_dx.y + dp1_perp * duv_dy.y;
        // The pixel's footprint as Cycles' camera ray holds it (its width across the ray,
        // the mean over the pixel's two sides), unfolded in the surface's plane as Cycles
        // does for the Bump; the UV's change along each axis from the UV's gradients (the
        // cotangent frame above over its determinant).
        vec3 across_x = dp_dx - sp.incoming * dot(sp.incoming, dp_dx);
        vec3 across_y = dp_dy - sp.incoming * dot(sp.incoming, dp_dy);
        node_footprint_axes(sp.geometric, 0.5 * (length(across_x) + length(across_y)), sp.dp_dx, sp.dp_dy);
        float frame_det = dot(dp_dx, dp2_perp);
        float inv_det = abs(frame_det) > 1e-30 ? 1.0 / frame_det : 0.0;
        sp.uv_dx = vec2(dot(sp.dp_du, sp.dp_dx), dot(sp.dp_dv, sp.dp_dx)) * inv_det;
        sp.uv_dy = vec2(dot(sp.dp_du, sp.dp_dy), dot(sp.dp_dv, sp.dp_dy)) * inv_det;
        sp.ray_depth = 0;
#ifdef INSTANCED
        sp.row = v_first_row + gl_PrimitiveID;
#else
        sp.row = v_row;
#endif
        sp.material = material;
        NodeClosure c = node_program_run(m.textures2.w, sp);
        out_normal_material = vec4(c.normal, out_normal_material.w);
        out_albedo = vec4(c.base_color, g_oct.x);
        out_emission_scale = vec4(c.emission, g_oct.y);
        out_surface = vec4(c.roughness, c.metallic, min(c.transmission, 1.0 - c.metallic), c.specular);
        return;
    }
#endif
    out_albedo = vec4(material_albedo_grad(m, v_uv, duv_dx, duv_dy), g_oct.x);
    out_emission_scale = vec4(material_emission_scale_grad(m, v_uv, duv_dx, duv_dy), g_oct.y);
    out_surface = vec4(material_surface_grad(m, v_uv, duv_dx, duv_dy), 0.0, 0.0);
#endif
}
