// SPDX-License-Identifier: GPL-3.0-or-later
// Level 0 of the lit cube map (hybrid_engine/passes/cube_light/, layout in
// include/cube_radiance.glsl): each texel of the cube map's faces (paper §3.2) shaded with
// its diffuse, view-independent light,
//   diffuse_weight * albedo / pi * (E_lamps + E_sky * V + E_bounce)
// where E_lamps is the lamps' irradiance through their shadow maps (lighting.glsl, hard
// shadows as the tracer's hits take them), E_sky the World's irradiance (world_light.glsl),
// and V and E_bounce the sky's visibility and the bounced irradiance of the gather
// (cube_light_gather.comp.glsl), upsampled from its blocks to the texel: the blocks around it
// weighted bilinearly and by how well their representative surface agrees with the texel's
// (normal and plane), so that light does not leak across an edge of the geometry. The
// diffuse layer's share (diffuse_weight, after its specular coat's Fresnel share) is the one
// the map's centre, the camera, sees. a = the texel's distance from the centre (0: none).
// Texels of the padding up to the power-of-two face size, and empty ones, are cleared.
//
// The texels hold no emission, only the light their surface reflects; whoever reads the map
// adds the hit material's emission where it counts, as it adds that of a surface it meets in
// the BVH (cube_light_gather.comp.glsl; trace_ray.glsl shade_hit and gather_light;
// diffuse_gather.comp.glsl, only where the path's last vertex took no next-event estimate of
// the emitters). Stored, it would have to be taken off again wherever it does not count (a
// linked emitter's non-receivers, a path that took the emitters' estimate), and what a float16
// texel keeps of a bright emission plus a dim reflection leaves that reflection to the texel's
// rounding (a step of 1/64 at an emission of 20); a filtered read would also spill the
// emission beside the emitter's edge.
//
// Storage block MaterialBuffer; uniform blocks LightBuffer, ShadowSlotBuffer; storage block
// SkyIrradiance. Samplers: the cube map's (cube_march.glsl, u_cube_surface, u_cube_geometric),
// u_gather (this frame's gather), u_textures, u_shadow_atlas, u_shadow_dynamic, u_sky_env.
// Image u_radiance (rgba16f, level 0, written). Uniforms: cube_march.glsl's,
// u_cube_radiance_res, u_gather_res, u_gathered (0: V = 1 and no bounce, without reading
// u_gather), the lighting's (FrameResources.bindings).
#define HARD_SHADOWS 1
#include "scene_layout.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(std430) readonly buffer MaterialBuffer { Material materials[]; };

#include "shading.glsl"
#include "textures.glsl"
#include "cube_march.glsl"
#include "cube_light_texels.glsl"
#ifdef NODE_PROGRAMS
#include "node_program.glsl"
uniform sampler2D u_cube_tangent;  // the texels' UV directions (cube_map.CubeFaceTargets)
#include "cube_tangent.glsl"
#endif

layout(rgba16f) writeonly uniform image2D u_radiance;
uniform sampler2D u_cube_surface;
uniform sampler2D u_gather;
uniform int u_cube_radiance_res;
uniform int u_gather_res;
uniform int u_gathered;  // 0: no gather (AO Distance 0 lights every surface by the whole sky)

const float CUBE_LIGHT_MAX = 60000.0;

// The gather's visibility (a) and bounced irradiance (rgb) at the texel `local` of (face,
// row) whose surface is at p with facing normal n (see the header).
vec4 gathered_light(int face, int row, ivec2 local, vec3 p, vec3 n) {
    vec2 at = (vec2(local) + 0.5) / float(CUBE_GATHER_BLOCK) - 0.5;
    ivec2 c = ivec2(floor(at));
    vec2 f = at - vec2(c);
    float texel_world = cube_texel_footprint(p);
    vec4 sum = vec4(0.0);
    float total = 0.0;
    for (int j = 0; j < 2; ++j) {
        for (int i = 0; i < 2; ++i) {
            ivec2 block = c + ivec2(i, j);
            if (any(lessThan(block, ivec2(0))) || any(greaterThanEqual(block, ivec2(u_gather_res)))) continue;
            ivec2 rep = ivec2(face, row) * u_cube_res + cube_gather_texel(block);
            vec4 nm = texelFetch(u_cube_normal_material, rep, 0);
            if (nm.w == 0.0) continue;
            vec3 q = cube_texel_position(face, rep);
            float facing = max(dot(normalize(nm.xyz), n), 0.0);
            facing *= facing;
            facing *= facing;
            float plane = abs(dot(q - p, n)) / (2.0 * CUBE_GATHER_BLOCK * texel_world);
            float w = (i == 1 ? f.x : 1.0 - f.x) * (j == 1 ? f.y : 1.0 - f.y) * facing * facing / (1.0 + plane * plane);
            sum += w * texelFetch(u_gather, ivec2(face, row) * u_gather_res + block, 0);
            total += w;
        }
    }
    if (total > 1e-4) return sum / total;
    // No block agrees: the one the texel lies in, whatever surface it stands for.
    ivec2 own = min(local / CUBE_GATHER_BLOCK, ivec2(u_gather_res - 1));
    return texelFetch(u_gather, ivec2(face, row) * u_gather_res + own, 0);
}

void main() {
    ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(u_radiance);
    if (any(greaterThanEqual(texel, size))) return;
    int face = texel.x / u_cube_radiance_res;
    int row = texel.y / u_cube_radiance_res;
    ivec2 local = texel - ivec2(face, row) * u_cube_radiance_res;
    if (any(greaterThanEqual(local, ivec2(u_cube_res)))) {
        imageStore(u_radiance, texel, vec4(0.0));
        return;
    }
    ivec2 atlas = ivec2(face, row) * u_cube_res + local;
    vec4 nm = texelFetch(u_cube_normal_material, atlas, 0);
    if (nm.w == 0.0) {
        imageStore(u_radiance, texel, vec4(0.0));
        return;
    }
    vec3 p = cube_texel_position(face, atlas);
    vec3 view_dir = normalize(p - u_cube_center);
    float dist = distance(p, u_cube_center);
    int index = int(abs(nm.w) + 0.5) - 1;
    // The texel's textures at the level of its own footprint, as the face's raster would.
    vec4 surface = texelFetch(u_cube_surface, atlas, 0);
    float lod = texture_lod(cube_texel_footprint(p), surface.z);
    Material m = material_at_lod(materials[index], surface.xy, lod);
    vec3 n_facing, g_facing;
    cube_texel_normals(atlas, nm, p, n_facing, g_facing);
#ifdef NODE_PROGRAMS
    // -- node programs: a material with a graph runs it at the texel, as a ray's cube-map hit
    // does (trace_ray.glsl hit_material), so the stored light has the graph's colours, not
    // the row's estimate; the texel's width is the footprint, and the UV directions the
    // faces keep (cube_tangent.glsl) its tangent frame
    if (material_has_program(materials[index])) {
        vec3 seen_from = dot(g_facing, view_dir) <= 0.0 ? -view_dir : view_dir;  // the centre's side
        vec3 g = normalize(g_facing);
        ShadingPoint sp = node_plain_point(p, normalize(nm.xyz), g, seen_from, surface.xy, lod, 1,
                                           cube_row_decode(surface.w), index);
        node_footprint_axes(sp.geometric, cube_texel_footprint(p), sp.dp_dx, sp.dp_dy);
        cube_tangent_decode(texelFetch(u_cube_tangent, atlas, 0), texelFetch(u_cube_geometric, atlas, 0).xy,
                            sp.dp_du, sp.dp_dv);
        sp.uv_dx = node_uv_change(sp.dp_dx, sp.dp_du, sp.dp_dv);
        sp.uv_dy = node_uv_change(sp.dp_dy, sp.dp_du, sp.dp_dv);
        if (sp.backfacing) {  // the frame flips with the normal (trace_ray.glsl hit_material)
            sp.dp_du = -sp.dp_du;
            sp.dp_dv = -sp.dp_dv;
        }
        NodeClosure c = node_program_run(materials[index].textures2.w, sp);
        m = node_closure_material(materials[index], c);
        n_facing = dot(c.normal, g_facing) >= 0.0 ? c.normal : -c.normal;
    }
#endif
    // -- end of node programs
    vec3 albedo = material_albedo_lod(m, surface.xy, lod);
    vec3 light = vec3(0.0);  // no emission: the readers add it (header)
    SpecularSplit split = specular_split_geometric(m, albedo, view_dir, n_facing, g_facing);
    if (split.diffuse_weight > 0.0) {
        DirectLight direct = direct_lighting(p, split.n_facing, -view_dir, vec3(0.0), 0.0, 1.0, true,
                                              material_light_set(m));  // light linking
        vec4 gathered = u_gathered != 0 ? gathered_light(face, row, local, p, split.n_facing) : vec4(0.0, 0.0, 0.0, 1.0);
        vec3 irradiance = direct.irradiance + sky_irradiance(split.n_facing) * gathered.a + gathered.rgb;
        light += split.diffuse_weight * albedo / PI * irradiance;
    }
    if (any(isnan(light)) || any(isinf(light))) light = vec3(0.0);
    imageStore(u_radiance, texel, vec4(clamp(light, vec3(0.0), vec3(CUBE_LIGHT_MAX)), dist));
}
