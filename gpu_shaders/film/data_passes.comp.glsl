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
// Bindings: u_depth (the G-buffer depth), u_normal_material (RGBA32F) read; images
// u_depth_pass (R32F) and u_normal_pass (RGBA32F) written, u_size texels.
layout(local_size_x = 8, local_size_y = 8) in;

layout(r32f) writeonly uniform image2D u_depth_pass;
layout(rgba32f) writeonly uniform image2D u_normal_pass;

uniform sampler2D u_depth;
uniform sampler2D u_normal_material;
uniform dmat4 u_inv_projection;
uniform ivec2 u_size;
uniform float u_background_depth;

void main() {
    ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(texel, u_size))) {
        return;
    }
    double window_depth = double(texelFetch(u_depth, texel, 0).r);
    dvec2 ndc_xy = (dvec2(texel) + 0.5lf) / dvec2(u_size) * 2.0lf - 1.0lf;
    dvec4 view = u_inv_projection * dvec4(ndc_xy, window_depth * 2.0lf - 1.0lf, 1.0lf);
    double depth = -view.z / view.w;
    float result = float(depth);
    bool finite = !isinf(result) && !isnan(result);
    imageStore(u_depth_pass, texel, vec4(window_depth < 1.0lf && finite ? result : u_background_depth));

    vec4 normal_material = texelFetch(u_normal_material, texel, 0);
    float len = length(normal_material.xyz);
    float side = sign(normal_material.w);
    vec3 unit = len > 0.0 ? normal_material.xyz / len : vec3(0.0);
    imageStore(u_normal_pass, texel, vec4(unit * side, 0.0));
}
