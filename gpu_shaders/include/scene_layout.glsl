// SPDX-License-Identifier: GPL-3.0-or-later
// Scene buffers shared by every pass. Each struct mirrors a numpy dtype in
// hybrid_engine/scene/data.py (MATERIAL_DTYPE) or hybrid_engine/passes/scene_upload/scene_buffers.py (LIGHT_DTYPE,
// SHADOW_SLOT_DTYPE); the byte sizes are asserted on the Python side.

// struct Material                                           // total: 96 bytes
//   vec4 base_color_refl;  rgb = linear base colour, a = reflectivity (metal lobe weight)
//   vec4 emission_trans;   rgb = emitted radiance,   a = transmission (glass lobe weight)
//   vec4 params;           x = IOR, y = thickness (paper §3.4), z = roughness (GGX),
//                          w = reflectance of the diffuse layer's specular coat at normal
//                          incidence (0: none)
//   ivec4 textures;        x = base colour texture layer, y = emission texture layer
//                          (-1 = none; the texture multiplies the colour above, see
//                          textures.glsl), z = tangent-space normal map layer (-1 = none),
//                          w = its strength in thousandths
//   ivec4 textures2;       x = roughness image, y = metallic image: layer * 4 + channel
//                          (0..2 red, green, blue, 3 luminance), -1 = none (the factor above
//                          holds); z = alpha image: layer * 4 + channel (0..2 red, green,
//                          blue, 3 alpha; data.py ALPHA_CHANNELS), -1 = none; w = the first
//                          word of the material's node program (include/node_program.glsl),
//                          -1 = no node graph. A material with a program has the host's
//                          estimate of its closure in the slots above (transmission,
//                          emission, IOR; scene/node_program.py row_estimate) for what reads
//                          the row only.
//   vec4 params2;          x = alpha, the surface's coverage in [0, 1] (times the alpha
//                          image's value; alpha.glsl), y = cutoff the image's value is
//                          clipped at (0: none); zw reserved (0)
struct Material {
    vec4 base_color_refl;
    vec4 emission_trans;
    vec4 params;
    ivec4 textures;
    ivec4 textures2;
    vec4 params2;
};

// struct Light                                              // total: 64 bytes
//   vec4 position;   xyz = world position, w = size: point/spot radius, area half-size along
//                    its x axis, sun angular diameter (radians); softens shadows and widens
//                    highlights
//   vec4 direction;  xyz = unit direction the light points to, w = cos(spot half angle);
//                    area: w = half-size along its y axis
//   vec4 color;      rgb = colour * power (W, or W/m^2 for sun), w = spot blend; area: w =
//                    the angle of its x axis in area_basis(direction) (lighting.glsl)
//   ivec4 info;      x = kind (0 point, 1 sun, 2 spot, 3 area), y = first shadow slot
//                    (-1 = no shadow), z = shadow slot count, w = 1 for an elliptic area
//                    lamp (disk, ellipse), 0 for a rectangle or square
struct Light {
    vec4 position;
    vec4 direction;
    vec4 color;
    ivec4 info;
};

// struct ShadowSlot                                         // total: 96 bytes
//   mat4 view_proj;  world -> light clip space of this slot
//   ivec4 rect;      x, y = texel origin in the shadow atlas, z = size in texels, w unused
//   vec4 texel;      x = world size of one texel (orthographic) or its size per unit of
//                    distance from the light (perspective), y = 1 for perspective slots
struct ShadowSlot {
    mat4 view_proj;
    ivec4 rect;
    vec4 texel;
};

#define LIGHT_POINT 0
#define LIGHT_SUN 1
#define LIGHT_SPOT 2
#define LIGHT_AREA 3

const float PI = 3.14159265358979;
