// SPDX-License-Identifier: GPL-3.0-or-later
// The World's light and the bounced light of the lit cube map (hybrid_engine/passes/cube_light/),
// gathered at a quarter of the map's resolution per side: per block of CUBE_GATHER_BLOCK^2
// texels, one cosine-distributed ray per frame from the block's representative texel
// (cube_light_texels.glsl), marched through the cube map (cube_march.glsl, paper §3.4). A ray
// that escapes sees the sky; one that meets a stored surface brings the light the previous
// frame stored there (cube_radiance.glsl at the hit, reprojected into the previous frame's
// map), so each frame adds one more bounce. The block keeps a running average:
//   rgb  the bounced irradiance, pi times the radiance brought (a cosine sample's estimate)
//   a    the sky's visibility, the share of rays that escaped
// blended as history + u_blend (sample - history); without history (u_history 0, or the
// block's surface no longer where the previous frame's map had it) the sample alone.
//
// A ray that crosses the near cube passes it: what lies inside is not in the map (the near
// cube's contents are clipped from the faces, paper §3.2), so they neither hide the sky nor
// bounce light here.
//
// Storage block MaterialBuffer (and EmitterLinks with EMITTER_LINKING). Samplers: the cube
// map's (cube_march.glsl, u_cube_surface, u_cube_geometric), u_textures (the emission images),
// u_cube_radiance (the previous frame's lit cube map, level 0), u_gather_prev (the previous
// frame's gather). Image u_gather (rgba16f, written). Uniforms: cube_march.glsl's,
// cube_radiance.glsl's, u_prev_center (the previous map's centre), u_history (1: the
// previous frame's map and gather are valid), u_blend, u_frame (random numbers), u_gather_res
// (blocks per face side), u_scene_bounded, u_scene_lo, u_scene_hi (the bounds of all
// geometry, padded: tracer.scene_bound_uniforms). Host defines: cube_march.glsl's.
#include "scene_layout.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(std430) readonly buffer MaterialBuffer { Material materials[]; };
// EMITTER_LINKING (some emissive object is linked): EmitterLinks, bound with it.
#include "emitter_links.glsl"

#include "textures.glsl"
#include "cube_march.glsl"
#include "scene_bounds.glsl"
#include "cube_radiance.glsl"
#include "cube_light_texels.glsl"
#include "random.glsl"

layout(rgba16f) writeonly uniform image2D u_gather;
uniform sampler2D u_cube_surface;  // the texels' UV and texture scale (cube_map.CubeFaceTargets)
uniform sampler2D u_gather_prev;
uniform vec3 u_prev_center;
uniform int u_history;
uniform float u_blend;
uniform int u_frame;
uniform int u_gather_res;

// Radiance fp16 can hold: samples are clamped to it, so no sum turns infinite.
const float CUBE_LIGHT_MAX = 60000.0;
// How far (relative) the previous map's distance at a point may differ from the point's own
// for its light to count as the same surface's.
const float SAME_SURFACE = 0.1;

// The previous frame's stored light at world point p on layer `row`, or -1 where that map
// held another surface there (or none).
vec3 previous_radiance(vec3 p, int row) {
    if (u_history == 0) return vec3(-1.0);
    int face;
    ivec2 local;
    float axial;
    cube_locate(p, u_prev_center, face, local, axial);
    vec4 v = texelFetch(u_cube_radiance, ivec2(face, row) * u_cube_radiance_res + local, 0);
    float dist = distance(p, u_prev_center);
    return abs(v.a - dist) <= SAME_SURFACE * dist ? v.rgb : vec3(-1.0);
}

void main() {
    ivec2 g = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(u_gather);
    if (any(greaterThanEqual(g, size))) return;
    int face = g.x / u_gather_res;
    int row = g.y / u_gather_res;
    ivec2 block = g - ivec2(face, row) * u_gather_res;
    ivec2 atlas = ivec2(face, row) * u_cube_res + cube_gather_texel(block);
    vec4 nm = texelFetch(u_cube_normal_material, atlas, 0);
    if (nm.w == 0.0) {
        imageStore(u_gather, g, vec4(0.0, 0.0, 0.0, 1.0));
        return;
    }
    vec3 p = cube_texel_position(face, atlas);
    vec3 n_facing, g_facing;
    cube_texel_normals(atlas, nm, p, n_facing, g_facing);

    // One cosine-distributed direction, kept above the surface.
    vec2 xi = random2(uvec4(uint(atlas.x), uint(atlas.y), uint(u_frame), 0xc0be11u));
    vec3 t, b;
    basis_around(n_facing, t, b);
    float r = sqrt(xi.x);
    vec3 d = r * cos(2.0 * PI * xi.y) * t + r * sin(2.0 * PI * xi.y) * b + sqrt(max(0.0, 1.0 - xi.x)) * n_facing;
    float c = dot(d, g_facing);
    if (c < 0.01) d = normalize(d + g_facing * (0.01 - c));
    vec3 o = p + g_facing * (scene_offset_absolute(1e-4) + 1e-4 * max(max(abs(p.x), abs(p.y)), abs(p.z)));

    float limit = scene_exit(o, d);
    CubeMarch cm;
    cm.kind = CUBE_SKY;
    if (limit >= 0.0) {
        cm = cube_march_limited(o, d, 0.0, limit);
        if (cm.kind == CUBE_TO_BVH) {
            // Through the near cube, on into the faces beyond it.
            vec2 span = box_interval(o, d, u_cube_center - vec3(u_cube_near), u_cube_center + vec3(u_cube_near));
            cm = cube_march_limited(o, d, max(cm.t, span.y), limit);
            if (cm.kind == CUBE_TO_BVH) cm.kind = CUBE_SKY;
        }
    }
    vec4 sample_value = vec4(0.0, 0.0, 0.0, 1.0);
    if (cm.kind == CUBE_HIT) {
        vec3 seen = previous_radiance(cm.position, cm.texel.y >= u_cube_res ? 1 : 0);
        // The map's texels hold no emission (cube_light_shade.comp.glsl): the ray adds the
        // hit's, its row's factor times its emission image at the texel's UV and footprint
        // (a node program's at the host's estimate of its row), where it lights the block's
        // surface (a linked emitter: only onto its receivers' texels).
        bool lights = all(greaterThanEqual(seen, vec3(0.0))) && cm.material >= 0;
#ifdef EMITTER_LINKING
        lights = lights && emission_lights_set(cm.material, row_light_set(int(abs(nm.w) + 0.5) - 1));
#endif
        if (lights) {
            vec4 surface = texelFetch(u_cube_surface, cm.texel, 0);
            float lod = texture_lod(cube_texel_footprint(cm.position), surface.z);
            seen += max(material_emission_lod(materials[cm.material], surface.xy, lod), vec3(0.0));
        }
        sample_value = vec4(PI * clamp(seen, vec3(0.0), vec3(CUBE_LIGHT_MAX)), 0.0);
    }

    // The block's history, where its surface was in the previous frame's map.
    vec4 history = vec4(-1.0);
    if (u_history != 0) {
        int pface;
        ivec2 plocal;
        float axial;
        cube_locate(p, u_prev_center, pface, plocal, axial);
        ivec2 pblock = min(plocal / CUBE_GATHER_BLOCK, ivec2(u_gather_res - 1));
        ivec2 prep = cube_gather_texel(pblock);
        float was = texelFetch(u_cube_radiance, ivec2(pface, row) * u_cube_radiance_res + prep, 0).a;
        float dist = distance(p, u_prev_center);
        if (abs(was - dist) <= SAME_SURFACE * dist)
            history = texelFetch(u_gather_prev, ivec2(pface, row) * u_gather_res + pblock, 0);
    }
    vec4 value = history.a >= 0.0 ? mix(history, sample_value, u_blend) : sample_value;
    imageStore(u_gather, g, clamp(value, vec4(0.0), vec4(CUBE_LIGHT_MAX)));
}
