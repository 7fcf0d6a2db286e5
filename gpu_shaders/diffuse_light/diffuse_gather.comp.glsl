// SPDX-License-Identifier: GPL-3.0-or-later
// Diffuse light by traced paths (hybrid_engine/passes/diffuse_light/diffuse_light.py): the
// World's light, the lamps' light off other surfaces and, with EMITTER_LIGHT, the emissive
// triangles' light, arriving at every diffuse primary pixel, with occlusion at any distance.
//
// Per diffuse primary pixel, u_diffuse_rays cosine-distributed paths through the near-cube
// BVH and the cube map (FULL_BVH: the whole scene's BVH), traced as the reflections are
// (trace_ray.glsl, paper §3.4; the hybrid ambient occlusion of Reinbothe et al., the paper's
// reference [14], carried on to several bounces). At each vertex of a path:
//   * escaping, the sky's radiance along the ray;
//   * meeting a surface: its emission (not with EMITTER_LIGHT, whose next-event estimate
//     already counts it), and while bounces remain the light its lamps give it (shadow maps)
//     and, with EMITTER_LIGHT, the emitters' (emitter_irradiance, where the path bounces
//     off the diffuse layer), then one more bounce (below);
//   * meeting glass: straight on through it, times its transmission (as the tracer's
//     occlusion rays take it), without spending a bounce.
//   * the bounce takes one of the surface's lobes, picked by its share of the reflected
//     light: the diffuse layer (cosine) or the specular layers (their GGX lobe, weight the
//     lobe's albedo; a rough metal has only that one); after a specular bounce the next
//     surface's emission counts, no next-event estimate having been taken there.
// u_diffuse_bounces 0 is direct light only: the sky or emission the primary's ray meets (and
// the emitters' next-event estimate at the primary point), no light off other surfaces.
//
// Writes u_ambient (RGBA32F): rgb the diffuse irradiance at the pixel (demodulated: not times
// its albedo; the deferred shading multiplies, shade_surface's world_irradiance), a the share
// of the first rays that saw the sky (the rough reflections' sky visibility). A rough metal
// (shading.glsl material_glossy_gathered: no diffuse layer whose rays could tell what hides
// the sky from its reflection) gathers the same way along its GGX lobe instead of the
// cosine: rgb is then pi times the radiance the lobe brings, which the deferred shading
// takes times the lobe's albedo. Pixels that are background or neither: (0, 0, 0, 1).
//
// Host defines: those of trace/hybrid_trace.comp.glsl (tracer.HybridTracer.inputs), and
//   EMITTER_LIGHT (the emissive triangles' table, include/emitter_light.glsl), SURFACE_MOTION
//   (with DIFFUSE_FEEDBACK: the instances moved since last frame, include/surface_motion.glsl),
//   BOUNCE_FEEDBACK (with DIFFUSE_FEEDBACK: paths past their last bounce take last frame's
//   light, feedback_irradiance; the setting bounce_feedback), RADIANCE_CACHE,
//   RADIANCE_CACHE_SLOTS, RADIANCE_PROBES, RADIANCE_FIXED_BITS (the world-space radiance
//   cache, and its table's size, probes and fixed point,
//   include/radiance_cache.glsl: with DIFFUSE_FEEDBACK its cells are read and filled, with
//   DIFFUSE_NO_HISTORY only filled), SHORT_PATHS_INDEPENDENT (a measurement switch: the short
//   paths' first directions independent, pixel_path), PIXEL_SHIFTS_INDEPENDENT (a
//   measurement switch: each pixel's first directions shifted by numbers of its own, not
//   interleaved with its neighbours', lattice_random).
// Storage blocks, uniform blocks, samplers: as trace/hybrid_trace.comp.glsl's contract lists
//   them; CounterBuffer counts this kernel's rays per path vertex (tracer.COUNTER_KINDS);
//   RadianceCache, with RADIANCE_CACHE.
// Uniforms: trace_ray.glsl's, u_diffuse_bounces, u_diffuse_rays, u_pixel_origin, u_gather_seed.
// Workgroup 8x8: neighbouring pixels' first rays start close together.
#include "trace_ray.glsl"
// Compiled only with EMITTER_LIGHT (some triangles emit).
#include "emitter_light.glsl"
#include "denoise.glsl"

// Paths a pixel without the denoiser's history traces, as a multiple of u_diffuse_rays
// (history_paths; DIFFUSE_NO_HISTORY: a denoised frame with no history at all, every pixel).
uniform int u_short_history_paths;

#ifdef SURFACE_MOTION
#include "surface_motion.glsl"
#endif

#ifdef RADIANCE_CACHE
// The world-space radiance cache (passes/diffuse_light/radiance_cache.py): where a path
// bounces diffusely off its first surface, the pixel counts that surface's cell's mean
// irradiance, once it holds u_radiance_min_deposits paths, instead of the path's own
// continuation (by the pixel's weight, below), which the path still traces and leaves in
// the cell.
#include "radiance_cache.glsl"
uniform float u_radiance_min_deposits;
// The denoiser's history at which a pixel's paths no longer count the cells: they count
// them by a weight falling from 1 (no history) to 0 there. A long history already averages
// that many frames of the pixel's own independent paths, where a cell's mean, which changes
// slowly, would keep its error over those frames.
uniform float u_radiance_history_frames;
// By what weight the current pixel's paths count the cells (pixel_paths): 0 not at all.
float pixel_cache_weight = 0.0;
// Short paths a pixel traces beside its own where its history is new (pixel_paths): this
// many over the frames its history holds (one at least) plus one, no fewer than
// u_radiance_short_floor while it counts the cells; 0 while no frame has filled the cells yet.
uniform int u_radiance_short_paths;
uniform int u_radiance_short_floor;
// The current pixel's paths of its own (those after them are short: diffuse_path_step), and the
// frames its history holds.
int pixel_full_paths = 0;
float pixel_frames = 0.0;
// The share of the pixel's first rays that did not escape to the sky, as its history holds
// it (1 where it holds none): where they escape a short path costs a whole one.
float pixel_enclosed = 1.0;
#endif

#ifdef DIFFUSE_FEEDBACK
// Last frame's diffuse light where the camera saw it (DenoisePass.feedback): the temporal
// blend of the irradiance, the surface point and normal of each texel, that frame's
// view-projection and size.
uniform sampler2D u_feedback_color;
uniform sampler2D u_feedback_surface;
uniform mat4 u_feedback_view_proj;
uniform ivec2 u_feedback_size;
// Frames the denoiser's history holds: this frame's index in it (gather_index).
uniform int u_feedback_frames;
// Last frame's history length per texel (DenoiseHistory "length": x frames, 0 background).
uniform sampler2D u_feedback_length;

// The texel q of last frame's image that showed the point p (facing normal n): false where
// last frame's camera did not see that very point (off its image, the background, another
// surface there).
bool feedback_texel(vec3 p, vec3 n, out ivec2 q) {
    q = ivec2(0);
    vec4 clip = u_feedback_view_proj * vec4(p, 1.0);
    if (!(clip.w > 0.0)) return false;
    vec2 ndc = clip.xy / clip.w;
    if (any(greaterThanEqual(abs(ndc), vec2(1.0)))) return false;
    q = clamp(ivec2((ndc * 0.5 + 0.5) * vec2(u_feedback_size)), ivec2(0), u_feedback_size - 1);
    vec4 surface = texelFetch(u_feedback_surface, q, 0);
    float scale = u_orthographic != 0 ? 1.0 : distance(p, u_camera_position);
    return !(denoise_is_background(surface) || abs(dot(denoise_surface_normal(surface), n)) < 0.9
             || denoise_plane_offset(p, n, surface.xyz, scale) > 0.02);
}

// How many times u_diffuse_rays paths a primary point traces whose history holds `frames`
// frames (history_frames): more where the denoiser's history holds few. What the camera just
// uncovered, or what a moving object uncovers, is otherwise shown from one
// or two samples, filtered hard and blotchy: u_short_history_paths times the paths for a
// point last frame did not see, falling as 1 / (frames + 1) to 1 by the time the temporal
// blend has a few frames. Only those pixels pay: a camera that moves keeps the history of
// what it still sees.
int history_paths(float frames) {
    int most = max(u_short_history_paths, 1);
    return clamp(int(ceil(float(most) / (frames + 1.0))), 1, most);
}

// How many frames the denoiser's history holds of the pixel's point p (normal n): 0 where
// last frame did not see it; `escaped` the history's blend of the share of the point's first
// rays that escaped (u_ambient's a), 0 where it holds none.
float history_frames(ivec2 pixel, vec3 p, vec3 n, out float escaped) {
    ivec2 q;
    bool seen = feedback_texel(p, n, q);
#ifdef SURFACE_MOTION
    // A moved instance's pixel: where its point stood last frame, as the denoiser's
    // reprojection looks it up when the camera's motion alone finds nothing.
    if (!seen && surface_moved_back(pixel, p, n)) seen = feedback_texel(p, n, q);
#endif
    escaped = seen ? clamp(texelFetch(u_feedback_color, q, 0).a, 0.0, 1.0) : 0.0;
    return seen ? texelFetch(u_feedback_length, q, 0).x : 0.0;
}

// Last frame's irradiance at the surface h a path ends on, if last frame's camera saw that
// very point (the texel found: `seen`); else nothing (as without feedback). With
// BOUNCE_FEEDBACK a path past its last bounce takes it, and the lamps' light there, instead
// of none: each frame adds the bounces its paths trace to those the last frame held, so
// bounces build up over frames, and die away as they do in a room (by the albedo, below 1):
// a light switched off leaves nothing after a few frames. It adds bounces past Diffuse
// Bounces (Cycles' count), and a view's first frame, which has no last frame, lacks them:
// an option, off by default.
vec3 feedback_irradiance(Hit h, SpecularSplit hs, out bool seen) {
    ivec2 q;
    seen = feedback_texel(h.position, hs.n_facing, q);
    return seen ? texelFetch(u_feedback_color, q, 0).rgb : vec3(0.0);
}
#endif

#ifdef PERSISTENT_PATHS
layout(local_size_x = 64) in;
#else
layout(local_size_x = 8, local_size_y = 8) in;
#endif
layout(rgba32f) writeonly uniform image2D u_ambient;
uniform int u_diffuse_bounces;  // 0..MAX_DIFFUSE_BOUNCES
uniform int u_diffuse_rays;     // paths per pixel

#define MAX_DIFFUSE_BOUNCES 8    // settings.FIELD_LIMITS["diffuse_bounces"]
#define MAX_GLASS_CROSSINGS 4    // glass surfaces one path passes straight through
#define PATH_SALT 0x5ca1         // random numbers of path i, vertex k: gather_random(PATH_SALT + 32 i + k)
#define EMITTER_SALT 0x6ca1
#define GLOSSY_SALT 0x7ca1       // the specular lobe's direction and the lobe's pick at a path's vertex
#define EXTRA_FIRST_SALT 0x8ca1  // the first direction of path i >= u_diffuse_rays (history_paths)
#define SHORT_FIRST_SALT 0x9ca1  // the first directions' lattice shift of the short paths (pixel_path)
#define MAX_SHORT_PATHS 64       // a pixel's short paths in one frame at most (pixel_paths)

// Whose numbers this frame's paths draw. Without a history, the view's sample (a final
// render's samples, a still view's redraws). With the denoiser's history, the frame's index
// in it, which equals the sample in a final render and a still view, but goes on counting
// where the viewport restarts its sample at 0 on every redraw that something moved: a
// moving camera, or a still camera with a moving object. There, the view's sample would
// give a surface point the same paths every frame, and the temporal blend would average one
// frame's noise with itself instead of converging.
uint gather_index() {
#ifdef DIFFUSE_FEEDBACK
    return uint(u_feedback_frames);
#else
    return uint(u_sample);
#endif
}

// Which set of numbers the paths draw: 0 the product's; another whole number makes every
// number of the paths another (gather_random, lattice_random), so that a measurement can
// average its figures over several sets (benchmarks/light_noise.py --realizations). A
// uniform, not a compile-time switch: every set runs the one compiled kernel.
uniform int u_gather_seed;

// The last word of the key of `salt`'s numbers: another set of every number for each seed.
uint gather_salt(int salt) {
    return uint(salt) ^ (uint(u_gather_seed) << 20u);
}

// Two uniform numbers for `salt` of this pixel's paths (lobe_random's, at gather_index()).
vec2 gather_random(int salt) {
    return random2(uvec4(pixel_key.x, pixel_key.y ^ pcg_hash(pixel_key.z), gather_index(),
                         gather_salt(salt)));
}

// Interleaved first directions (Keller & Heidrich 2001, interleaved sampling). Each pixel
// shifts its lattice of first directions (lattice_random) by a point of a second lattice,
// over the screen: pixel (x, y) of the whole frame (u_pixel_origin: a render region's or a
// sub-pixel sample's first pixel) takes x PIXEL_LATTICE_X + y PIXEL_LATTICE_Y, modulo 1. A
// few neighbouring pixels then sample the hemisphere evenly between them, where shifts of
// their own (PIXEL_SHIFTS_INDEPENDENT) clump and leave holes: what a handful of pixels
// average, as the denoiser's wavelet filter does, is nearer the light, and their error,
// moved from the blotches the filter leaves to the pixel scale it removes, is smaller after
// it. The two vectors are those among which the light's slowest variations over the
// hemisphere (its Fourier modes up to 2 either way) vary fastest over the screen: the
// pattern is close to a 3x3 tile of strata, which drifts so that no two pixels nearby take
// the same. Each pixel still follows its own lattice over the frames; what it converges to
// is unchanged. The short paths take the lattice transposed (pixel_short_shift): otherwise
// a pixel's short and own paths would keep one offset between them over the whole screen.
// In 32-bit fixed point, as the lattice: the wrap of the products is the modulo.
uniform ivec2 u_pixel_origin;
const uvec2 PIXEL_LATTICE_X = uvec2(4091825466u, 1462072640u);
const uvec2 PIXEL_LATTICE_Y = uvec2(2842969710u, 4054245591u);
uvec2 pixel_own_shift = uvec2(0u);    // the pixel's own paths' shift (set by pixel_paths)
uvec2 pixel_short_shift = uvec2(0u);  // its short paths'

void set_pixel_shifts(ivec2 pixel) {
    uvec2 whole = uvec2(pixel + u_pixel_origin);
    pixel_own_shift = whole.x * PIXEL_LATTICE_X + whole.y * PIXEL_LATTICE_Y;
    pixel_short_shift = whole.x * PIXEL_LATTICE_Y + whole.y * PIXEL_LATTICE_X;
}

// Point k of the R2 sequence (Roberts 2018: the plastic number's Kronecker lattice, in 32-bit
// fixed point so that the index never loses precision), shifted by `salt`'s number, the same
// everywhere, and the pixel's `pixel_shift` (Cranley-Patterson rotation; above). With
// PIXEL_SHIFTS_INDEPENDENT the shift is a number of the pixel's surface point's key and
// `salt` alone, drawn from the scale-invariant position key (random.glsl) as every other one.
vec2 lattice_random(uint k, int salt, uvec2 pixel_shift) {
#ifdef PIXEL_SHIFTS_INDEPENDENT
    vec2 shift = random2(uvec4(pixel_key.x, pixel_key.y ^ pcg_hash(pixel_key.z), 0x9e3779b9u,
                               gather_salt(salt)));
#else
    vec2 shift = random2(uvec4(0u, 0u, 0x9e3779b9u, gather_salt(salt)))
                 + vec2(pixel_shift >> 8u) * (1.0 / 16777216.0);
#endif
    uvec2 lattice = uvec2(k * 3242174889u, k * 2447445414u);  // k (1/g, 1/g^2) 2^32, g^3 = g + 1
    return fract(vec2(lattice >> 8u) * (1.0 / 16777216.0) + shift);
}

// The first direction of path `path`: point gather_index() * paths + path of the lattice.
// Consecutive frames of one point thus cover the hemisphere evenly where independent numbers
// clump and leave holes, so the mean of a still view's samples, and the temporal blend,
// converge faster than one over the square root of the count; the later bounces, whose
// light is a smaller share, keep independent numbers.
vec2 first_random(int path, int paths) {
    return lattice_random(gather_index() * uint(paths) + uint(path), PATH_SALT, pixel_own_shift);
}

// trace_ray.glsl's spawning is the tracer's: nothing is spawned here.
bool ray_room() { return false; }
void store_ray(vec3 origin, vec3 dir, vec3 weight, int depth, float blur, float reach) {}

#ifdef EMITTER_LIGHT
vec3 random3(int salt) {
    return vec3(gather_random(salt), gather_random(salt + 0x10000).x);
}
#endif

// The emission of the surface h (material hm) a path meets, where it counts: without
// EMITTER_LIGHT always; with it only where the vertex the ray left took no next-event estimate
// of the emitters (`counts`), and with EMITTER_LINKING only where that emitter lights the
// receiver set of the surface the ray left (material row `left`), as Cycles links the
// emitters its indirect rays find. The next-event estimates ask the same of the surface they
// start from (emitter_irradiance).
vec3 path_emission(Hit h, Material hm, bool counts, int left) {
#ifdef EMITTER_LIGHT
    if (!counts) return vec3(0.0);
#ifdef EMITTER_LINKING
    if (!emission_lights_set(h.material, row_light_set(left))) return vec3(0.0);
#endif
#endif
    return material_emission_lod(hm, h.uv, h.lod);
}

// A path on its way: where its next ray leaves from and goes, what it carries and has
// gathered. diffuse_path_step traces one ray of it; the two shapes of main (below) run the
// steps.
struct DiffusePath {
    vec3 o, d;
    vec3 throughput;
    vec3 radiance;  // gathered so far: in the end, the radiance the path brings back
    float sky;      // the share of the first ray that escaped (through glass by its transmission)
    int vertex;     // the ray's vertex: 1 the primary point's ray
    int step;       // rays traced, glass crossings included
    int crossings;
    int path;       // the path's index at its pixel (its random numbers)
    // Whether the surface this ray meets adds its emission with EMITTER_LIGHT: only where the
    // vertex it left took no next-event estimate of the emitters (a glossy lobe's).
    bool emission_counts;
    // The surface the ray left (its light-linking receiver set: path_emission); a glass
    // surface passed straight through is not one.
    int left;
    int material;   // the surface the ray leaves (CUBE_FOOTPRINT)
#ifdef EMITTER_LIGHT
    // The vertex whose next-event estimate is due: its point, facing normals, weight (0: none
    // due), material and index (0 the primary point).
    vec3 nee_point, nee_n, nee_g, nee_weight;
    int nee_material, nee_vertex;
#ifdef RADIANCE_CACHE
    vec3 nee_cont_weight;  // nee_weight's share of the continuation (cont_radiance)
#endif
#endif
#ifdef RADIANCE_CACHE
    // From the diffuse bounce off the path's first surface on (`cached`): what the path
    // gathers per unit of its throughput along the ray that leaves that surface
    // (cont_radiance, cont_throughput; both 0 before), that throughput (cache_throughput),
    // and the surface's cell and its mean as the last frame left it.
    bool cached;
    // A short path (path >= pixel_full_paths: pixel_paths) ends where it bounces off its
    // first surface, once that surface's own estimates are in, on the cell's mean, where the
    // cell holds enough paths; elsewhere it goes on as a whole path. `ends_on_cache`: it has
    // reached that end.
    bool ends_on_cache;
    vec3 cont_throughput, cont_radiance, cache_throughput;
    vec4 cache_mean;
    uvec2 cache_cell;
#endif
};

// What the path gathers: `light` times its throughput.
void path_gather(inout DiffusePath s, vec3 light) {
    s.radiance += s.throughput * light;
#ifdef RADIANCE_CACHE
    s.cont_radiance += s.cont_throughput * light;
#endif
}

// The path's throughput times `f` (a surface's weight, glass's transmission).
void path_scale(inout DiffusePath s, vec3 f) {
    s.throughput *= f;
#ifdef RADIANCE_CACHE
    s.cont_throughput *= f;
#endif
}

// The radiance the ended path s brings back to its pixel, of which `own` is the part only
// the pixel's own (not short) paths estimate, averaged over those alone (store_ambient).
// With the cache, where the path bounced diffusely off its first surface, it leaves there
// the irradiance its continuation brought (pi times its radiance: cosine-distributed
// directions); where that cell holds enough paths, the pixel counts the cell's mean by its
// weight w, and its own continuation by 1 - w. A short path has no continuation of its own:
// it counts the cell's mean by w, and the own paths' continuations stand in for the rest,
// so that the cells count by w whatever the mix (pixel_paths).
vec3 path_result(DiffusePath s, out vec3 own) {
    own = vec3(0.0);
#ifdef RADIANCE_CACHE
    vec3 cell = s.cache_throughput * (s.cache_mean.rgb / PI);
    if (s.ends_on_cache) return s.radiance + pixel_cache_weight * cell;
    if (s.cached) {
        radiance_deposit(s.cache_cell, PI * s.cont_radiance);
        if (pixel_cache_weight > 0.0 && s.cache_mean.a >= u_radiance_min_deposits) {
            vec3 continuation = s.cache_throughput * s.cont_radiance;
            own = (1.0 - pixel_cache_weight) * continuation;
            return s.radiance - continuation + pixel_cache_weight * cell;
        }
    }
#endif
    return s.radiance;
}

// A path from the primary point p (facing geometric normal g) along its first direction d,
// before its first ray. `first_emission`: the first surface's emission counts even with
// EMITTER_LIGHT (a glossy lobe's paths, which take no next-event estimate of the emitters).
// `n`: the primary point's facing shading normal, where the emitters' next-event estimate of
// the diffuse layer starts (not for a glossy lobe's paths, first_emission). `material`: the
// primary point's.
DiffusePath diffuse_path_start(vec3 p, vec3 g, vec3 n, vec3 d, int path, bool first_emission, int material) {
    DiffusePath s;
    s.o = offset_origin(p, g);
    s.d = d;
    s.throughput = vec3(1.0);
    s.radiance = vec3(0.0);
    s.sky = 0.0;
    s.vertex = 1;
    s.step = 0;
    s.crossings = 0;
    s.path = path;
    s.emission_counts = first_emission;
    s.left = material;
    s.material = material;
#ifdef EMITTER_LIGHT
    s.nee_point = p;
    s.nee_n = n;
    s.nee_g = g;
    s.nee_weight = first_emission ? vec3(0.0) : vec3(1.0 / PI);
    s.nee_material = material;
    s.nee_vertex = 0;
#ifdef RADIANCE_CACHE
    s.nee_cont_weight = vec3(0.0);
#endif
#endif
#ifdef RADIANCE_CACHE
    s.cached = false;
    s.ends_on_cache = false;
    s.cont_throughput = vec3(0.0);
    s.cont_radiance = vec3(0.0);
    s.cache_throughput = vec3(0.0);
    s.cache_mean = vec4(0.0);
    s.cache_cell = uvec2(0u);
#endif
    return s;
}

// One ray of the path s, and what the surface it meets gives: false once the path has ended
// (s.radiance is then what it brings back; for a cosine-distributed first direction, pi
// times it estimates the irradiance).
//
// Each heavy step has one call site, as the tracer's kernels keep theirs: a GPU compiler
// inlines every call, and a second copy of the emitters' estimate (a whole trace_ray) or of
// the lamps' shading makes the kernel larger and slower however rarely it runs
// (docs/BENCHMARKS.md, GPU figures). The estimate of a vertex therefore waits for the next
// step, and both shapes of main call this function once.
bool diffuse_path_step(inout DiffusePath s) {
#ifdef EMITTER_LIGHT
    if (max(max(s.nee_weight.r, s.nee_weight.g), s.nee_weight.b) > 0.0) {
#if CUBE_FOOTPRINT
        cube_origin_material = s.nee_material;  // the shadow ray leaves that vertex's surface
#endif
        vec3 e = emitter_irradiance(s.nee_point, s.nee_n, s.nee_g, random3(EMITTER_SALT + 32 * s.path + s.nee_vertex),
                                    material_light_set(materials[s.nee_material]), s.nee_vertex);
        s.radiance += s.nee_weight * e;
#ifdef RADIANCE_CACHE
        s.cont_radiance += s.nee_cont_weight * e;
#endif
        s.nee_weight = vec3(0.0);
    }
#endif
#ifdef RADIANCE_CACHE
    if (s.ends_on_cache) return false;
#endif
    if (s.step > MAX_DIFFUSE_BOUNCES + MAX_GLASS_CROSSINGS) return false;
    s.step += 1;
#if CUBE_FOOTPRINT
    // The surface the ray leaves (cube_march.glsl "Surface footprints").
    cube_origin_material = s.material;
#endif
    vec3 d = s.d;
    Hit h = trace_ray(s.o, d, s.vertex, PATH_TEXTURE_BLUR, FLOAT_MAX);
#if CUBE_FOOTPRINT
    s.material = h.material;
#endif
    if (h.kind == HIT_SKY) {
        path_gather(s, sky_radiance(d));
        if (s.vertex == 1) s.sky = s.throughput.g;
        return false;
    }
    Material hm = hit_material(h, d, s.vertex);
    vec3 h_albedo = material_albedo_lod(hm, h.uv, h.lod);
    SpecularSplit hs = specular_split_geometric(hm, h_albedo, d, h.normal, h.geometric);
    bool bounces_left = s.vertex <= u_diffuse_bounces;
#ifdef LIT_CUBE
    // A surface in the cube map holds its light already (the lit cube map: lamps, World
    // and the bounces fed back from earlier frames): the path ends there. Its texels hold
    // no emission (cube_light_shade.comp.glsl): the path adds it as it adds a surface's
    // the BVH finds (below), only where the last vertex took no next-event estimate of
    // the emitters.
    if (bounces_left && h.kind == HIT_CUBE) {
        path_gather(s, cube_stored_radiance(h, 0.0) + path_emission(h, hm, s.emission_counts, s.left));
        return false;
    }
#endif
    path_gather(s, path_emission(h, hm, s.emission_counts, s.left));
    float through = material_transmission(hm);
    // The lamps' light off this surface (its emission counted above), where the path goes
    // on from it, or ends on it with last frame's light; the ray stands for a whole
    // hemisphere, so highlights are filtered as the roughest lobe.
    bool lamps = bounces_left;
#if defined(BOUNCE_FEEDBACK) && defined(DIFFUSE_FEEDBACK)
    bool ends_on_feedback = false;
    if (!bounces_left && hs.diffuse_weight > 0.0 && through <= 0.0) {
        path_gather(s, (hs.diffuse_weight * h_albedo / PI) * feedback_irradiance(h, hs, ends_on_feedback));
        lamps = ends_on_feedback;
    }
#endif
    if (lamps) path_gather(s, lamp_light_response(hm, h_albedo, vec3(0.0), h.position, d, hs, 1.0));
#if defined(BOUNCE_FEEDBACK) && defined(DIFFUSE_FEEDBACK)
    if (ends_on_feedback) return false;
#endif
    if (through > 0.0 && s.crossings < MAX_GLASS_CROSSINGS) {
        path_scale(s, vec3(through));
        s.o = offset_origin(h.position, -hs.g_facing);
        s.crossings += 1;
        return true;
    }
    if (!bounces_left) return false;
    // The path goes on along one of the surface's lobes, picked by its share of what the
    // surface reflects: the diffuse layer (a cosine direction) or the specular layers
    // (a visible-normal sample of their GGX lobe, traced or too rough to trace alike;
    // a rough metal has nothing else). A wall sees the sky and the sunlit floor in a
    // glossy floor's reflection, and a rough metal passes on what it reflects, as in a
    // path tracer; ending the path at the specular layers drops that light.
    vec3 diffuse_w = hs.diffuse_weight * h_albedo;
    SpecularSplit gs = specular_split_sampled(hm, h_albedo, d, h.normal, h.geometric,
                                              gather_random(GLOSSY_SALT + 32 * s.path + s.vertex));
    vec3 specular_w = gs.reflect_weight + gs.glossy_local;
    float p_diffuse = dot(diffuse_w, vec3(1.0));
    float p_specular = dot(specular_w, vec3(1.0));
    if (!(p_diffuse + p_specular > 0.0)) return false;
    if (gather_random(GLOSSY_SALT + 32 * s.path + s.vertex + 16).x * (p_diffuse + p_specular) < p_specular) {
        path_scale(s, specular_w * ((p_diffuse + p_specular) / p_specular));
        if (!(max(max(s.throughput.r, s.throughput.g), s.throughput.b) > 0.0)) return false;
        s.d = gs.reflect_dir;
        s.o = offset_origin(h.position, gs.g_facing);
        s.emission_counts = true;  // no next-event estimate of the emitters along a specular lobe
        s.left = h.material;
        s.vertex += 1;
        return true;
    }
    s.emission_counts = false;
    path_scale(s, diffuse_w * ((p_diffuse + p_specular) / p_diffuse));
    if (!(max(max(s.throughput.r, s.throughput.g), s.throughput.b) > 0.0)) return false;
#ifdef EMITTER_LIGHT
    s.nee_point = h.position;
    s.nee_n = hs.n_facing;
    s.nee_g = hs.g_facing;
    s.nee_weight = s.throughput / PI;
    s.nee_material = h.material;
    s.nee_vertex = s.vertex;
#ifdef RADIANCE_CACHE
    // The first surface's own estimate of the emitters is the pixel's, not the cell's (0:
    // its continuation starts below).
    s.nee_cont_weight = s.cont_throughput / PI;
#endif
#endif
#ifdef RADIANCE_CACHE
    if (s.vertex == 1) {
        s.cached = true;
        s.cache_throughput = s.throughput;
        s.cont_throughput = vec3(1.0);
        s.cont_radiance = vec3(0.0);
        s.cache_cell = radiance_cell(h.position, hs.g_facing);
        // Only a pixel that counts the cells reads one (a long history's fills them alone).
        s.cache_mean = pixel_cache_weight > 0.0 ? radiance_lookup(s.cache_cell) : vec4(0.0);
        if (s.path >= pixel_full_paths && s.cache_mean.a >= u_radiance_min_deposits) {
            // The surface's own estimate of the emitters (due at the next step) is still
            // the path's; then it ends (path_result).
            s.ends_on_cache = true;
#ifdef EMITTER_LIGHT
            return true;
#else
            return false;
#endif
        }
    }
#endif
    s.d = cosine_direction(hs.n_facing, hs.g_facing, gather_random(PATH_SALT + 32 * s.path + s.vertex));
    s.o = offset_origin(h.position, hs.g_facing);
    s.left = h.material;
    s.vertex += 1;
    return true;
}

// How many paths the pixel traces: 0 where it is background or neither diffuse nor a rough
// metal (its ambient is then (0, 0, 0, 1)). Sets pixel_key, whose numbers its paths draw.
int pixel_paths(ivec2 pixel) {
    vec4 nm = texelFetch(u_normal_material, pixel, 0);
    if (nm.w == 0.0) return 0;
    Material m = primary_material(int(abs(nm.w) + 0.5) - 1, pixel);
    if (!(material_glossy_gathered(m) || material_diffuse(m) > 0.0)) return 0;
    vec3 p, view_dir, n;
    primary_surface(pixel, nm, p, view_dir, n);
    pixel_key = position_key(p);
    set_pixel_shifts(pixel);
    int paths = max(u_diffuse_rays, 1);
#ifdef DIFFUSE_FEEDBACK
    vec4 albedo_g = texelFetch(u_albedo, pixel, 0);
    vec3 g = gbuffer_geometric(albedo_g.a, texelFetch(u_emission_scale, pixel, 0).a, n);
    vec3 g_facing = dot(g, view_dir) < 0.0 ? g : -g;
    float escaped;
    float frames = history_frames(pixel, p, dot(n, g_facing) >= 0.0 ? n : -n, escaped);
    paths *= history_paths(frames);
#ifdef RADIANCE_CACHE
    pixel_cache_weight = clamp(1.0 - frames / u_radiance_history_frames, 0.0, 1.0);
    pixel_frames = frames;
    pixel_enclosed = 1.0 - escaped;
#endif
#elif defined(DIFFUSE_NO_HISTORY)
    paths *= max(u_short_history_paths, 1);
#endif
#ifdef RADIANCE_CACHE
    // The short paths: most where the history is new, falling as its extra paths do
    // (history_paths) to a floor, times the weight by which it counts the cells, and times
    // the share of its first rays that do not escape (where they escape, a short path is a
    // whole path: outdoors they would double a view's first frames for the first bounce's
    // noise, which the sky's smooth light keeps small), rounded to the nearest: none once
    // they would be fewer than half a path. A pixel last frame did not see (what the camera
    // or an object uncovers) traces as many as one frame of history would: its own paths are
    // already several (history_paths), and how many of its rays escape is not known.
    pixel_full_paths = paths;
    float short_paths = max(float(u_radiance_short_paths) / (max(pixel_frames, 1.0) + 1.0),
                            float(u_radiance_short_floor));
    paths += min(int(pixel_cache_weight * pixel_enclosed * short_paths + 0.5), MAX_SHORT_PATHS);
#endif
    return paths;
}

// Path i of the pixel, before its first ray (the pixel's surface read again from the
// G-buffer: a pixel's state is then its index and sums alone, what the persistent shape
// keeps while other pixels' paths run).
DiffusePath pixel_path(ivec2 pixel, int i) {
    vec4 nm = texelFetch(u_normal_material, pixel, 0);
    int material = int(abs(nm.w) + 0.5) - 1;
    Material m = primary_material(material, pixel);
    // A rough metal gathers along its glossy lobe (shading.glsl material_glossy_gathered):
    // pi times the radiance its lobe's samples bring back, which the deferred shading
    // takes in place of the prefiltered sky.
    bool glossy = material_glossy_gathered(m);
    vec3 p, view_dir, n;
    primary_surface(pixel, nm, p, view_dir, n);
    vec4 albedo_g = texelFetch(u_albedo, pixel, 0);
    vec3 g = gbuffer_geometric(albedo_g.a, texelFetch(u_emission_scale, pixel, 0).a, n);
    vec3 g_facing = dot(g, view_dir) < 0.0 ? g : -g;
    vec3 n_facing = dot(n, g_facing) >= 0.0 ? n : -n;
    int rays = max(u_diffuse_rays, 1);
    // Diffuse Rays' paths follow the frames' low-discrepancy sequence (first_random);
    // the extra paths of a short history draw independent numbers, so that the
    // sequence, which a pixel follows for as long as it stays in view, is the same
    // whether or not its first frames traced more.
    vec2 xi = i < rays ? first_random(i, rays) : gather_random(EXTRA_FIRST_SALT + i);
#if defined(RADIANCE_CACHE) && !defined(SHORT_PATHS_INDEPENDENT)
    // A pixel's short paths of one frame take consecutive points of a lattice of their own
    // (lattice_random, MAX_SHORT_PATHS points a frame): a handful of them then cover the
    // hemisphere evenly, so which surfaces the first bounce meets, the noise they sample,
    // is averaged better than by as many independent directions. SHORT_PATHS_INDEPENDENT
    // (a measurement switch, tests/test_radiance_cache.py) draws independent ones.
    if (i >= pixel_full_paths)
        xi = lattice_random(gather_index() * uint(MAX_SHORT_PATHS) + uint(i - pixel_full_paths), SHORT_FIRST_SALT,
                            pixel_short_shift);
#endif
    // The glossy lobe's direction: a visible-normal sample of its GGX lobe, as the
    // tracer samples the traced ones (weight 1: split.glossy_local is the lobe's albedo).
    vec3 d = glossy ? specular_split_sampled(m, albedo_g.rgb, view_dir, n, g, xi).reflect_dir
                    : cosine_direction(n_facing, g_facing, xi);
    // With the emitters' next-event estimate of the diffuse layer (cosine-weighted).
    return diffuse_path_start(p, g_facing, n_facing, d, i, glossy, material);
}

// The pixel's ambient from the sums of its `paths` paths' radiance and sky, and of its own
// paths' `own` part (path_result).
void store_ambient(ivec2 pixel, vec3 radiance, vec3 own, float sky, int paths) {
    vec4 ambient = paths > 0 ? vec4(PI * radiance, sky) / float(paths) : vec4(0.0, 0.0, 0.0, 1.0);
#ifdef RADIANCE_CACHE
    if (pixel_full_paths > 0) ambient.rgb += PI * own / float(pixel_full_paths);
#endif
    if (any(isnan(ambient)) || any(isinf(ambient))) ambient = vec4(0.0, 0.0, 0.0, 1.0);
    imageStore(u_ambient, pixel, ambient);
}

#ifdef PERSISTENT_PATHS
// The GPU's shape: persistent threads with path regeneration (Aila & Laine 2009; Novak et
// al. 2010). A path's length varies from one ray (most escape to the sky or end in the lit
// cube map) to several bounces, and a warp runs as long as its longest path: per pixel,
// most of its lanes would idle through the few long paths' bounces. Here each invocation
// traces one ray per turn, and one whose path ended starts the next path of its pixel, or
// takes the next pixel from a shared counter, so the lanes stay busy until the work runs
// out. Items are the pixels in 8x8 tiles, so a warp's paths start close together as the
// per-pixel shape's do. The images are the same as that shape's: a pixel's numbers are keyed
// by its surface (pixel_key), never by the invocation that traces it.
layout(std430) buffer PathWork { uint next_item; };  // zeroed before the dispatch
uniform int u_invocations;  // invocations launched: each starts with item gl_GlobalInvocationID.x

ivec2 item_pixel(uint item) {
    uint tiles_x = (uint(u_size.x) + 7u) / 8u;
    uint tile = item / 64u, within = item % 64u;
    return ivec2(int((tile % tiles_x) * 8u + within % 8u), int((tile / tiles_x) * 8u + within / 8u));
}

void main() {
    uint items = ((uint(u_size.x) + 7u) / 8u) * ((uint(u_size.y) + 7u) / 8u) * 64u;
    uint item = gl_GlobalInvocationID.x;
    ivec2 pixel = ivec2(0);
    int paths = 0, i = 0;
    vec3 radiance = vec3(0.0), own = vec3(0.0);
    float sky = 0.0;
    bool live = false;
    DiffusePath s;
    for (;;) {
        if (!live) {
            if (i >= paths) {
                // The next pixel with paths to trace (others store their ambient at once).
                paths = 0;
                while (paths == 0) {
                    if (item >= items) break;
                    pixel = item_pixel(item);
                    item = atomicAdd(next_item, 1u) + uint(u_invocations);
                    if (any(greaterThanEqual(pixel, u_size))) continue;
                    paths = pixel_paths(pixel);
                    if (paths == 0) store_ambient(pixel, vec3(0.0), vec3(0.0), 0.0, 0);
                }
                if (paths == 0) break;
                i = 0;
                radiance = vec3(0.0);
                own = vec3(0.0);
                sky = 0.0;
            }
            s = pixel_path(pixel, i);
        }
        live = diffuse_path_step(s);
        if (!live) {
            vec3 path_own;
            radiance += path_result(s, path_own);
            own += path_own;
            sky += s.sky;
            i += 1;
            if (i >= paths) store_ambient(pixel, radiance, own, sky, paths);
        }
    }
}
#else
// llvmpipe's shape: one pixel per invocation, its paths one after another (8-wide SIMD on a
// CPU core idles less over long paths than a GPU's warp, and pays for the shared counter).
void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(pixel, u_size))) return;
    int paths = pixel_paths(pixel);
    vec3 radiance = vec3(0.0), own = vec3(0.0);
    float sky = 0.0;
    for (int i = 0; i < paths; ++i) {
        DiffusePath s = pixel_path(pixel, i);
        while (diffuse_path_step(s)) {}
        vec3 path_own;
        radiance += path_result(s, path_own);
        own += path_own;
        sky += s.sky;
    }
    store_ambient(pixel, radiance, own, sky, paths);
}
#endif
