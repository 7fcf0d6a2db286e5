// SPDX-License-Identifier: GPL-3.0-or-later
// Blender's Brick Texture node: rows of bricks in the xy plane of (Vector * Scale), each row
// Row Height tall; every offset_frequency-th row (counting from row 0) is shifted by offset
// times the brick width, and every squash_frequency-th row has its bricks squash times as
// wide. A brick is tinted between Color1 and Color2 by an integer noise of its row and column
// (plus Bias); a band of Mortar Size along its four sides is Mortar, blended in over Mortar
// Smooth of that band with a smoothstep.
//
// node_tex_brick(vector, color1, color2, mortar, scale, mortar_size, mortar_smooth, bias,
//                brick_width, row_height, offset, offset_frequency, squash, squash_frequency,
//                out color, out fac)
//   Blender node "Brick Texture" (ShaderNodeTexBrick).
//   Settings (node properties, passed as plain values; Blender default):
//     offset: 0.5 (0..1)            offset_frequency: 2 (int, 1..99)
//     squash: 1.0 (0..99)           squash_frequency: 2 (int, 1..99)
//   Inputs (socket identifier: Blender default):
//     Vector:        Generated texture coordinates when unlinked (the caller supplies them)
//     Color1: (0.8, 0.8, 0.8)    Color2: (0.2, 0.2, 0.2)    Mortar: (0.0, 0.0, 0.0)
//     Scale: 5.0    Mortar Size: 0.02    Mortar Smooth: 0.1    Bias: 0.0
//     Brick Width: 0.5    Row Height: 0.25
//   Outputs: Color, Fac (the mortar weight: 0 inside a brick, 1 in the mortar).
#ifndef HYBRID_NODES_TEX_BRICK_GLSL
#define HYBRID_NODES_TEX_BRICK_GLSL

// The per-brick random number in [0, 1): the classic integer lattice noise (a cubic
// polynomial in wrapping 32-bit arithmetic, constants 60493, 19990303, 1376312589) that
// Blender uses for brick tints, so each brick gets Blender's shade rather than a new one.
float node_tex_brick_noise(uint n) {
    n = (n + 1013u) & 0x7fffffffu;
    n = (n >> 13u) ^ n;
    uint m = (n * (n * n * 60493u + 19990303u) + 1376312589u) & 0x7fffffffu;
    return 0.5 * (float(m) / 1073741824.0);
}

void node_tex_brick(vec3 vector, vec3 color1, vec3 color2, vec3 mortar, float scale,
                    float mortar_size, float mortar_smooth, float bias, float brick_width,
                    float row_height, float offset, int offset_frequency, float squash,
                    int squash_frequency, out vec3 color, out float fac) {
    vec2 p = vector.xy * scale;
    int row = int(floor(p.y / row_height));
    float shift = 0.0;
    if (offset_frequency != 0 && squash_frequency != 0) {
        // Only whether the row is a multiple matters, so the sign of row is irrelevant
        // (GLSL leaves % of a negative operand undefined).
        if (abs(row) % squash_frequency == 0) brick_width *= squash;
        if (abs(row) % offset_frequency == 0) shift = brick_width * offset;
    }
    float along = p.x + shift;
    int column = int(floor(along / brick_width));
    float x = along - brick_width * float(column);
    float y = p.y - row_height * float(row);

    // Row in the high 16 bits, column in the low 16: one integer per brick.
    uint brick = (uint(row) << 16u) + (uint(column) & 0xffffu);
    float tint = clamp(node_tex_brick_noise(brick) + bias, 0.0, 1.0);

    float edge = min(min(x, y), min(brick_width - x, row_height - y));
    float weight;
    if (edge >= mortar_size) {
        weight = 0.0;
    } else if (mortar_smooth == 0.0) {
        weight = 1.0;
    } else {
        float depth = 1.0 - edge / mortar_size;  // 0 at the band's brick side, 1 at the joint
        float t = depth / mortar_smooth;
        weight = depth < mortar_smooth ? t * t * (3.0 - 2.0 * t) : 1.0;
    }
    vec3 face = weight != 1.0 ? mix(color1, color2, tint) : color1;
    color = face * (1.0 - weight) + mortar * weight;
    fac = weight;
}

#endif
