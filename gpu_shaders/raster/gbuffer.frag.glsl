// SPDX-License-Identifier: GPL-3.0-or-later
// Primary G-buffer, fragment stage (paper §3.1): like a standard deferred renderer, except
// that the alpha of the normal target holds the material index instead of a specular value.
//
// Outputs:
//   location 0 (RGBA32F): xyz = world shading normal as modelled (not flipped),
//                         w = material index + 1, negated when the triangle is seen from its
//                         back side (0 = background, cleared by the host)
//   location 1 (RGBA16F): rgb = albedo (base colour times its image texture), a = 1
//   location 2 (RGBA16F): rgb = emission scale (the emission image texture's colour, 1
//                         without one; the shading multiplies the material's emission), a = 1
// Depth: the hardware depth buffer (DEPTH32F); positions are reconstructed from it.
// Samplers: u_textures (textures.glsl), sampled with the UV derivatives of the fragment
// (mipmaps, anisotropic filtering).
#include "scene_layout.glsl"
#include "textures.glsl"

layout(std430, binding = 0) readonly buffer MaterialBuffer { Material materials[]; };

in vec3 v_world;
in vec3 v_normal;
in vec2 v_uv;
flat in int v_material;

layout(location = 0) out vec4 out_normal_material;
layout(location = 1) out vec4 out_albedo;
layout(location = 2) out vec4 out_emission_scale;

void main() {
    vec3 n = v_normal;
    float len2 = dot(n, n);
    if (!(len2 > 1e-20) || any(isinf(n)) || any(isnan(n))) {
        // Degenerate shading normal: fall back to the geometric normal of the triangle.
        n = cross(dFdx(v_world), dFdy(v_world));
        len2 = dot(n, n);
        n = len2 > 0.0 ? n * inversesqrt(len2) : vec3(0.0, 0.0, 1.0);
    } else {
        n *= inversesqrt(len2);
    }
    float id = float(v_material + 1);
    out_normal_material = vec4(n, gl_FrontFacing ? id : -id);
    // Derivatives outside any branch (they are undefined in non-uniform control flow).
    vec2 duv_dx = dFdx(v_uv);
    vec2 duv_dy = dFdy(v_uv);
    Material m = materials[v_material];
    out_albedo = vec4(material_albedo_grad(m, v_uv, duv_dx, duv_dy), 1.0);
    out_emission_scale = vec4(material_emission_scale_grad(m, v_uv, duv_dx, duv_dy), 1.0);
}
