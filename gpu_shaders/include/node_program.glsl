// SPDX-License-Identifier: GPL-3.0-or-later
// The node-program interpreter: a material's shader node graph, compiled into words by
// hybrid_engine/scene/node_program.py (encoding: hybrid_engine/scene/node_codes.py), run at
// one shading point. One shader for every graph: an edit of the graph is an upload of words,
// never a compile (docs/ARCHITECTURE.md "Shader node programs"). Compiled into a shader only
// with NODE_PROGRAMS defined, which the host defines when some material has a graph
// (GPUScene.defines); a material's program starts at word Material.textures2.w (-1: none).
//
// Storage blocks: NodeProgram (the words of every material), NodeObjects (per instance of the
// instance table: world-to-object map, texture space, location, colour, random; written by
// hybrid_engine/passes/scene_upload/node_programs.py). Sampler: u_textures (textures.glsl).
//
// The closure. A shader socket carries NODE_CLOSURE_REGISTERS registers of weighted sums
// (Cycles' SVM instead keeps a list of closures, each with its own BSDF): rgb = weight x base
// colour and a = the surface weight w; metallic, roughness, transmission, IOR times w;
// emission (summed) and the Transparent weight t; normal and specular coat times w; and the
// Glossy lobes' own sums (weight x tint and weight; weight x roughness), which registers 0-3
// hold too. Mix Shader mixes the sums by its factor, Add Shader adds them. At the Material
// Output (node_closure_of, "closure lobes" below) the parameters are the w-weighted means
// (one BSDF whose lobes are the means of the mixed ones'), the base colour is the sum over
// the alpha (so that an Emission mixed with a Diffuse darkens the diffuse as Cycles' closure
// weights do), alpha = 1 - t, emission the sum; except that Glossy lobes over a base with a
// diffuse part become that diffuse layer's coat (lobes, not means). What this cannot show:
// two lobes of different colours or roughnesses where no layer holds them (a tinted Glossy
// over a diffuse is a white coat of the tint's luminance; a Glossy mixed with a metal or a
// glass is one lobe of the mean colour and roughness), as the engine's shading model
// (shading.glsl: one base colour, one roughness, one white coat) cannot hold them.
#ifndef HYBRID_NODE_PROGRAM_GLSL
#define HYBRID_NODE_PROGRAM_GLSL
#include "scene_layout.glsl"
#include "textures.glsl"
#include "include/nodes/tex_white_noise.glsl"
// -- textures: each family's node functions only where a program of the scene uses it
// (node_codes.TEXTURE_FAMILIES, GPUScene.defines), so the interpreter stays small elsewhere.
#ifdef NODE_FAMILY_NOISE
#include "include/nodes/tex_noise.glsl"
#include "include/nodes/tex_wave.glsl"
#endif
#ifdef NODE_FAMILY_VORONOI
#include "include/nodes/tex_voronoi.glsl"
#endif
#ifdef NODE_FAMILY_PATTERN
#include "include/nodes/tex_checker.glsl"
#include "include/nodes/tex_brick.glsl"
#include "include/nodes/tex_gradient.glsl"
#include "include/nodes/tex_magic.glsl"
#endif
#ifdef NODE_FAMILY_IMAGE
#include "include/nodes/tex_image_mapping.glsl"
#endif
#include "node_material.glsl"
// closure lobes: the Glossy layer as the diffuse layer's coat
#include "coat.glsl"
// -- colour and vector: each family's node functions only where a graph uses it
// (node_codes.FAMILY_*, GPUScene.defines).
#ifdef NODE_FAMILY_COLOUR
#include "include/nodes/color_mix.glsl"
#include "include/nodes/color_adjust.glsl"
#include "include/nodes/curves.glsl"
#include "include/nodes/separate_combine.glsl"
#endif
#ifdef NODE_FAMILY_VECTOR
#include "include/nodes/vector_math.glsl"
#include "include/nodes/map_range.glsl"
#include "include/nodes/mapping.glsl"
#endif
#ifdef NODE_WORLD
// The World's graph, run per direction by lighting/world_bake.comp.glsl: its Environment
// Textures' images as layers of one array (largest size), and the Sky Texture's models.
#include "include/nodes/tex_sky.glsl"
#include "include/nodes/tex_environment.glsl"
uniform sampler2DArray u_world_images;
uniform float u_world_lod;  // the images' mip level whose texels match the bake's
#endif

// Opcodes, operand kinds, implicit values: hybrid_engine/scene/node_codes.py.
#define NODE_OP_OUTPUT 1u
#define NODE_OP_VALUE 2u
#define NODE_OP_TEX_COORD 3u
#define NODE_OP_UVMAP 4u
#define NODE_OP_GEOMETRY 5u
#define NODE_OP_OBJECT_INFO 6u
#define NODE_OP_FRESNEL 7u
#define NODE_OP_LAYER_WEIGHT 8u
#define NODE_OP_LIGHT_PATH 9u
#define NODE_OP_SEPARATE_XYZ 10u
#define NODE_OP_COMBINE_XYZ 11u
#define NODE_OP_TEX_WHITE_NOISE 12u
#define NODE_OP_TEX_IMAGE 13u
#define NODE_OP_NORMAL_MAP 14u
#define NODE_OP_BSDF_PRINCIPLED 32u
#define NODE_OP_BSDF_DIFFUSE 33u
#define NODE_OP_BSDF_GLOSSY 34u
#define NODE_OP_BSDF_GLASS 35u
#define NODE_OP_BSDF_REFRACTION 36u
#define NODE_OP_BSDF_TRANSPARENT 37u
#define NODE_OP_EMISSION 38u
#define NODE_OP_MIX_SHADER 39u
#define NODE_OP_ADD_SHADER 40u
// -- colour and vector (41-79)
#define NODE_OP_MATH 41u
#define NODE_OP_VECTOR_MATH 42u
#define NODE_OP_MIX 43u
#define NODE_OP_MIX_RGB 44u
#define NODE_OP_COLOR_RAMP 45u
#define NODE_OP_CURVE_RGB 46u
#define NODE_OP_CURVE_VECTOR 47u
#define NODE_OP_CURVE_FLOAT 48u
#define NODE_OP_HUE_SAT 49u
#define NODE_OP_INVERT 50u
#define NODE_OP_GAMMA 51u
#define NODE_OP_BRIGHT_CONTRAST 52u
#define NODE_OP_MAP_RANGE 53u
#define NODE_OP_CLAMP 54u
#define NODE_OP_SEPARATE_COLOR 55u
#define NODE_OP_COMBINE_COLOR 56u
#define NODE_OP_MAPPING 57u
#define NODE_OP_VECTOR_ROTATE 58u
// -- shading normals and bump (60-69)
#define NODE_OP_BUMP_OFFSET 60u
#define NODE_OP_BUMP 61u
// -- attributes (70-79)
#define NODE_OP_ATTRIBUTE 70u
// -- world (hybrid_engine/passes/lighting/world_bake.py)
#define NODE_OP_BACKGROUND 120u
#define NODE_OP_TEX_ENVIRONMENT 121u
#define NODE_OP_TEX_SKY 122u
// -- textures
#define NODE_OP_TEX_NOISE 80u
#define NODE_OP_TEX_WAVE 81u
#define NODE_OP_TEX_VORONOI 82u
#define NODE_OP_TEX_CHECKER 83u
#define NODE_OP_TEX_BRICK 84u
#define NODE_OP_TEX_GRADIENT 85u
#define NODE_OP_TEX_MAGIC 86u
#define NODE_CONSTANT 0x80000000u
#define NODE_IMPLICIT 0x40000000u
#define NODE_IMPLICIT_NORMAL 0u
#define NODE_IMPLICIT_UV 1u
#define NODE_IMPLICIT_GENERATED 2u
#define NODE_REGISTERS 32
#define NODE_MAX_OPERANDS 16
#define NODE_MAX_OUTPUTS 8
#define NODE_MAX_INSTRUCTIONS 256
// -- closure lobes: a shader value's registers (scene/node_program.py CLOSURE_REGISTERS)
#define NODE_CLOSURE_REGISTERS 6
// -- end of closure lobes

layout(std430) readonly buffer NodeProgram { uint node_words[]; };

// struct NodeObject (node_programs.py NODE_OBJECT_DTYPE)      // total: 128 bytes
//   vec4 to_object[3];   rows of the world-to-object affine map
//   vec4 location;       xyz = the object's origin in world space, w = Object Info Random
//   vec4 color;          Object Info Color (Blender's object colour; white without one)
//   vec4 space_min;      xyz = the mesh's object-space bounds' minimum (Generated's origin)
//   vec4 space_size;     xyz = their extent (Generated divides by it; 0 where flat)
//   ivec4 rows;          x = first world row (triangle), y = triangles
struct NodeObject {
    vec4 to_object[3];
    vec4 location;
    vec4 color;
    vec4 space_min;
    vec4 space_size;
    ivec4 rows;
};
// Row 0 is a header (rows.x = the instance count); instance k is row k + 1.
layout(std430) readonly buffer NodeObjects { NodeObject node_objects[]; };

// The render camera, for Texture Coordinate's Camera and Window (the frame's primary view,
// RasterView.uniforms): world to camera space as Cycles has it (+Z in front of the camera,
// where Blender's camera object looks down its -Z), and world to clip space (Window is its
// perspective divide mapped to 0..1). At a ray hit Cycles gives the hit's own camera-space
// and window position, and so does the interpreter.
uniform mat4 u_node_world_to_camera;
uniform mat4 u_node_world_to_clip;

// What the input nodes read at a shading point; the caller fills every field.
struct ShadingPoint {
    vec3 position;    // world space
    vec3 surface;     // where the mesh's interpolated attributes are read (Generated, Color
                      //   Attribute): the position, but for a back face's Bump step, which
                      //   runs backwards there as the UV's does (node_bump_offset)
    vec3 normal;      // unit shading normal facing the incoming ray (Cycles' N: flipped on backfaces)
    vec3 geometric;   // unit true normal, facing alike
    vec3 incoming;    // unit vector from the point towards where the ray came from (Geometry Incoming)
    vec2 uv;          // the active UV map
    vec2 duv_dx;      // UV derivatives per pixel (fragment stage; Image Texture's filter)
    vec2 duv_dy;
    vec3 dp_dx;       // the footprint's two axes on the surface (Cycles' dP: the Bump's
    vec3 dp_dy;       //   offsets and tangent plane; node_footprint_axes); zero: none
    vec2 uv_dx;       // the UV's change along dp_dx and dp_dy (the Bump's shifted UVs)
    vec2 uv_dy;
    float lod;        // < 0: sample with the derivatives; else the ray cone's mip level (compute)
    vec3 dp_du;       // the surface's direction of increasing u and v (Normal Map's tangent
    vec3 dp_dv;       //   frame); zero where the UVs are degenerate
    bool backfacing;
    int ray_depth;    // 0: the camera ray (Light Path Is Camera Ray, Ray Depth); < 0: a shadow
                      //   ray's, of depth -ray_depth (node_shadow_ray_depth)
    int row;          // world row (triangle) of the surface: finds its instance; -1 unknown
    int material;
};

// The ray depth a shading point of a shadow ray holds: Cycles' shadow ray tests a blocker's
// transparency with Light Path's Is Shadow Ray set and its Ray Depth one more than the
// bounce the ray left from (svm light_path.h), so an artist's "no shadow from this glass"
// (a Transparent BSDF mixed in by Is Shadow Ray) holds. Negative, so that the one number
// tells both without a field more in every shading point.
int node_shadow_ray_depth(int bounce) {
    return -1 - max(bounce, 0);
}

// A shading point that knows no footprint, no UV derivatives and no tangent frame (the
// World's direction-only bake, the alpha tests, the lit cube map's texels): `normal` and
// `geometric` unit and as modelled, `incoming` towards where the point is seen from; both
// normals are turned to face it, as Cycles' N and Ng are. The caller sets what it knows beyond.
ShadingPoint node_plain_point(vec3 position, vec3 normal, vec3 geometric, vec3 incoming, vec2 uv, float lod,
                              int depth, int row, int material) {
    ShadingPoint sp;
    sp.position = sp.surface = position;
    sp.backfacing = dot(normal, incoming) < 0.0;
    sp.normal = sp.backfacing ? -normal : normal;
    sp.geometric = dot(geometric, incoming) < 0.0 ? -geometric : geometric;
    sp.incoming = incoming;
    sp.uv = uv;
    sp.duv_dx = vec2(0.0);
    sp.duv_dy = vec2(0.0);
    sp.dp_dx = vec3(0.0);
    sp.dp_dy = vec3(0.0);
    sp.uv_dx = vec2(0.0);
    sp.uv_dy = vec2(0.0);
    sp.lod = lod;
    sp.dp_du = vec3(0.0);
    sp.dp_dv = vec3(0.0);
    sp.ray_depth = depth;
    sp.row = row;
    sp.material = material;
    return sp;
}

// The closure the program returns (the surface as the engine's shading model holds it).
struct NodeClosure {
    vec3 base_color;
    float metallic;
    float roughness;
    float transmission;
    float ior;
    float specular;      // reflectance of the diffuse layer's coat at normal incidence
    vec3 emission;       // colour x strength
    float alpha;
    vec3 normal;         // unit shading normal as modelled (not flipped)
};

#ifndef NODE_GENERATED_ONLY
// Whether the instruction's output o is read by a later one (its register; NO_REGISTER:
// nobody reads it). A node computes an output only where it is read, as Cycles' SVM does
// (stack_valid): the generator writes a constant in its place (node_codegen.py), so the
// compiler drops an unread output's code; here it is one word, the same for the whole
// program, so the branch it guards is uniform.
#define node_output_read(o) (uint(o) < n_out && node_words[out_at + uint(o)] < uint(NODE_REGISTERS))
vec4 node_reg[NODE_REGISTERS];
vec4 node_in[NODE_MAX_OPERANDS];
vec4 node_out[NODE_MAX_OUTPUTS];
#endif

// The NodeObjects row of the instance whose world rows hold `row` (-1 when unknown):
// instances lie in row order.
int node_object_of(int row) {
    int count = node_objects[0].rows.x;
    if (row < 0 || count <= 0) return -1;
    int lo = 1, hi = count;
    while (lo < hi) {
        int mid = (lo + hi + 1) >> 1;
        if (node_objects[mid].rows.x <= row) lo = mid; else hi = mid - 1;
    }
    return lo;
}

vec3 node_to_object(int k, vec3 p, float w) {
    if (k < 0) return p;
    vec4 q = vec4(p, w);
    return vec3(dot(node_objects[k].to_object[0], q), dot(node_objects[k].to_object[1], q),
                dot(node_objects[k].to_object[2], q));
}

// -- attributes: Color Attribute and Attribute (the store's block and lookup) where a
// program of the scene reads one (node_codes.FAMILY_ATTRIBUTES).
#ifdef NODE_ATTRIBUTES
#include "node_attributes.glsl"
#endif
// -- end of attributes

// Texture Coordinate Generated: the point in its mesh's texture space (scene_upload/
// node_programs.py texture_space), 0.5 across an axis the mesh is flat along.
vec3 node_generated(ShadingPoint sp) {
    int k = node_object_of(sp.row);
    if (k < 0) return sp.surface;
    vec3 size = node_objects[k].space_size.xyz;
    vec3 p = node_to_object(k, sp.surface, 1.0) - node_objects[k].space_min.xyz;
    return vec3(size.x > 0.0 ? p.x / size.x : 0.5, size.y > 0.0 ? p.y / size.y : 0.5,
                size.z > 0.0 ? p.z / size.z : 0.5);
}

vec4 node_convert(vec4 v, uint code) {
    if (code == 1u) return vec4(v.xxx, 1.0);
    if (code == 2u) return vec4(dot(v.rgb, vec3(0.2126, 0.7152, 0.0722)));
    if (code == 3u) return vec4((v.x + v.y + v.z) * (1.0 / 3.0));
    return v;
}

#ifndef NODE_GENERATED_ONLY
// One operand at word pc (advanced past it).
vec4 node_operand(inout uint pc, ShadingPoint sp) {
    uint w = node_words[pc++];
    if ((w & NODE_CONSTANT) != 0u) {
        uint n = w & 7u;
        vec4 v = vec4(0.0, 0.0, 0.0, 1.0);
        for (uint i = 0u; i < n && i < 4u; ++i) v[i] = uintBitsToFloat(node_words[pc++]);
        return v;
    }
    uint convert = (w >> 16) & 3u;
    if ((w & NODE_IMPLICIT) != 0u) {
        uint code = w & 0xffu;
        vec4 v = code == NODE_IMPLICIT_NORMAL ? vec4(sp.normal, 0.0)
               : code == NODE_IMPLICIT_UV ? vec4(sp.uv, 0.0, 0.0) : vec4(node_generated(sp), 0.0);
        return node_convert(v, convert);
    }
    return node_convert(node_reg[min(w & 0xffffu, uint(NODE_REGISTERS - 1))], convert);
}
#endif

// Cycles' Fresnel of a dielectric of relative index eta at cos(theta) = cosi.
float node_fresnel_dielectric(float cosi, float eta) {
    float c = abs(cosi);
    float g = eta * eta - 1.0 + c * c;
    if (g <= 0.0) return 1.0;
    g = sqrt(g);
    float a = (g - c) / (g + c);
    float b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
    return 0.5 * a * a * (1.0 + b * b);
}

vec3 node_unit(vec3 v, vec3 fallback) {
    float l = dot(v, v);
    return l > 1e-20 && !isinf(l) && !isnan(l) ? v * inversesqrt(l) : fallback;
}

// One BSDF's closure as a shader socket's four registers (weights: module header).
void node_bsdf(float w, vec3 base, float metallic, float roughness, float transmission, float ior,
               float specular, vec3 n, vec3 emission, float transparent,
               out vec4 c0, out vec4 c1, out vec4 c2, out vec4 c3) {
    c0 = vec4(w * max(base, vec3(0.0)), w);
    c1 = w * vec4(clamp(metallic, 0.0, 1.0), clamp(roughness, 0.0, 1.0),
                  clamp(transmission, 0.0, 1.0), max(ior, 1.0));
    c2 = vec4(max(emission, vec3(0.0)), transparent);
    c3 = w * vec4(n, clamp(specular, 0.0, 1.0));
}

vec4 node_image(int layer, vec2 uv, ShadingPoint sp) {
    if (layer < 0) return vec4(1.0, 0.0, 1.0, 1.0);  // Blender's colour of a missing image
    vec3 at = vec3(uv, float(layer));
    return sp.lod < 0.0 ? textureGrad(u_textures, at, sp.duv_dx, sp.duv_dy) : textureLod(u_textures, at, sp.lod);
}

#ifdef NODE_FAMILY_IMAGE
// -- textures: the Image Texture's extension and interpolation on the layer's texels
// (include/nodes/tex_image_mapping.glsl does the arithmetic, this the fetches). Linear with
// Repeat is the array's own trilinear filter (node_image); every other pair reads texels by
// hand, because the array's sampler only repeats. Closest reads the full-size image, as
// Cycles does (no mip level: a nearest texel of a smaller level would be another texel);
// Linear and Cubic read the mip level of the point's footprint (the UV's derivatives or the
// ray cone's level; a Vector other than the UV is given the UV's footprint), where Cycles
// reads the full-size image and leaves the minified image aliased.
vec4 node_image_texel(int layer, ivec2 texel, int level) {
    return texelFetch(u_textures, ivec3(texel, layer), level);
}

vec4 node_image_mapped(int layer, int extension, int interpolation, vec2 uv, ShadingPoint sp) {
    if (layer < 0) return vec4(1.0, 0.0, 1.0, 1.0);
    if (interpolation == 0 && extension == 0) return node_image(layer, uv, sp);
    int level = 0;
    if (interpolation != 1) {
        vec2 full = vec2(textureSize(u_textures, 0).xy);
        float lod = sp.lod;
        if (lod < 0.0) {
            vec2 dx = sp.duv_dx * full, dy = sp.duv_dy * full;
            float rho = max(dot(dx, dx), dot(dy, dy));
            lod = rho > 1.0 ? 0.5 * log2(rho) : 0.0;
        }
        level = clamp(int(floor(lod + 0.5)), 0, textureQueryLevels(u_textures) - 1);
    }
    ivec2 size = textureSize(u_textures, level).xy;
    if (interpolation == 1) {
        ivec2 texel;
        vec2 centre;
        return node_tex_image_closest(extension, uv, size, texel, centre) ? node_image_texel(layer, texel, 0)
                                                                           : vec4(0.0);
    }
    if (interpolation == 0) {
        ivec2 lo, hi;
        vec4 w = node_tex_image_linear(extension, uv, size, lo, hi);
        return w.x * node_image_texel(layer, lo, level) + w.y * node_image_texel(layer, ivec2(hi.x, lo.y), level)
             + w.z * node_image_texel(layer, ivec2(lo.x, hi.y), level) + w.w * node_image_texel(layer, hi, level);
    }
    ivec4 xs, ys;
    vec4 wx, wy;
    node_tex_image_cubic(extension, uv, size, xs, ys, wx, wy);
    vec4 sum = vec4(0.0);
    for (int j = 0; j < 4; ++j) {
        if (wy[j] == 0.0) continue;
        vec4 row = vec4(0.0);
        for (int i = 0; i < 4; ++i) row += wx[i] * node_image_texel(layer, ivec2(xs[i], ys[j]), level);
        sum += wy[j] * row;
    }
    return sum;
}

// The Image Texture node: the projection of the Vector (Box weighs its sides by the
// object-space normal), then each side's lookup.
vec4 node_tex_image(int layer, int projection, int extension, int interpolation, float blend, vec3 vector,
                    ShadingPoint sp) {
    int k = node_object_of(sp.row);
    vec3 n = node_unit(node_to_object(k, sp.normal, 0.0), sp.normal);
    vec2 uv0, uv1, uv2;
    vec3 weights;
    node_tex_image_project(projection, vector, n, blend, uv0, uv1, uv2, weights);
    vec4 c = node_image_mapped(layer, extension, interpolation, uv0, sp) * weights.x;
    if (weights.y > 0.0) c += node_image_mapped(layer, extension, interpolation, uv1, sp) * weights.y;
    if (weights.z > 0.0) c += node_image_mapped(layer, extension, interpolation, uv2, sp) * weights.z;
    return c;
}
#endif

// Blender's Normal Map node in tangent space (textures.glsl apply_normal_map, with the
// strength an input); world and object space read the colour as a normal in that space, the
// Blender Object and Blender World spaces with Y and Z negated (Blender's old baking
// convention, as Cycles reads them), and outside tangent space a back face's normal is the
// map's turned over, as Cycles turns it (the interpreter's normals face the ray).
vec3 node_normal_map(ShadingPoint sp, int space, float strength, vec3 color) {
    vec3 n = sp.normal;
    vec3 c = color * 2.0 - 1.0;
    if (space == 3 || space == 4) c.yz = -c.yz;
    vec3 mapped;
    if (space == 0) {
        vec3 t = sp.dp_du - n * dot(n, sp.dp_du);
        vec3 b = sp.dp_dv - n * dot(n, sp.dp_dv);
        float lt = dot(t, t), lb = dot(b, b);
        if (!(lt > 1e-30) || !(lb > 1e-30)) return n;
        mapped = normalize(t * inversesqrt(lt) * c.x + b * inversesqrt(lb) * c.y + n * max(c.z, 1e-3));
    } else if (space == 1 || space == 3) {
        int k = node_object_of(sp.row);
        // Object to world for normals: the transpose of the world-to-object map.
        mapped = k < 0 ? c : vec3(dot(vec3(node_objects[k].to_object[0].x, node_objects[k].to_object[1].x,
                                                node_objects[k].to_object[2].x), c),
                                  dot(vec3(node_objects[k].to_object[0].y, node_objects[k].to_object[1].y,
                                           node_objects[k].to_object[2].y), c),
                                  dot(vec3(node_objects[k].to_object[0].z, node_objects[k].to_object[1].z,
                                           node_objects[k].to_object[2].z), c));
        mapped = node_unit(mapped, n);
    } else {
        mapped = node_unit(c, n);
    }
    if (space != 0 && sp.backfacing) mapped = -mapped;
    return node_unit(mix(n, mapped, max(strength, 0.0)), n);
}

// -- shading normals and bump
// The shading point one filter width along a differential (Cycles' bump evaluation: the
// position and the texture coordinates move, the normal stays): axis 1 along dP/dx, 2 along
// dP/dy, 0 the point itself. Filter Width is in pixels, the differentials span one. Seen
// from behind, the UV and the mesh's other interpolated attributes (Generated, Color
// Attributes: sp.surface) step backwards while the position steps forwards, as in Cycles,
// which solves the barycentrics' change with dP/du and dP/dv after flipping them with the
// normal: a Height that reads any of them is bumped the other way on a back face.
ShadingPoint node_bump_offset(ShadingPoint base, int axis, float width) {
    ShadingPoint sp = base;
    float surface_width = base.backfacing ? -width : width;
    if (axis == 1) {
        sp.position += width * base.dp_dx;
        sp.surface += surface_width * base.dp_dx;
        sp.uv += surface_width * base.uv_dx;
    } else if (axis == 2) {
        sp.position += width * base.dp_dy;
        sp.surface += surface_width * base.dp_dy;
        sp.uv += surface_width * base.uv_dy;
    }
    return sp;
}

// The footprint of a ray as Cycles' dP holds it (one width, differential_make_compact) and
// unfolds it for the Bump (differential_from_compact): two axes of that length in the plane of
// the true normal ng, the first along (1, 1, 1) x ng (make_orthonormals), so a stepped height
// bevels its edges where Cycles' do.
void node_footprint_axes(vec3 ng, float width, out vec3 dp_dx, out vec3 dp_dy) {
    vec3 a = ng.x != ng.y || ng.x != ng.z ? vec3(ng.z - ng.y, ng.x - ng.z, ng.y - ng.x)
                                          : vec3(ng.z - ng.y, ng.x + ng.z, -ng.y - ng.x);
    a = node_unit(a, vec3(1.0, 0.0, 0.0));
    dp_dx = a * width;
    dp_dy = cross(ng, a) * width;
}

// The change of the UV along a surface step dp, given the surface's directions of increasing
// u and v (dp = du dP/du + dv dP/dv, solved in the least-squares sense); zero without them.
vec2 node_uv_change(vec3 dp, vec3 tu, vec3 tv) {
    float a = dot(tu, tu), b = dot(tu, tv), c = dot(tv, tv);
    float det = a * c - b * b;
    if (!(abs(det) > 1e-30)) return vec2(0.0);
    float pu = dot(dp, tu), pv = dot(dp, tv);
    return vec2(c * pu - b * pv, a * pv - b * pu) / det;
}

// Cycles' Bump node: the height's surface gradient from its values at the point (h) and one
// filter width along dP/dx (hx) and dP/dy (hy), as Mikkelsen's "Bump mapping unparametrized
// surfaces on the GPU" (2010) does with screen derivatives. R_x, R_y span the dual frame of
// the differentials in the plane of n, so (hx - h) R_x + (hy - h) R_y is width x det x the
// gradient; the width times |det| on n makes the result N - distance x grad(height), the same
// at any filter width. Strength blends towards the input normal, Invert flips the distance.
vec3 node_bump(ShadingPoint sp, float strength, float distance, float width, float h, float hx, float hy,
               vec3 normal, bool invert) {
    vec3 n = node_unit(normal, sp.normal);
    vec3 rx = cross(sp.dp_dy, n);
    vec3 ry = cross(n, sp.dp_dx);
    float det = dot(sp.dp_dx, rx);
    vec3 gradient = (hx - h) * rx + (hy - h) * ry;
    float d = invert ? -distance : distance;
    vec3 bent = node_unit(width * abs(det) * n - d * sign(det) * gradient, n);
    strength = max(strength, 0.0);
    return node_unit(strength * bent + (1.0 - strength) * n, n);
}

#ifdef NODE_FAMILY_COLOUR
// Sample i of an inline table of `columns` floats per sample at word `at` (Color Ramp, curves).
vec4 node_table_at(uint at, int i, int columns) {
    uint base = at + uint(i * columns);
    vec4 v = vec4(0.0, 0.0, 0.0, 1.0);
    for (int k = 0; k < columns; ++k) v[k] = uintBitsToFloat(node_words[base + uint(k)]);
    return v;
}

// A curve table's value at x (nodes/curves.glsl's lookup), column `column` of `columns`.
float node_curve_value(uint at, int columns, int column, float x, float min_x, float max_x, bool extrapolate) {
    int i0, i1;
    float weight;
    node_curve_coords(x, min_x, max_x, extrapolate, i0, i1, weight);
    float a = uintBitsToFloat(node_words[at + uint(i0 * columns + column)]);
    float b = uintBitsToFloat(node_words[at + uint(i1 * columns + column)]);
    return (1.0 - weight) * a + weight * b;
}
#endif

// -- closure lobes
// Glossy lobes (Cycles: a GGX lobe of constant colour, weighted by their Mix factors, a
// Fresnel or Layer Weight most often) over the rest of the closure (the base: its own means)
// as the shading model holds two layers: the base's diffuse part under a white dielectric
// coat (shading.glsl), whose f0 is chosen so that at this point's view it reflects what the
// Glossy lobes weigh here, plus the base's own coat. The base's layers are rescaled so that
// metal, glass and diffuse keep the light Cycles gives each: with the base's shares m, t, d
// (sum 1, d its diffuse after its own coat), scale s and gloss weight G (both over the
// alpha), the material's albedo is s A (m + t + d) / (1 - G), its metal and glass shares
// m (1 - G) / (m + t + d) and t alike, and its coat reflects G / (its diffuse share). One
// roughness for every specular lobe: the mean of the gloss's and the base's specular
// roughnesses, weighted by the light each reflects. Without a diffuse part in the base (a
// Glossy alone, or over a metal or glass) the means stand (the metal lobe holds a Glossy
// exactly when it is alone).
void node_gloss_layer(vec4 result[NODE_CLOSURE_REGISTERS], ShadingPoint sp, inout NodeClosure c) {
    float wg = result[4].a;
    float w = result[0].a;
    float wb = w - wg;
    if (!(wg > 1e-6) || !(wb > 1e-6) || c.alpha <= 1e-8) return;
    float inv_wb = 1.0 / wb;
    float m_b = clamp((result[1].x - wg) * inv_wb, 0.0, 1.0);
    float t_b = clamp(result[1].z * inv_wb, 0.0, 1.0 - m_b);
    float d_b = 1.0 - m_b - t_b;
    if (d_b <= 1e-3) return;
    float r_b = clamp((result[1].y - result[5].x) * inv_wb, 0.0, 1.0);
    float f0_b = clamp(result[3].w * inv_wb, 0.0, 1.0);
    float ior_b = max((result[1].w - 1.5 * wg) * inv_wb, 1.0);
    float r_g = clamp(result[5].x / wg, 0.0, 1.0);
    float s = wb / c.alpha;
    vec3 base = max(result[0].rgb - result[4].rgb, vec3(0.0)) / c.alpha;  // s x the base's mean colour
    float gloss = dot(result[4].rgb, vec3(0.2126, 0.7152, 0.0722)) / c.alpha;
    float cos_v = clamp(abs(dot(sp.incoming, c.normal)), 1e-4, 1.0);
    float coat_b = coat_reflectance(f0_b, cos_v, r_b);
    float d_after = d_b * (1.0 - coat_b);
    float gloss_total = min(gloss + s * d_b * coat_b, 0.999);
    float shares = m_b + t_b + d_after;
    if (!(shares > 1e-6)) return;
    float spec_b = s * (m_b + t_b + d_b * coat_b);
    c.base_color = base * (shares / (1.0 - gloss_total));
    c.metallic = m_b * (1.0 - gloss_total) / shares;
    c.transmission = t_b * (1.0 - gloss_total) / shares;
    c.ior = ior_b;
    c.roughness = (gloss * r_g + spec_b * r_b) / max(gloss + spec_b, 1e-8);
    float diffuse_share = max(1.0 - c.metallic - c.transmission, 1e-6);
    c.specular = coat_f0_for(min(gloss_total / diffuse_share, 1.0), cos_v, c.roughness);
    if (any(isnan(c.base_color)) || any(isinf(c.base_color))) c.base_color = vec3(0.0);
}

// The closure of the Output's sums (module header) at the shading point: the w-weighted
// means, or, where Glossy lobes lie over a base with a diffuse part, the two as layers.
NodeClosure node_closure_of(vec4 result[NODE_CLOSURE_REGISTERS], ShadingPoint sp) {
    NodeClosure c;
    float w = result[0].a;
    float inv_w = w > 1e-8 ? 1.0 / w : 0.0;
    c.alpha = clamp(1.0 - result[2].a, 0.0, 1.0);
    c.base_color = c.alpha > 1e-8 ? max(result[0].rgb / c.alpha, vec3(0.0)) : vec3(0.0);
    c.metallic = w > 1e-8 ? clamp(result[1].x * inv_w, 0.0, 1.0) : 0.0;
    c.roughness = w > 1e-8 ? clamp(result[1].y * inv_w, 0.0, 1.0) : 1.0;
    c.transmission = w > 1e-8 ? clamp(result[1].z * inv_w, 0.0, 1.0) : 0.0;
    c.ior = w > 1e-8 ? max(result[1].w * inv_w, 1.0) : 1.5;
    c.specular = w > 1e-8 ? clamp(result[3].w * inv_w, 0.0, 1.0) : 0.0;
    c.emission = max(result[2].rgb, vec3(0.0));
    vec3 n = node_unit(result[3].xyz, sp.normal);
    c.normal = sp.backfacing ? -n : n;  // back to the orientation as modelled
    if (any(isnan(c.base_color)) || any(isinf(c.base_color))) c.base_color = vec3(0.0);
    if (any(isnan(c.emission)) || any(isinf(c.emission))) c.emission = vec3(0.0);
    node_gloss_layer(result, sp, c);
    return c;
}
// -- end of closure lobes

#ifndef NODE_GENERATED_ONLY
// Interpret the program at word `offset` at the shading point; returns the material's closure.
NodeClosure node_program_interpret(int offset, ShadingPoint sp) {
    // The point as the caller gave it: a Bump's offset instructions move sp away from it and back.
    ShadingPoint base = sp;
    for (int r = 0; r < NODE_REGISTERS; ++r) node_reg[r] = vec4(0.0);
    uint pc = uint(max(offset, 0));
    vec4 result[NODE_CLOSURE_REGISTERS];
    for (int k = 0; k < NODE_CLOSURE_REGISTERS; ++k) result[k] = vec4(0.0);
    for (int step = 0; step < NODE_MAX_INSTRUCTIONS; ++step) {
        uint header = node_words[pc];
        uint op = header & 0xffu;
        uint n_out = (header >> 8) & 0xffu;
        uint n_set = (header >> 16) & 0xffu;
        uint n_in = header >> 24;
        uint out_at = pc + 1u;
        uint set_at = out_at + n_out;
        pc = set_at + n_set;
        for (uint i = 0u; i < n_in; ++i) {
            vec4 v = node_operand(pc, sp);
            if (i < uint(NODE_MAX_OPERANDS)) node_in[i] = v;
        }
        if (op == NODE_OP_OUTPUT || op == 0u) {
            if (op == NODE_OP_OUTPUT) {
                for (int k = 0; k < NODE_CLOSURE_REGISTERS; ++k) result[k] = node_in[k];
            }
            break;
        }
        for (int o = 0; o < NODE_MAX_OUTPUTS; ++o) node_out[o] = vec4(0.0);
        switch (op) {
        case NODE_OP_VALUE:
            node_out[0] = node_in[0];
            break;
        case NODE_OP_TEX_COORD: {
            // Generated and Object find the instance by a search over the instance table,
            // which the compiler cannot drop where the output is unread: only what is read.
            int k = node_output_read(1) || node_output_read(3) ? node_object_of(sp.row) : -1;
            if (node_output_read(0)) node_out[0] = vec4(node_generated(sp), 0.0);
            if (node_output_read(1)) node_out[1] = vec4(node_unit(node_to_object(k, sp.normal, 0.0), sp.normal), 0.0);  // object space
            node_out[2] = vec4(sp.uv, 0.0, 0.0);
            if (node_output_read(3)) node_out[3] = vec4(node_to_object(k, sp.position, 1.0), 0.0);
            if (node_output_read(4)) node_out[4] = vec4((u_node_world_to_camera * vec4(sp.position, 1.0)).xyz, 0.0);
            if (node_output_read(5)) {
                vec4 clip = u_node_world_to_clip * vec4(sp.position, 1.0);
                node_out[5] = clip.w != 0.0 ? vec4(clip.xy / clip.w * 0.5 + 0.5, 0.0, 0.0) : vec4(0.0);
            }
            node_out[6] = vec4(reflect(-sp.incoming, sp.normal), 0.0);
            break;
        }
        case NODE_OP_UVMAP:
            node_out[0] = vec4(sp.uv, 0.0, 0.0);
            break;
        case NODE_OP_GEOMETRY:
            node_out[0] = vec4(sp.position, 0.0);
            node_out[1] = vec4(sp.normal, 0.0);
            node_out[2] = vec4(node_unit(sp.dp_du, vec3(0.0)), 0.0);
            node_out[3] = vec4(sp.geometric, 0.0);
            node_out[4] = vec4(sp.incoming, 0.0);
            node_out[6] = vec4(sp.backfacing ? 1.0 : 0.0);
            break;
        case NODE_OP_OBJECT_INFO: {
            int k = node_object_of(sp.row);
            node_out[0] = k < 0 ? vec4(0.0) : vec4(node_objects[k].location.xyz, 0.0);
            node_out[1] = k < 0 ? vec4(1.0) : node_objects[k].color;
            node_out[2] = vec4(k < 0 ? 1.0 : node_objects[k].color.a);
            node_out[3] = vec4(0.0);
            node_out[4] = vec4(float(sp.material));
            node_out[5] = vec4(k < 0 ? 0.0 : node_objects[k].location.w);
            break;
        }
        case NODE_OP_FRESNEL: {
            float eta = max(node_in[0].x, 1e-5);
            eta = sp.backfacing ? 1.0 / eta : eta;
            node_out[0] = vec4(node_fresnel_dielectric(dot(sp.incoming, node_in[1].xyz), eta));
            break;
        }
        case NODE_OP_LAYER_WEIGHT: {
            float blend = node_in[0].x;
            float eta = max(1.0 - blend, 1e-5);
            eta = sp.backfacing ? eta : 1.0 / eta;
            node_out[0] = vec4(node_fresnel_dielectric(dot(sp.incoming, node_in[1].xyz), eta));
            float f = abs(dot(sp.incoming, node_in[1].xyz));
            if (blend != 0.5) {
                blend = clamp(blend, 0.0, 1.0 - 1e-5);
                blend = blend < 0.5 ? 2.0 * blend : 0.5 / (1.0 - blend);
                f = pow(f, blend);
            }
            node_out[1] = vec4(1.0 - f);
            break;
        }
        case NODE_OP_LIGHT_PATH:
            node_out[0] = vec4(sp.ray_depth == 0 ? 1.0 : 0.0);
            node_out[1] = vec4(sp.ray_depth < 0 ? 1.0 : 0.0);  // node_shadow_ray_depth
            node_out[2] = vec4(float(abs(sp.ray_depth)));
            break;
        case NODE_OP_SEPARATE_XYZ:
            node_out[0] = node_in[0].xxxx;
            node_out[1] = node_in[0].yyyy;
            node_out[2] = node_in[0].zzzz;
            break;
        case NODE_OP_COMBINE_XYZ:
            node_out[0] = vec4(node_in[0].x, node_in[1].x, node_in[2].x, 0.0);
            break;
        case NODE_OP_TEX_WHITE_NOISE: {
            float value;
            vec3 color;
            node_tex_white_noise(int(node_words[set_at]), node_in[0].xyz, node_in[1].x, value, color);
            node_out[0] = vec4(value);
            node_out[1] = vec4(color, 1.0);
            break;
        }
        case NODE_OP_TEX_IMAGE: {
#ifdef NODE_FAMILY_IMAGE
            // Settings: layer, projection, extension, interpolation, box blend (float bits).
            vec4 texel = node_tex_image(int(node_words[set_at]), int(node_words[set_at + 1u]),
                                        int(node_words[set_at + 2u]), int(node_words[set_at + 3u]),
                                        uintBitsToFloat(node_words[set_at + 4u]), node_in[0].xyz, sp);
#else
            vec4 texel = node_image(int(node_words[set_at]), node_in[0].xy, sp);
#endif
            node_out[0] = texel;
            node_out[1] = vec4(texel.a);
            break;
        }
        case NODE_OP_NORMAL_MAP:
            node_out[0] = vec4(node_normal_map(sp, int(node_words[set_at]), node_in[0].x, node_in[1].rgb), 0.0);
            break;
        // -- shading normals and bump
        case NODE_OP_BUMP_OFFSET:
            sp = node_bump_offset(base, int(node_words[set_at]), node_in[0].x);
            break;
        case NODE_OP_BUMP:
            node_out[0] = vec4(node_bump(base, node_in[0].x, node_in[1].x, node_in[2].x, node_in[3].x,
                                         node_in[5].x, node_in[6].x, node_in[4].xyz, node_words[set_at] != 0u), 0.0);
            break;
        // -- end of shading normals and bump
        case NODE_OP_BSDF_PRINCIPLED: {
            // Base Color, Metallic, Roughness, IOR, Alpha, Normal, Specular IOR Level,
            // Transmission Weight, Emission Color, Emission Strength (materials.py's folding).
            float metallic = clamp(node_in[1].x, 0.0, 1.0);
            float ior = max(node_in[3].x, 1.0);
            float alpha = clamp(node_in[4].x, 0.0, 1.0);
            float f0 = (ior - 1.0) / (ior + 1.0);
            float coat = clamp(f0 * f0 * 2.0 * clamp(node_in[6].x, 0.0, 1.0), 0.0, 1.0);
            node_bsdf(alpha, node_in[0].rgb, metallic, node_in[2].x, clamp(node_in[7].x, 0.0, 1.0) * (1.0 - metallic),
                      ior, coat, node_in[5].xyz, alpha * node_in[8].rgb * max(node_in[9].x, 0.0), 1.0 - alpha,
                      node_out[0], node_out[1], node_out[2], node_out[3]);
            break;
        }
        case NODE_OP_BSDF_DIFFUSE:
            node_bsdf(1.0, node_in[0].rgb, 0.0, 1.0, 0.0, 1.5, 0.0, node_in[2].xyz, vec3(0.0), 0.0,
                      node_out[0], node_out[1], node_out[2], node_out[3]);
            break;
        case NODE_OP_BSDF_GLOSSY:
            node_bsdf(1.0, node_in[0].rgb, 1.0, node_in[1].x, 0.0, 1.5, 0.0, node_in[2].xyz, vec3(0.0), 0.0,
                      node_out[0], node_out[1], node_out[2], node_out[3]);
            // -- closure lobes: the Glossy layer's own sums (weight 1)
            node_out[4] = vec4(max(node_in[0].rgb, vec3(0.0)), 1.0);
            node_out[5] = vec4(clamp(node_in[1].x, 0.0, 1.0), 0.0, 0.0, 0.0);
            // -- end of closure lobes
            break;
        case NODE_OP_BSDF_GLASS:
        case NODE_OP_BSDF_REFRACTION:
            node_bsdf(1.0, node_in[0].rgb, 0.0, node_in[1].x, 1.0, node_in[2].x, 0.0, node_in[3].xyz, vec3(0.0), 0.0,
                      node_out[0], node_out[1], node_out[2], node_out[3]);
            break;
        case NODE_OP_BSDF_TRANSPARENT:
            node_bsdf(0.0, vec3(0.0), 0.0, 0.0, 0.0, 1.0, 0.0, vec3(0.0), vec3(0.0), 1.0,
                      node_out[0], node_out[1], node_out[2], node_out[3]);
            break;
        case NODE_OP_EMISSION:
            node_bsdf(0.0, vec3(0.0), 0.0, 0.0, 0.0, 1.0, 0.0, vec3(0.0), node_in[0].rgb * node_in[1].x, 0.0,
                      node_out[0], node_out[1], node_out[2], node_out[3]);
            break;
        case NODE_OP_MIX_SHADER: {
            float fac = clamp(node_in[0].x, 0.0, 1.0);
            for (int k = 0; k < NODE_CLOSURE_REGISTERS; ++k)
                node_out[k] = mix(node_in[1 + k], node_in[1 + NODE_CLOSURE_REGISTERS + k], fac);
            break;
        }
        case NODE_OP_ADD_SHADER:
            for (int k = 0; k < NODE_CLOSURE_REGISTERS; ++k) node_out[k] = node_in[k] + node_in[NODE_CLOSURE_REGISTERS + k];
            break;
        // -- colour and vector
#ifdef NODE_FAMILY_VECTOR
        case NODE_OP_MATH: {
            float value;
            node_math(int(node_words[set_at]), node_in[0].x, node_in[1].x, node_in[2].x,
                      node_words[set_at + 1u] != 0u, value);
            node_out[0] = vec4(value);
            break;
        }
        case NODE_OP_VECTOR_MATH: {
            vec3 vector;
            float value;
            node_vector_math(int(node_words[set_at]), node_in[0].xyz, node_in[1].xyz, node_in[2].xyz, node_in[3].x,
                             vector, value);
            node_out[0] = vec4(vector, 0.0);
            node_out[1] = vec4(value);
            break;
        }
        case NODE_OP_MAP_RANGE: {
            // data_type, interpolation_type, clamp; the Float sockets, then the FLOAT3 ones.
            int interpolation = int(node_words[set_at + 1u]);
            bool use_clamp = node_words[set_at + 2u] != 0u;
            if (node_words[set_at] == 0u) {
                float result;
                node_map_range(interpolation, use_clamp, node_in[0].x, node_in[1].x, node_in[2].x, node_in[3].x,
                               node_in[4].x, node_in[5].x, result);
                node_out[0] = vec4(result);
            } else {
                vec3 result;
                node_map_range_vector(interpolation, use_clamp, node_in[6].xyz, node_in[7].xyz, node_in[8].xyz,
                                      node_in[9].xyz, node_in[10].xyz, node_in[11].xyz, result);
                node_out[1] = vec4(result, 0.0);
            }
            break;
        }
        case NODE_OP_CLAMP: {
            float result;
            node_clamp(int(node_words[set_at]), node_in[0].x, node_in[1].x, node_in[2].x, result);
            node_out[0] = vec4(result);
            break;
        }
        case NODE_OP_MAPPING: {
            vec3 result;
            node_mapping(int(node_words[set_at]), node_in[0].xyz, node_in[1].xyz, node_in[2].xyz, node_in[3].xyz,
                         result);
            node_out[0] = vec4(result, 0.0);
            break;
        }
        case NODE_OP_VECTOR_ROTATE: {
            vec3 result;
            node_vector_rotate(int(node_words[set_at]), node_words[set_at + 1u] != 0u, node_in[0].xyz, node_in[1].xyz,
                               node_in[2].xyz, node_in[3].x, node_in[4].xyz, result);
            node_out[0] = vec4(result, 0.0);
            break;
        }
#endif
#ifdef NODE_FAMILY_COLOUR
        case NODE_OP_MIX: {
            // data_type, factor_mode, blend_type, clamp_factor, clamp_result; operands:
            // Factor_Float, Factor_Vector, A_Float, B_Float, A_Vector, B_Vector, A_Color, B_Color.
            uint data_type = node_words[set_at];
            bool clamp_factor = node_words[set_at + 3u] != 0u;
            if (data_type == 0u) {
                float result;
                node_mix_float(clamp_factor, node_in[0].x, node_in[2].x, node_in[3].x, result);
                node_out[0] = vec4(result);
            } else if (data_type == 1u) {
                vec3 result;
                if (node_words[set_at + 1u] != 0u)
                    node_mix_vector_non_uniform(clamp_factor, node_in[1].xyz, node_in[4].xyz, node_in[5].xyz, result);
                else
                    node_mix_vector(clamp_factor, node_in[0].x, node_in[4].xyz, node_in[5].xyz, result);
                node_out[1] = vec4(result, 0.0);
            } else {
                vec3 result;
                node_mix_color(int(node_words[set_at + 2u]), clamp_factor, node_words[set_at + 4u] != 0u, node_in[0].x,
                               node_in[6].rgb, node_in[7].rgb, result);
                node_out[2] = vec4(result, 1.0);
            }
            break;
        }
        case NODE_OP_MIX_RGB: {
            vec3 result;
            node_mix_color(int(node_words[set_at]), true, node_words[set_at + 1u] != 0u, node_in[0].x, node_in[1].rgb,
                           node_in[2].rgb, result);
            node_out[0] = vec4(result, 1.0);
            break;
        }
        case NODE_OP_COLOR_RAMP: {
            // The table (NODE_RAMP_TABLE_SIZE RGBA samples) follows the operands.
            int i0, i1;
            float weight;
            node_color_ramp_coords(int(node_words[set_at]), node_in[0].x, i0, i1, weight);
            vec4 rgba = node_table_mix(node_table_at(pc, i0, 4), node_table_at(pc, i1, 4), weight);
            node_out[0] = rgba;
            node_out[1] = vec4(rgba.a);
            pc += uint(NODE_RAMP_TABLE_SIZE * 4);
            break;
        }
        case NODE_OP_CURVE_RGB:
        case NODE_OP_CURVE_VECTOR:
        case NODE_OP_CURVE_FLOAT: {
            // Settings: min_x, max_x (float bits), extrapolate; the table follows the operands.
            float min_x = uintBitsToFloat(node_words[set_at]);
            float max_x = uintBitsToFloat(node_words[set_at + 1u]);
            bool extrapolate = node_words[set_at + 2u] != 0u;
            int columns = op == NODE_OP_CURVE_FLOAT ? 1 : 3;
            vec3 curved = vec3(0.0);
            for (int k = 0; k < columns; ++k)
                curved[k] = node_curve_value(pc, columns, k, node_in[1][k], min_x, max_x, extrapolate);
            if (op == NODE_OP_CURVE_FLOAT) {
                float result;
                node_curve_finish_float(node_in[0].x, node_in[1].x, curved.x, result);
                node_out[0] = vec4(result);
            } else {
                vec3 result;
                node_curves_finish(node_in[0].x, node_in[1].xyz, curved, result);
                node_out[0] = vec4(result, op == NODE_OP_CURVE_RGB ? node_in[1].a : 0.0);
            }
            pc += uint(NODE_RAMP_TABLE_SIZE * columns);
            break;
        }
        case NODE_OP_HUE_SAT: {
            vec3 result;
            node_hue_saturation_value(node_in[0].x, node_in[1].x, node_in[2].x, node_in[3].x, node_in[4].rgb, result);
            node_out[0] = vec4(result, node_in[4].a);
            break;
        }
        case NODE_OP_INVERT: {
            vec3 result;
            node_invert(node_in[0].x, node_in[1].rgb, result);
            node_out[0] = vec4(result, node_in[1].a);
            break;
        }
        case NODE_OP_GAMMA: {
            vec3 result;
            node_gamma(node_in[0].rgb, node_in[1].x, result);
            node_out[0] = vec4(result, node_in[0].a);
            break;
        }
        case NODE_OP_BRIGHT_CONTRAST: {
            vec3 result;
            node_bright_contrast(node_in[0].rgb, node_in[1].x, node_in[2].x, result);
            node_out[0] = vec4(result, node_in[0].a);
            break;
        }
        case NODE_OP_SEPARATE_COLOR: {
            float a, b, c;
            node_separate_color(int(node_words[set_at]), node_in[0].rgb, a, b, c);
            node_out[0] = vec4(a);
            node_out[1] = vec4(b);
            node_out[2] = vec4(c);
            break;
        }
        case NODE_OP_COMBINE_COLOR: {
            vec3 color;
            node_combine_color(int(node_words[set_at]), node_in[0].x, node_in[1].x, node_in[2].x, color);
            node_out[0] = vec4(color, 1.0);
            break;
        }
#endif
        // -- world
        case NODE_OP_BACKGROUND:  // radiance colour x strength: an emission seen from every direction
            node_bsdf(0.0, vec3(0.0), 0.0, 0.0, 0.0, 1.0, 0.0, vec3(0.0), node_in[0].rgb * node_in[1].x, 0.0,
                      node_out[0], node_out[1], node_out[2], node_out[3]);
            break;
#ifdef NODE_WORLD
        case NODE_OP_TEX_ENVIRONMENT: {
            int layer = int(node_words[set_at]);
            vec2 uv = node_environment_uv(node_in[0].xyz, int(node_words[set_at + 1u]));
            node_out[0] = layer < 0 ? vec4(1.0, 0.0, 1.0, 1.0)  // Blender's colour of a missing image
                                    : vec4(textureLod(u_world_images, vec3(uv, float(layer)), u_world_lod).rgb, 1.0);
            break;
        }
        case NODE_OP_TEX_SKY: {  // settings in NODE_SPECS["TEX_SKY"] order
            vec3 sun = vec3(uintBitsToFloat(node_words[set_at + 1u]), uintBitsToFloat(node_words[set_at + 2u]),
                            uintBitsToFloat(node_words[set_at + 3u]));
            vec3 sun_at = vec3(uintBitsToFloat(node_words[set_at + 6u]), uintBitsToFloat(node_words[set_at + 7u]),
                               uintBitsToFloat(node_words[set_at + 8u]));
            vec3 density = vec3(uintBitsToFloat(node_words[set_at + 9u]), uintBitsToFloat(node_words[set_at + 10u]),
                                uintBitsToFloat(node_words[set_at + 11u]));
            int model = int(node_words[set_at]);
#ifdef NODE_SKY_HOSEK
            if (model == 3) {  // Hosek-Wilkie: parameter k of X, Y, Z at words 13 + k, 22 + k, 31 + k
                vec3 p[10];
                for (uint k = 0u; k < 9u; ++k) {
                    uint at = set_at + 13u + k;
                    p[k] = vec3(uintBitsToFloat(node_words[at]), uintBitsToFloat(node_words[at + 9u]),
                                uintBitsToFloat(node_words[at + 18u]));
                }
                p[9] = vec3(uintBitsToFloat(node_words[set_at + 40u]), uintBitsToFloat(node_words[set_at + 41u]),
                            uintBitsToFloat(node_words[set_at + 42u]));  // L_M of X, Y, Z
                node_out[0] = vec4(node_sky_hosek(node_in[0].xyz, sun, p), 1.0);
                break;
            }
#endif
            node_out[0] = vec4(node_tex_sky(model, node_in[0].xyz, sun, uintBitsToFloat(node_words[set_at + 4u]),
                                            sun_at, density, int(node_words[set_at + 12u])), 1.0);
            break;
        }
#endif
        // -- textures (inputs in NODE_SPECS order; enums as node_codes.py codes)
#ifdef NODE_FAMILY_NOISE
        case NODE_OP_TEX_NOISE: {
            float fac;
            vec3 color;
            // The Color's green and blue are two more fractal sums: only where it is read. The
            // Color's register word is read at run time (Noise has two outputs, before its
            // settings), not folded into a constant in generated code as other outputs are: with the
            // dimension count a literal too, a lone fractal sum per Noise sent llvmpipe's LLVM
            // into a compile without end in a fragment shader holding several Bump copies of
            // a Noise. The branch is uniform either way.
            bool color_read = node_words[set_at - 1u] < uint(NODE_REGISTERS);
            node_tex_noise_channels(int(node_words[set_at]), int(node_words[set_at + 1u]), int(node_words[set_at + 2u]),
                                    node_in[0].xyz, node_in[1].x, node_in[2].x, node_in[3].x, node_in[4].x,
                                    node_in[5].x, node_in[6].x, node_in[7].x, node_in[8].x,
                                    color_read ? 3 : 1, fac, color);
            node_out[0] = vec4(fac);
            node_out[1] = vec4(color, 1.0);
            break;
        }
        case NODE_OP_TEX_WAVE: {
            float fac;
            vec3 color;
            node_tex_wave(int(node_words[set_at]), int(node_words[set_at + 1u]), int(node_words[set_at + 2u]),
                          int(node_words[set_at + 3u]), node_in[0].xyz, node_in[1].x, node_in[2].x, node_in[3].x,
                          node_in[4].x, node_in[5].x, node_in[6].x, color, fac);
            node_out[0] = vec4(color, 1.0);
            node_out[1] = vec4(fac);
            break;
        }
#endif
#ifdef NODE_FAMILY_VORONOI
        case NODE_OP_TEX_VORONOI: {
            float distance, w, radius;
            vec3 color, position;
            node_tex_voronoi(int(node_words[set_at]), int(node_words[set_at + 1u]), int(node_words[set_at + 2u]),
                             int(node_words[set_at + 3u]), node_in[0].xyz, node_in[1].x, node_in[2].x, node_in[3].x,
                             node_in[4].x, node_in[5].x, node_in[6].x, node_in[7].x, node_in[8].x,
                             distance, color, position, w, radius);
            node_out[0] = vec4(distance);
            node_out[1] = vec4(color, 1.0);
            node_out[2] = vec4(position, 0.0);
            node_out[3] = vec4(w);
            node_out[4] = vec4(radius);
            break;
        }
#endif
#ifdef NODE_FAMILY_PATTERN
        case NODE_OP_TEX_CHECKER: {
            float fac;
            vec3 color;
            node_tex_checker(node_in[0].xyz, node_in[1].rgb, node_in[2].rgb, node_in[3].x, color, fac);
            node_out[0] = vec4(color, 1.0);
            node_out[1] = vec4(fac);
            break;
        }
        case NODE_OP_TEX_BRICK: {
            // Settings: offset (float bits), offset frequency, squash (float bits), squash frequency.
            float fac;
            vec3 color;
            node_tex_brick(node_in[0].xyz, node_in[1].rgb, node_in[2].rgb, node_in[3].rgb, node_in[4].x, node_in[5].x,
                           node_in[6].x, node_in[7].x, node_in[8].x, node_in[9].x,
                           uintBitsToFloat(node_words[set_at]), int(node_words[set_at + 1u]),
                           uintBitsToFloat(node_words[set_at + 2u]), int(node_words[set_at + 3u]), color, fac);
            node_out[0] = vec4(color, 1.0);
            node_out[1] = vec4(fac);
            break;
        }
        case NODE_OP_TEX_GRADIENT: {
            float fac;
            vec3 color;
            node_tex_gradient(int(node_words[set_at]), node_in[0].xyz, color, fac);
            node_out[0] = vec4(color, 1.0);
            node_out[1] = vec4(fac);
            break;
        }
        case NODE_OP_TEX_MAGIC: {
            float fac;
            vec3 color;
            node_tex_magic(int(node_words[set_at]), node_in[0].xyz, node_in[1].x, node_in[2].x, color, fac);
            node_out[0] = vec4(color, 1.0);
            node_out[1] = vec4(fac);
            break;
        }
#endif
// -- attributes (70-79): settings = source, slot (scene/node_program.py). Outputs as
// Cycles' svm_node_attr: Color and Vector the RGB, Fac its mean, Alpha the A.
#ifdef NODE_ATTRIBUTES
        case NODE_OP_ATTRIBUTE: {
            vec4 a = node_attribute(int(node_words[set_at]), int(node_words[set_at + 1u]),
                                    node_object_of(sp.row), sp.row, sp.surface);
            node_out[0] = vec4(a.rgb, 1.0);
            node_out[1] = vec4(a.rgb, 0.0);
            node_out[2] = vec4((a.r + a.g + a.b) * (1.0 / 3.0));
            node_out[3] = vec4(a.a);
            break;
        }
#else
        case NODE_OP_ATTRIBUTE:  // no store bound (the World's bake): missing, as in Cycles
            node_out[0] = node_out[1] = node_out[2] = node_out[3] = vec4(0.0);
            break;
#endif
// -- end of attributes
        default:
            break;
        }
        for (uint o = 0u; o < n_out && o < uint(NODE_MAX_OUTPUTS); ++o) {
            uint r = node_words[out_at + o];
            if (r < uint(NODE_REGISTERS)) node_reg[r] = node_out[o];
        }
    }
    return node_closure_of(result, sp);
}
#endif

// Generated straight-line GLSL, one function per program topology (values still read from
// the words), and node_generated_run, which runs a program's function when the word before
// the program names one (passes/scene_upload/node_codegen.py); absent without NODE_GENERATED.
#include "generated:NODE_GENERATED"

// Run the program at word `offset` at the shading point; returns the material's closure:
// the generated function of its topology where one is compiled in, else the interpreter.
NodeClosure node_program_run(int offset, ShadingPoint sp) {
#ifdef NODE_GENERATED
    NodeClosure c;
    if (node_generated_run(offset, sp, c)) return c;
#endif
#ifdef NODE_GENERATED_ONLY
    vec4 nothing[NODE_CLOSURE_REGISTERS];
    for (int k = 0; k < NODE_CLOSURE_REGISTERS; ++k) nothing[k] = vec4(0.0);
    return node_closure_of(nothing, sp);
#else
    return node_program_interpret(offset, sp);
#endif
}

// The material row with the closure's parameters in its slots, its images switched off: what
// every shading function (shading.glsl, textures.glsl) reads. The metal layer sits on the
// glass one as in materials.py.
Material node_closure_material(Material m, NodeClosure c) {
    m.base_color_refl = vec4(c.base_color, c.metallic);
    m.emission_trans = vec4(c.emission, min(c.transmission, 1.0 - c.metallic));
    m.params.x = c.ior;
    m.params.z = c.roughness;
    m.params.w = c.specular;
    m.textures = ivec4(-1, -1, -1, 0);
    m.textures2.xy = ivec2(-1);
    return m;
}


#endif
