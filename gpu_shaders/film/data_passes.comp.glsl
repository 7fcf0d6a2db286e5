// SPDX-License-Identifier: GPL-3.0-or-later
// The Depth and Normal passes of a final render from the primary G-buffer, with Cycles'
// conventions (frame/film.py):
// * Depth: the distance along the camera's view axis, each pixel centre taken back through
//   the inverse projection (perspective, orthographic, shifted or cropped alike), in double
//   precision: near the far plane the depth buffer's z and w cancel to few float32 bits;
//   BACKGROUND_DEPTH where nothing was hit (depth 1, the clear value);
// * Normal: the world shading normal, normalised, turned to the side the camera sees (the
//   G-buffer's material code is negative on back sides), 0 where nothing was hit.
//
// DENOISING defined: also the Denoising Albedo and Denoising Normal passes, the feature
// images a denoiser (OpenImageDenoise, the compositor's Denoise node) reads beside the noisy
// colour to tell texture and edges from noise. They follow Cycles' film (its
// denoising-features write): the surface's closures are split into diffuse-like ones (the
// diffuse layer, and metal or glass rougher than GGX alpha 0.075) and specular-like ones
// (smoother metal and glass); a surface more than a quarter diffuse-like writes the albedo
// of its diffuse-like closures, a specular-dominant one (mirror, polished metal, clear
// glass) its specular tint. Cycles would instead follow the specular ray and write the tint
// times what it meets; the G-buffer holds no such hit, and the tint alone keeps the
// denoiser from reading a reflection's detail as the surface's texture to blur. The normal
// is the shading normal on the viewer's side in Cycles' camera space (x right, y up, z
// into the view). Both are running means over the view's samples (u_sample), as Cycles
// averages every sample, so that they are antialiased exactly like the colour they guide.
//
// Bindings: u_depth (the G-buffer depth), u_normal_material (RGBA32F) read; images
// u_depth_pass (R32F) and u_normal_pass (RGBA32F) written, u_size texels. DENOISING adds
// u_albedo and u_surface (G-buffer) and the storage block MaterialBuffer read, and the
// images u_denoising_albedo and u_denoising_normal (RGBA32F) read and written.
#include "scene_layout.glsl"
#include "textures.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(r32f) writeonly uniform image2D u_depth_pass;
layout(rgba32f) writeonly uniform image2D u_normal_pass;

uniform sampler2D u_depth;
uniform sampler2D u_normal_material;
uniform dmat4 u_inv_projection;
uniform ivec2 u_size;
uniform float u_background_depth;

#ifdef DENOISING
layout(std430) readonly buffer MaterialBuffer { Material materials[]; };
layout(rgba32f) uniform image2D u_denoising_albedo;
layout(rgba32f) uniform image2D u_denoising_normal;
uniform sampler2D u_albedo;   // rgb: base colour times its texture (gbuffer.frag.glsl)
uniform sampler2D u_surface;  // roughness, metallic of their images
uniform mat3 u_world_to_camera;  // Cycles' camera space: Blender's with z towards the view
uniform int u_sample;  // this sample's index among the view's: 0 starts the means over
// 0: this frame reads no Depth or Normal back (a final render's later samples), skip them.
uniform int u_depth_normal;

// The layers' weights as shading.glsl reads them (that include brings the lamps and the
// sky, which this pass does not bind): metal, glass, and the diffuse rest.
float layer_metal(Material m) { return clamp(m.base_color_refl.a, 0.0, 1.0); }
float layer_glass(Material m) { return clamp(m.emission_trans.a, 0.0, 1.0); }
float layer_diffuse(Material m) { return max(0.0, 1.0 - layer_metal(m) - layer_glass(m)); }

// Cycles' line between specular-like and diffuse-like closures: GGX alpha 0.075 (alpha is
// roughness squared, in Blender's Principled BSDF as here).
const float SPECULAR_ALPHA = 0.075;

// The Denoising Albedo of a surface of material m and (textured) base colour `base`.
vec3 denoising_albedo(Material m, vec3 base) {
    float roughness = clamp(m.params.z, 0.0, 1.0);
    bool rough = roughness * roughness > SPECULAR_ALPHA;
    float diffuse = layer_diffuse(m);
    float specular = layer_metal(m) + layer_glass(m);
    // Metal reflects and glass transmits tinted by the base colour (shading.glsl).
    vec3 diffuse_like = diffuse * base + (rough ? specular * base : vec3(0.0));
    vec3 specular_like = rough ? vec3(0.0) : specular * base;
    float total = diffuse + specular;
    float nonspecular = diffuse + (rough ? specular : 0.0);
    return nonspecular * 4.0 > total ? diffuse_like : specular_like;
}

// The running mean `mean` of samples 0..u_sample - 1 with `value` added: sample k (from 0)
// weighs 1 / (k + 1); sample 0 ignores what the images held.
vec4 running_mean(vec4 mean, vec3 value) {
    vec3 old = u_sample == 0 ? vec3(0.0) : mean.rgb;
    return vec4(old + (value - old) / float(u_sample + 1), 0.0);
}
#endif

void main() {
    ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(texel, u_size))) {
        return;
    }
    vec4 normal_material = texelFetch(u_normal_material, texel, 0);
    float len = length(normal_material.xyz);
    float side = sign(normal_material.w);
    vec3 unit = len > 0.0 ? normal_material.xyz / len : vec3(0.0);
#ifdef DENOISING
    if (u_depth_normal != 0)
#endif
    {
        double window_depth = double(texelFetch(u_depth, texel, 0).r);
        dvec2 ndc_xy = (dvec2(texel) + 0.5lf) / dvec2(u_size) * 2.0lf - 1.0lf;
        dvec4 view = u_inv_projection * dvec4(ndc_xy, window_depth * 2.0lf - 1.0lf, 1.0lf);
        double depth = -view.z / view.w;
        float result = float(depth);
        bool finite = !isinf(result) && !isnan(result);
        imageStore(u_depth_pass, texel, vec4(window_depth < 1.0lf && finite ? result : u_background_depth));
        imageStore(u_normal_pass, texel, vec4(unit * side, 0.0));
    }

#ifdef DENOISING
    vec3 albedo = vec3(0.0);  // the background has neither (Cycles writes nothing there)
    vec3 normal = vec3(0.0);
    if (normal_material.w != 0.0) {
        Material m = materials[int(abs(normal_material.w) + 0.5) - 1];
        if (material_has_surface_maps(m)) {
            vec2 surface = texelFetch(u_surface, texel, 0).rg;
            m = material_with_surface(m, surface.x, surface.y);
        }
        albedo = max(denoising_albedo(m, texelFetch(u_albedo, texel, 0).rgb), vec3(0.0));
        normal = u_world_to_camera * (unit * side);
    }
    imageStore(u_denoising_albedo, texel, running_mean(imageLoad(u_denoising_albedo, texel), albedo));
    imageStore(u_denoising_normal, texel, running_mean(imageLoad(u_denoising_normal, texel), normal));
#endif
}
