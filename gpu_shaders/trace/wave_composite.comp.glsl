// SPDX-License-Identifier: GPL-3.0-or-later
// Wave tracer, last step: the traced light of every specular pixel added to its deferred-
// shaded colour (as the megakernel's end: a non-finite sum keeps the shaded colour).
// Storage blocks: PixelAccum (read). Image u_color (RGBA32F, read and written).
// Uniforms: u_size.
layout(local_size_x = 8, local_size_y = 8) in;

layout(std430) readonly buffer PixelAccum { vec4 pixel_accum[]; };
layout(rgba32f) uniform image2D u_color;
uniform ivec2 u_size;

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(pixel, u_size))) return;
    vec4 traced = pixel_accum[pixel.y * u_size.x + pixel.x];
    if (traced.a == 0.0) return;  // no secondary rays: the deferred-shaded colour stands
    vec4 base = imageLoad(u_color, pixel);
    vec3 color = base.rgb + traced.rgb;
    if (any(isnan(color)) || any(isinf(color))) color = base.rgb;
    if (any(isnan(color)) || any(isinf(color))) color = vec3(0.0);
    imageStore(u_color, pixel, vec4(color, 1.0));
}
