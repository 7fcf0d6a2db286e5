// SPDX-License-Identifier: GPL-3.0-or-later
// Blender's Magic Texture node: three sines of planes through the scaled point, then up to
// ten turbulence steps, each replacing one of the three channels by a sine or cosine of a
// signed sum of all three and amplifying it by Distortion. The channels are finally brought
// back near [0, 1] (halved by Distortion, flipped around 0.5).
//
// node_tex_magic(depth, vector, scale, distortion, out color, out fac)
//   Blender node "Magic Texture" (ShaderNodeTexMagic).
//   depth: the setting turbulence_depth, 0 to 10 (Blender default 2), passed as is.
//   Inputs (socket identifier: Blender default):
//     Vector:     Generated texture coordinates when unlinked (the caller supplies them)
//     Scale:      5.0
//     Distortion: 1.0
//   Outputs: Color, Fac (the mean of Color's three channels).
//
// The point is first reduced modulo 2 pi (every sine below has a whole-number frequency, so
// the value is unchanged) because a far-away point would otherwise lose all its precision in
// the sum of coordinates; Blender reduces it the same way, so far points agree too.
#ifndef HYBRID_NODES_TEX_MAGIC_GLSL
#define HYBRID_NODES_TEX_MAGIC_GLSL

// One turbulence step: channel MAGIC_TARGET[i] becomes
// MAGIC_SIGN[i] * (MAGIC_USES_SIN[i] ? sin : cos)(dot(MAGIC_TERMS[i], channels)).
const int MAGIC_TARGET[10] = int[10](1, 0, 2, 0, 1, 1, 0, 2, 0, 1);
const vec3 MAGIC_TERMS[10] = vec3[10](
    vec3(1, -1, 1), vec3(1, -1, -1), vec3(-1, -1, -1), vec3(-1, 1, -1), vec3(-1, 1, 1),
    vec3(-1, 1, 1), vec3(1, 1, 1), vec3(1, 1, -1), vec3(-1, -1, 1), vec3(1, -1, 1));
const bool MAGIC_USES_SIN[10] = bool[10](false, false, true, false, true, false, false, true, false, true);
const float MAGIC_SIGN[10] = float[10](-1.0, 1.0, 1.0, -1.0, -1.0, -1.0, 1.0, 1.0, -1.0, -1.0);

void node_tex_magic(int depth, vec3 vector, float scale, float distortion, out vec3 color, out float fac) {
    vec3 p = mod(vector * scale, 6.28318530717959);
    vec3 c = vec3(sin((p.x + p.y + p.z) * 5.0),
                  cos((-p.x + p.y - p.z) * 5.0),
                  -cos((-p.x - p.y + p.z) * 5.0));
    if (depth > 0) c *= distortion;
    for (int i = 0; i < min(depth, 10); ++i) {
        vec3 t = MAGIC_TERMS[i];
        float a = c.x * t.x + c.y * t.y + c.z * t.z;
        c[MAGIC_TARGET[i]] = MAGIC_SIGN[i] * (MAGIC_USES_SIN[i] ? sin(a) : cos(a)) * distortion;
    }
    if (distortion != 0.0) c /= 2.0 * distortion;
    color = vec3(0.5) - c;
    fac = (color.x + color.y + color.z) * (1.0 / 3.0);
}

#endif
