// SPDX-License-Identifier: GPL-3.0-or-later
// Image textures of materials (hybrid_engine/passes/scene_upload/textures.py): every image of the scene is one
// layer of u_textures (RGBA16F, mipmapped, repeat wrapping, linear colour). A material's
// textures.x / textures.y (scene_layout.glsl) are the layers of its base-colour and emission
// images, -1 for none; a texture multiplies the material's colour (base_color_refl.rgb,
// emission_trans.rgb), and its alpha is not used. textures.z is its normal map.
//
// Two ways to pick the mip level: with UV derivatives (fragment shaders: the G-buffer pass,
// trilinear + anisotropic), or an explicit level (compute shaders, which have no
// derivatives: the tracer's ray cones, texture_lod below).
#ifndef HYBRID_TEXTURES_GLSL
#define HYBRID_TEXTURES_GLSL
#include "scene_layout.glsl"

uniform sampler2DArray u_textures;

// Texture colour of `layer` (>= 0) at uv, or white when the material has none (layer < 0).
vec3 texture_rgb_grad(int layer, vec2 uv, vec2 duv_dx, vec2 duv_dy) {
    if (layer < 0) return vec3(1.0);
    return textureGrad(u_textures, vec3(uv, float(layer)), duv_dx, duv_dy).rgb;
}

vec3 texture_rgb_lod(int layer, vec2 uv, float lod) {
    if (layer < 0) return vec3(1.0);
    return textureLod(u_textures, vec3(uv, float(layer)), lod).rgb;
}

// Mip level for a footprint of `footprint_world` metres on a triangle whose UVs cover
// `uv_per_world` UV units per metre (sqrt of the UV area over the world area): log2 of the
// footprint in texels of the array's layers. Degenerate input gives level 0.
float texture_lod(float footprint_world, float uv_per_world) {
    vec2 size = vec2(textureSize(u_textures, 0).xy);
    float texels = footprint_world * uv_per_world * sqrt(size.x * size.y);
    return (texels > 1.0 && !isinf(texels)) ? log2(texels) : 0.0;
}

// The material's albedo and the factor its emission is multiplied by (the emission
// texture's colour, or 1) at uv.
vec3 material_albedo_grad(Material m, vec2 uv, vec2 duv_dx, vec2 duv_dy) {
    return m.base_color_refl.rgb * texture_rgb_grad(m.textures.x, uv, duv_dx, duv_dy);
}
vec3 material_emission_scale_grad(Material m, vec2 uv, vec2 duv_dx, vec2 duv_dy) {
    return texture_rgb_grad(m.textures.y, uv, duv_dx, duv_dy);
}
vec3 material_albedo_lod(Material m, vec2 uv, float lod) {
    return m.base_color_refl.rgb * texture_rgb_lod(m.textures.x, uv, lod);
}
vec3 material_emission_lod(Material m, vec2 uv, float lod) {
    return m.emission_trans.rgb * texture_rgb_lod(m.textures.y, uv, lod);
}

// The value a roughness or metallic image gives (textures2: layer * 4 + channel).
float texture_value(vec4 texel, int selector) {
    int channel = selector & 3;
    return channel == 3 ? dot(texel.rgb, vec3(0.2126, 0.7152, 0.0722)) : texel[channel];
}

// The material with its roughness and metallic images applied at the texel fetches given
// (the metal layer takes its weight from the image; the glass layer keeps what is left).
Material material_with_surface(Material m, float roughness, float metallic) {
    if (m.textures2.x >= 0) m.params.z = clamp(roughness, 0.0, 1.0);
    if (m.textures2.y >= 0) {
        m.base_color_refl.a = clamp(metallic, 0.0, 1.0);
        m.emission_trans.a = min(m.emission_trans.a, 1.0 - m.base_color_refl.a);
    }
    return m;
}
bool material_has_surface_maps(Material m) { return max(m.textures2.x, m.textures2.y) >= 0; }
// The material at uv (roughness and metallic images sampled at mip level lod).
Material material_at_lod(Material m, vec2 uv, float lod) {
    if (!material_has_surface_maps(m)) return m;
    float r = m.params.z, k = m.base_color_refl.a;
    if (m.textures2.x >= 0) r = texture_value(textureLod(u_textures, vec3(uv, float(m.textures2.x >> 2)), lod), m.textures2.x);
    if (m.textures2.y >= 0) k = texture_value(textureLod(u_textures, vec3(uv, float(m.textures2.y >> 2)), lod), m.textures2.y);
    return material_with_surface(m, r, k);
}
vec2 material_surface_grad(Material m, vec2 uv, vec2 duv_dx, vec2 duv_dy) {
    float r = m.params.z, k = m.base_color_refl.a;
    if (m.textures2.x >= 0) r = texture_value(textureGrad(u_textures, vec3(uv, float(m.textures2.x >> 2)), duv_dx, duv_dy), m.textures2.x);
    if (m.textures2.y >= 0) k = texture_value(textureGrad(u_textures, vec3(uv, float(m.textures2.y >> 2)), duv_dx, duv_dy), m.textures2.y);
    return vec2(r, k);
}

// Blender's Normal Map node (tangent space): the map's colour is a normal n * 0.5 + 0.5 in
// the frame (t, b, n) of the UVs' u and v directions; strength blends it with the shading
// normal n. t and b need not be unit or orthogonal to n (they are the surface's dp/du and
// dp/dv directions); without a map, n comes back unchanged.
bool material_has_normal_map(Material m) { return m.textures.z >= 0; }
vec3 apply_normal_map(Material m, vec3 n, vec3 t, vec3 b, vec3 texel) {
    vec3 ts = texel * 2.0 - 1.0;
    t = t - n * dot(n, t);
    b = b - n * dot(n, b);
    float lt = dot(t, t), lb = dot(b, b);
    if (!(lt > 1e-30) || !(lb > 1e-30)) return n;
    vec3 mapped = normalize(t * inversesqrt(lt) * ts.x + b * inversesqrt(lb) * ts.y + n * max(ts.z, 1e-3));
    float strength = float(m.textures.w) * 1e-3;
    vec3 blended = mix(n, mapped, strength);
    return dot(blended, blended) > 1e-12 ? normalize(blended) : n;
}
vec3 material_normal_grad(Material m, vec3 n, vec3 t, vec3 b, vec2 uv, vec2 duv_dx, vec2 duv_dy) {
    if (!material_has_normal_map(m)) return n;
    return apply_normal_map(m, n, t, b, textureGrad(u_textures, vec3(uv, float(m.textures.z)), duv_dx, duv_dy).rgb);
}
vec3 material_normal_lod(Material m, vec3 n, vec3 t, vec3 b, vec2 uv, float lod) {
    if (!material_has_normal_map(m)) return n;
    return apply_normal_map(m, n, t, b, textureLod(u_textures, vec3(uv, float(m.textures.z)), lod).rgb);
}

#endif
