// SPDX-License-Identifier: GPL-3.0-or-later
// The denoiser's temporal step (Schied et al. 2017, "Spatiotemporal Variance-Guided
// Filtering", §4.1): each pixel of this frame's ambient estimate (rgb diffuse irradiance,
// a sky visibility) is blended with what the same surface point held last frame.
//
// The point is found through the camera's motion: this pixel's world position (its depth
// through this frame's inverse view-projection) projected by last frame's view-projection
// gives a place between four of last frame's texels. Where none of them showed this surface
// and the pixel's instance moved since last frame, the point and normal are taken back by
// its move (include/surface_motion.glsl, passes/surface_motion/) and looked up again. The camera's
// lookup goes first: a moving object's light is mostly the room's light where it now stands,
// so a face sliding along its own plane is best served by the history of that place. Each of the four is
// kept (with its bilinear weight) only where it showed the same surface: the same material,
// a normal within u_normal_cos, and a point on this pixel's tangent plane within
// u_plane_tolerance of the distance to the camera. With u_history_filter the colour is
// fetched instead by a Catmull-Rom cubic over the 4x4 texels around the place, held within
// the range of the inner four (its negative lobes overshoot at an edge), where all sixteen
// showed this surface: a camera that moves resamples the history at a sub-pixel shift every
// frame, and the bilinear fetch's blur, small each time, adds up over the history's length.
// The moments and the history length stay bilinear (a cubic's overshoot would make a
// variance negative). A moved object therefore keeps its history, and what it uncovers
// loses its own (last frame showed the object there, at another depth), while a camera
// that moves keeps the history of everything it still sees. With no tap kept the pixel starts
// over (history length 1); else its history length n grows by one and it takes
// alpha = max(1 / n, u_alpha_color) of this frame (the mean of the frames so far, then an
// exponential average), its moments alpha = max(1 / n, u_alpha_moments).
//
// Also writes this frame's surface texels (world point and normal, include/denoise.glsl),
// which the later steps read in one fetch per tap, and the next frame's reprojection too.
//
// Bindings: u_ambient (RGBA32F, this frame's estimate), u_depth (DEPTH32F), u_normal_material
//   (RGBA32F), u_prev_color (RGBA32F), u_prev_moments (RGBA32F: guide means and means of
//   squares), u_prev_surface (RGBA32F), u_prev_length (RG32F: history length, surface id)
//   read; images u_integrated (RGBA32F), u_moments (RGBA32F), u_surface (RGBA32F), u_length
//   (RG32F) written; with u_moving, surface_motion.glsl's u_motion and u_motion_turn read.
// Workgroup 8x8: square tiles keep the four taps of neighbouring pixels together.
#include "denoise.glsl"
#include "surface_motion.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

uniform sampler2D u_ambient;
uniform sampler2D u_depth;
uniform sampler2D u_normal_material;
uniform sampler2D u_prev_color;
uniform sampler2D u_prev_moments;
uniform sampler2D u_prev_surface;
uniform sampler2D u_prev_length;
uniform mat4 u_inv_view_proj;
uniform mat4 u_prev_view_proj;
uniform vec3 u_camera_position;
uniform int u_orthographic;
uniform ivec2 u_size;
uniform int u_history_valid;  // 0: no last frame of this size to blend with
uniform float u_alpha_color;
uniform float u_alpha_moments;
uniform float u_plane_tolerance;
uniform float u_normal_cos;
uniform float u_max_length;  // the longest history counted (denoise.py max_length: shorter at a rest)
uniform int u_history_filter;  // 0: bilinear fetch of the history; 1: Catmull-Rom, clamped
uniform int u_moving;  // 0: no instance moved since last frame (surface_motion.glsl's images are not read)

// The Catmull-Rom spline's weights of the four texels around a point at fraction t between
// the middle two: an interpolating cubic, so a history fetched at a half-pixel shift keeps
// its detail, where the bilinear fetch halves a one-pixel feature's contrast every frame.
vec4 catmull_rom_weights(float t) {
    float t2 = t * t, t3 = t2 * t;
    return 0.5 * vec4(-t3 + 2.0 * t2 - t, 3.0 * t3 - 5.0 * t2 + 2.0, -3.0 * t3 + 4.0 * t2 + t, t3 - t2);
}

float catmull_rom_abs_sum(vec4 w) {
    return abs(w.x) + abs(w.y) + abs(w.z) + abs(w.w);
}

layout(rgba32f) writeonly uniform image2D u_integrated;
layout(rgba32f) writeonly uniform image2D u_moments;
layout(rgba32f) writeonly uniform image2D u_surface;
layout(rg32f) writeonly uniform image2D u_length;

// Last frame's history of the surface point p (normal n, surface id, camera distance scale):
// returns the weight kept (0: last frame did not see it), with the colour, moments and
// length summed times their weights.
float history_at(vec3 p, vec3 n, int id, float scale, out vec4 prev_color, out vec4 prev_moments,
                 out float prev_length) {
    prev_color = vec4(0.0);
    prev_moments = vec4(0.0);
    prev_length = 0.0;
    float kept = 0.0;
    vec4 clip = u_prev_view_proj * vec4(p, 1.0);
    if (u_history_valid == 0 || !(clip.w > 0.0)) return 0.0;
    // Last frame's texel coordinates of p (texel centres at integers).
    vec2 at = (clip.xy / clip.w * 0.5 + 0.5) * vec2(u_size) - 0.5;
    vec2 base = floor(at);
    vec2 f = at - base;
    vec4 wx = u_history_filter != 0 ? catmull_rom_weights(f.x) : vec4(0.0, 1.0 - f.x, f.x, 0.0);
    vec4 wy = u_history_filter != 0 ? catmull_rom_weights(f.y) : vec4(0.0, 1.0 - f.y, f.y, 0.0);
    // The sharp fetch's sum, and the bilinear one over the four inner taps, which also
    // bounds it: its negative lobes may overshoot the texels it lies between.
    vec4 sharp = vec4(0.0);
    float sharp_kept = 0.0;
    int outer_taps = u_history_filter != 0 ? 16 : 0;
    vec4 low = vec4(1e30), high = vec4(-1e30);
    // No branch per tap: a tap off the image or of another surface weighs 0.
    for (int i = 0; i < 16; ++i) {
        ivec2 offset = ivec2(i & 3, i >> 2);
        bool inner = all(greaterThanEqual(offset, ivec2(1))) && all(lessThanEqual(offset, ivec2(2)));
        if (!inner && outer_taps == 0) continue;
        ivec2 want = ivec2(base) + offset - 1;
        ivec2 q = clamp(want, ivec2(0), u_size - 1);
        vec2 prev_length_id = texelFetch(u_prev_length, q, 0).rg;
        vec4 prev_surface = texelFetch(u_prev_surface, q, 0);
        bool same = want == q && int(prev_length_id.y + 0.5) == id
                    && dot(denoise_surface_normal(prev_surface), n) >= u_normal_cos
                    && denoise_plane_offset(p, n, prev_surface.xyz, scale) <= u_plane_tolerance;
        vec4 color = texelFetch(u_prev_color, q, 0);
        float w_sharp = same ? wx[offset.x] * wy[offset.y] : 0.0;
        sharp += w_sharp * color;
        sharp_kept += same ? abs(wx[offset.x] * wy[offset.y]) : 0.0;
        if (!inner) continue;
        vec2 fb = vec2(offset - 1) * f + vec2(2 - offset) * (1.0 - f);
        float w = same ? fb.x * fb.y : 0.0;
        prev_color += w * color;
        prev_moments += w * texelFetch(u_prev_moments, q, 0);
        prev_length += w * prev_length_id.x;
        kept += w;
        low = same ? min(low, color) : low;
        high = same ? max(high, color) : high;
    }
    // The sharp fetch counts only where all sixteen taps showed this surface (their
    // absolute weights sum to the kernel's whole); near an edge of the history the
    // bilinear fetch over the taps kept is all there is.
    if (outer_taps != 0 && kept > 1e-3 && sharp_kept >= catmull_rom_abs_sum(wx) * catmull_rom_abs_sum(wy) - 1e-4) {
        prev_color = clamp(sharp, low, high) * kept;
    }
    return kept;
}

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(pixel, u_size))) return;
    vec4 nm = texelFetch(u_normal_material, pixel, 0);
    float depth = texelFetch(u_depth, pixel, 0).r;
    vec4 current = texelFetch(u_ambient, pixel, 0);
    vec2 g = denoise_guides(current);
    vec4 moments = vec4(g.x, g.x * g.x, g.y, g.y * g.y);
    int id = denoise_surface_id(nm.w);
    if (id == 0) {  // background: nothing to filter
        imageStore(u_integrated, pixel, current);
        imageStore(u_moments, pixel, moments);
        imageStore(u_length, pixel, vec4(0.0));
        imageStore(u_surface, pixel, vec4(0.0, 0.0, 0.0, uintBitsToFloat(DENOISE_BACKGROUND)));
        return;
    }

    vec3 p_now = denoise_unproject(u_inv_view_proj, pixel, u_size, depth);
    vec3 n_now = nm.xyz;
    imageStore(u_surface, pixel, denoise_pack_surface(p_now, n_now));
    float scale = u_orthographic != 0 ? 1.0 : distance(p_now, u_camera_position);
    vec4 prev_color, prev_moments;
    float prev_length;
    // The surface that stood at this point last frame (the camera's motion alone): a moving
    // object's light is mostly the room's light where it now stands, so while its surface
    // still lies there (a face sliding along its own plane) that history fits best.
    float kept = history_at(p_now, n_now, id, scale, prev_color, prev_moments, prev_length);
    vec3 p = p_now, n = n_now;
    if (kept <= 1e-3 && u_moving != 0 && surface_moved_back(pixel, p, n)) {
        // Else, where this very point of a moved instance was last frame, and its normal then.
        kept = history_at(p, n, id, scale, prev_color, prev_moments, prev_length);
    }
    vec4 integrated = current;
    float length_now = 1.0;
    if (kept > 1e-3) {
        prev_color /= kept;
        prev_moments /= kept;
        length_now = min(floor(prev_length / kept + 0.5) + 1.0, u_max_length);
        float alpha = max(1.0 / length_now, u_alpha_color);
        float alpha_moments = max(1.0 / length_now, u_alpha_moments);
        integrated = mix(prev_color, current, alpha);
        moments = mix(prev_moments, moments, alpha_moments);
    }
    imageStore(u_integrated, pixel, integrated);
    imageStore(u_moments, pixel, moments);
    imageStore(u_length, pixel, vec4(length_now, float(id), 0.0, 0.0));
}
