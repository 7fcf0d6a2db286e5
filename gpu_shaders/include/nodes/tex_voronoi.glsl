// SPDX-License-Identifier: GPL-3.0-or-later
// Blender's Voronoi Texture node: Worley's cellular noise ("A Cellular Texture Basis Function",
// SIGGRAPH 1996) on Blender's lattice of one random feature point per unit cell, with Inigo
// Quilez's smooth minimum for Smooth F1 and his exact distance to the cell border ("voronoi
// edges"), summed over octaves the way Blender 4's Voronoi does (an fBM whose sums of
// position and edge distance are blends, since a sum of positions means nothing).
//
// The feature points and cell colours come from the hash of the cell coordinates
// (nodes/hash.glsl: PCG of the integer cell for 2D-4D, lookup3 of the cell's float coordinate
// for 1D), so each cell carries the same point and colour as in Cycles; only float rounding
// of the distances differs.
//
// node_tex_voronoi(dimensions, feature, metric, normalize,
//                  vector, w, scale, detail, roughness, lacunarity, smoothness, exponent,
//                  randomness, out distance_out, out color_out, out position_out, out w_out,
//                  out radius_out)
//   Settings (int codes <-> Blender's enum strings):
//     dimensions  (voronoi_dimensions): 1 '1D', 2 '2D', 3 '3D' (default), 4 '4D'
//     feature     (feature): 0 'F1' (default), 1 'F2', 2 'SMOOTH_F1', 3 'DISTANCE_TO_EDGE',
//                            4 'N_SPHERE_RADIUS'
//     metric      (distance): 0 'EUCLIDEAN' (default), 1 'MANHATTAN', 2 'CHEBYCHEV',
//                            3 'MINKOWSKI'; 1D and the last two features measure Euclidean.
//     normalize   (normalize): 0 False (default), 1 True
//   Inputs (socket identifier: Blender's default):
//     vector "Vector": the Texture Coordinate's Generated output when unlinked (the caller
//       supplies it); w "W": 0.0; scale "Scale": 5.0; detail "Detail": 0.0 (0..15, a
//       fraction blends in the last octave); roughness "Roughness": 0.5; lacunarity
//       "Lacunarity": 2.0; smoothness "Smoothness": 1.0 (Smooth F1 only); exponent
//       "Exponent": 0.5 (Minkowski only); randomness "Randomness": 1.0.
//   Outputs (socket identifier): distance_out "Distance" (F1, F2, Smooth F1, Distance to
//     Edge), color_out "Color", position_out "Position" (2D-4D) and w_out "W" (1D, 4D) for F1,
//     F2 and Smooth F1, radius_out "Radius" (N-Sphere Radius). Outputs a feature does not
//     have are 0, as in Cycles.
#ifndef HYBRID_NODES_TEX_VORONOI_GLSL
#define HYBRID_NODES_TEX_VORONOI_GLSL
#include "include/nodes/hash.glsl"

const int VORONOI_F1 = 0;
const int VORONOI_F2 = 1;
const int VORONOI_SMOOTH_F1 = 2;
const int VORONOI_DISTANCE_TO_EDGE = 3;
const int VORONOI_N_SPHERE_RADIUS = 4;

const int VORONOI_EUCLIDEAN = 0;
const int VORONOI_MANHATTAN = 1;
const int VORONOI_CHEBYCHEV = 2;
const int VORONOI_MINKOWSKI = 3;

const float VORONOI_FLT_MAX = 3.402823466e+38;

// Every dimension runs through one code path on vec4 coordinates: a 1D coordinate sits in .x,
// 2D in .xy, 3D in .xyz, 4D in all four; unused components stay exactly 0 (their cells are
// never searched), so they add nothing to a distance. One path instead of four keeps the
// interpreter shader that wires this node as one opcode small.

// How far the cell search reaches along each axis: r on the used axes, 0 on the others.
ivec4 voronoi_reach(int dimensions, int r) {
    return ivec4(r, dimensions >= 2 ? r : 0, dimensions >= 3 ? r : 0, dimensions >= 4 ? r : 0);
}

// The cell's feature point, in [0, 1] per used axis, before Randomness scales it.
vec4 voronoi_cell_point(int dimensions, ivec4 cell) {
    // 1D hashes the cell's coordinate as a float, as Blender does (exact below 2^24).
    if (dimensions == 1) return vec4(hash_float_to_float(float(cell.x)), 0.0, 0.0, 0.0);
    if (dimensions == 2) return vec4(hash_ivec2_to_vec2(cell.xy), 0.0, 0.0);
    if (dimensions == 3) return vec4(hash_ivec3_to_vec3(cell.xyz), 0.0);
    return hash_ivec4_to_vec4(cell);
}

vec3 voronoi_cell_color(int dimensions, ivec4 cell) {
    if (dimensions == 1) return hash_float_to_vec3(float(cell.x));
    if (dimensions == 2) return hash_ivec2_to_vec3(cell.xy);
    if (dimensions == 3) return hash_ivec3_to_vec3(cell.xyz);
    return hash_ivec4_to_vec4(cell).xyz;
}

// The length of d in the chosen metric; 1D is always |d|. `minkowski`: whether the metric
// may be Minkowski. The cell searches below call it with a literal there, from one branch per
// kind of metric outside their loops (voronoi_octave): Minkowski's four or five powers per cell
// are then compiled only into the loop that runs them, so a driver that executes both sides of
// a branch (a CPU's SIMD lanes under a mask) does not pay them at every cell of every search.
float voronoi_metric_of(vec4 d, int dimensions, int metric, float exponent, bool minkowski) {
    if (dimensions == 1) return abs(d.x);
    if (metric == VORONOI_EUCLIDEAN) return length(d);
    vec4 a = abs(d);
    if (metric == VORONOI_MANHATTAN) return a.x + a.y + a.z + a.w;
    if (metric == VORONOI_CHEBYCHEV || !minkowski) return max(max(a.x, a.y), max(a.z, a.w));
    // Minkowski: pow(0, e) is undefined in GLSL for e <= 0, so unused axes are left out.
    float sum = pow(a.x, exponent) + pow(a.y, exponent);
    if (dimensions >= 3) sum += pow(a.z, exponent);
    if (dimensions >= 4) sum += pow(a.w, exponent);
    return pow(sum, 1.0 / exponent);
}

float voronoi_metric(vec4 d, int dimensions, int metric, float exponent) {
    return voronoi_metric_of(d, dimensions, metric, exponent, true);
}

// Zero on the unused axes (Smooth F1's blend drifts them otherwise).
vec4 voronoi_mask(vec4 v, int dimensions) {
    return vec4(v.x, dimensions >= 2 ? v.y : 0.0, dimensions >= 3 ? v.z : 0.0,
                dimensions >= 4 ? v.w : 0.0);
}

struct VoronoiOctave {
    float distance;
    vec3 color;
    vec4 position;  // the chosen point, in the octave's coordinates
};

// F1 (nearest point) or F2 (second nearest) over the 3^n cells around the point: with one
// point per unit cell, no nearer point can lie farther out (Worley 1996, section 3).
VoronoiOctave voronoi_f1_f2(int dimensions, int metric, float exponent, float randomness,
                            bool second, vec4 coord, bool minkowski) {
    vec4 cell_f = floor(coord);
    vec4 local = coord - cell_f;
    ivec4 cell = ivec4(cell_f);
    ivec4 r = voronoi_reach(dimensions, 1);
    float d1 = VORONOI_FLT_MAX, d2 = VORONOI_FLT_MAX;
    ivec4 o1 = ivec4(0), o2 = ivec4(0);
    vec4 p1 = vec4(0.0), p2 = vec4(0.0);
    for (int u = -r.w; u <= r.w; ++u)
    for (int k = -r.z; k <= r.z; ++k)
    for (int j = -r.y; j <= r.y; ++j)
    for (int i = -r.x; i <= r.x; ++i) {
        ivec4 offset = ivec4(i, j, k, u);
        vec4 point = vec4(offset) + voronoi_cell_point(dimensions, cell + offset) * randomness;
        float d = voronoi_metric_of(point - local, dimensions, metric, exponent, minkowski);
        if (d < d1) {
            d2 = d1; o2 = o1; p2 = p1;
            d1 = d; o1 = offset; p1 = point;
        } else if (d < d2) {
            d2 = d; o2 = offset; p2 = point;
        }
    }
    VoronoiOctave octave;
    octave.distance = second ? d2 : d1;
    octave.color = voronoi_cell_color(dimensions, cell + (second ? o2 : o1));
    octave.position = (second ? p2 : p1) + cell_f;
    return octave;
}

// Smooth F1: a running smooth minimum (Quilez's polynomial smin) of the distances to the 5^n
// nearest cells' points, with colour and position blended by the same weights. The wider
// window is needed because the smooth minimum feels points beyond the nearest ring.
// `smoothness` is already the node's Smoothness / 2, clamped to [0, 0.5].
VoronoiOctave voronoi_smooth_f1(int dimensions, int metric, float exponent, float randomness,
                                float smoothness, vec4 coord, bool minkowski) {
    vec4 cell_f = floor(coord);
    vec4 local = coord - cell_f;
    ivec4 cell = ivec4(cell_f);
    ivec4 r = voronoi_reach(dimensions, 2);
    float smooth_distance = 0.0;
    vec3 smooth_color = vec3(0.0);
    vec4 smooth_position = vec4(0.0);
    float h = -1.0;
    for (int u = -r.w; u <= r.w; ++u)
    for (int k = -r.z; k <= r.z; ++k)
    for (int j = -r.y; j <= r.y; ++j)
    for (int i = -r.x; i <= r.x; ++i) {
        ivec4 offset = ivec4(i, j, k, u);
        vec4 point = vec4(offset) + voronoi_cell_point(dimensions, cell + offset) * randomness;
        float d = voronoi_metric_of(point - local, dimensions, metric, exponent, minkowski);
        h = h == -1.0 ? 1.0
                      : smoothstep(0.0, 1.0, 0.5 + 0.5 * (smooth_distance - d) / smoothness);
        float correction = smoothness * h * (1.0 - h);
        smooth_distance = mix(smooth_distance, d, h) - correction;
        correction /= 1.0 + 3.0 * smoothness;
        smooth_color = mix(smooth_color, voronoi_cell_color(dimensions, cell + offset), h) - correction;
        smooth_position = mix(smooth_position, point, h) - correction;
    }
    VoronoiOctave octave;
    octave.distance = smooth_distance;
    octave.color = smooth_color;
    octave.position = voronoi_mask(smooth_position, dimensions) + cell_f;
    return octave;
}

// Distance to the nearest cell border (Quilez, "voronoi edges"): find the nearest point, then
// the distance to each bisector plane between it and another point, over the 3^n cells. In 1D
// this is the distance to the nearer midpoint between the middle cell's point and its two
// neighbours, which is how Blender states its 1D case.
float voronoi_distance_to_edge(int dimensions, float randomness, vec4 coord) {
    vec4 cell_f = floor(coord);
    vec4 local = coord - cell_f;
    ivec4 cell = ivec4(cell_f);
    ivec4 r = voronoi_reach(dimensions, 1);
    vec4 to_closest = vec4(0.0);
    float nearest = VORONOI_FLT_MAX;
    for (int u = -r.w; u <= r.w; ++u)
    for (int k = -r.z; k <= r.z; ++k)
    for (int j = -r.y; j <= r.y; ++j)
    for (int i = -r.x; i <= r.x; ++i) {
        ivec4 offset = ivec4(i, j, k, u);
        vec4 to_point = vec4(offset) + voronoi_cell_point(dimensions, cell + offset) * randomness - local;
        float d = dot(to_point, to_point);
        if (d < nearest) { nearest = d; to_closest = to_point; }
    }
    float edge = VORONOI_FLT_MAX;
    for (int u = -r.w; u <= r.w; ++u)
    for (int k = -r.z; k <= r.z; ++k)
    for (int j = -r.y; j <= r.y; ++j)
    for (int i = -r.x; i <= r.x; ++i) {
        ivec4 offset = ivec4(i, j, k, u);
        vec4 to_point = vec4(offset) + voronoi_cell_point(dimensions, cell + offset) * randomness - local;
        vec4 across = to_point - to_closest;
        // The nearest point itself (and a coincident one) has no border with itself.
        if (dot(across, across) > 0.0001) {
            edge = min(edge, dot((to_closest + to_point) / 2.0, normalize(across)));
        }
    }
    return edge;
}

// Half the distance from the nearest point to its own nearest neighbour: the radius of the
// largest n-sphere around the point that stays inside its cell. Always Euclidean.
float voronoi_n_sphere_radius(int dimensions, float randomness, vec4 coord) {
    vec4 cell_f = floor(coord);
    vec4 local = coord - cell_f;
    ivec4 cell = ivec4(cell_f);
    ivec4 r = voronoi_reach(dimensions, 1);
    vec4 closest = vec4(0.0);
    ivec4 closest_offset = ivec4(0);
    float nearest = VORONOI_FLT_MAX;
    for (int u = -r.w; u <= r.w; ++u)
    for (int k = -r.z; k <= r.z; ++k)
    for (int j = -r.y; j <= r.y; ++j)
    for (int i = -r.x; i <= r.x; ++i) {
        ivec4 offset = ivec4(i, j, k, u);
        vec4 point = vec4(offset) + voronoi_cell_point(dimensions, cell + offset) * randomness;
        float d = length(point - local);
        if (d < nearest) { nearest = d; closest = point; closest_offset = offset; }
    }
    nearest = VORONOI_FLT_MAX;
    vec4 neighbour = vec4(0.0);
    for (int u = -r.w; u <= r.w; ++u)
    for (int k = -r.z; k <= r.z; ++k)
    for (int j = -r.y; j <= r.y; ++j)
    for (int i = -r.x; i <= r.x; ++i) {
        if (i == 0 && j == 0 && k == 0 && u == 0) continue;
        ivec4 offset = ivec4(i, j, k, u) + closest_offset;
        vec4 point = vec4(offset) + voronoi_cell_point(dimensions, cell + offset) * randomness;
        float d = length(closest - point);
        if (d < nearest) { nearest = d; neighbour = point; }
    }
    return length(neighbour - closest) / 2.0;
}

VoronoiOctave voronoi_octave(int dimensions, int feature, int metric, float exponent,
                             float randomness, float smoothness, vec4 coord) {
    // Minkowski in a search of its own, every other metric in another (voronoi_metric_of).
    bool minkowski = metric == VORONOI_MINKOWSKI && dimensions != 1;
    if (feature == VORONOI_SMOOTH_F1 && smoothness != 0.0) {
        if (minkowski) return voronoi_smooth_f1(dimensions, metric, exponent, randomness, smoothness, coord, true);
        return voronoi_smooth_f1(dimensions, metric, exponent, randomness, smoothness, coord, false);
    }
    if (minkowski) return voronoi_f1_f2(dimensions, metric, exponent, randomness, feature == VORONOI_F2, coord, true);
    return voronoi_f1_f2(dimensions, metric, exponent, randomness, feature == VORONOI_F2, coord, false);
}

// The octave sum of F1, F2 and Smooth F1 (Blender 4's fractal Voronoi): distances and colours
// add with falling amplitude as in fBM; the position is blended towards each finer octave's
// point by the octave's amplitude. A fractional Detail blends the last octave in by its
// fraction. Detail 0 or Roughness 0 is the single first octave (Lacunarity 0 is not: Cycles
// then adds octaves of the cell at the origin, and so does this).
VoronoiOctave voronoi_fractal(int dimensions, int feature, int metric, float exponent,
                              float randomness, float smoothness, float detail,
                              float roughness, float lacunarity, float max_distance,
                              bool normalize_, vec4 coord) {
    float amplitude = 1.0, max_amplitude = 0.0, scale = 1.0;
    VoronoiOctave sum;
    sum.distance = 0.0; sum.color = vec3(0.0); sum.position = vec4(0.0);
    bool single = detail == 0.0 || roughness == 0.0;
    float last = ceil(detail);
    for (int i = 0; float(i) <= last; ++i) {
        VoronoiOctave octave = voronoi_octave(dimensions, feature, metric, exponent, randomness,
                                              smoothness, coord * scale);
        if (single) {
            max_amplitude = 1.0;
            sum = octave;
            break;
        }
        if (float(i) <= detail) {
            max_amplitude += amplitude;
            sum.distance += octave.distance * amplitude;
            sum.color += octave.color * amplitude;
            sum.position = mix(sum.position, octave.position / scale, amplitude);
            scale *= lacunarity;
            amplitude *= roughness;
        } else {
            float fraction = detail - floor(detail);
            if (fraction != 0.0) {
                max_amplitude = mix(max_amplitude, max_amplitude + amplitude, fraction);
                sum.distance = mix(sum.distance, sum.distance + octave.distance * amplitude, fraction);
                sum.color = mix(sum.color, sum.color + octave.color * amplitude, fraction);
                sum.position = mix(sum.position, mix(sum.position, octave.position / scale, amplitude),
                                   fraction);
            }
        }
    }
    if (normalize_) {
        sum.distance /= max_amplitude * max_distance;
        sum.color /= max_amplitude;
    }
    return sum;
}

// The octave sum of Distance to Edge: each finer octave can only bring an edge nearer, so the
// distance is the minimum over octaves (in the first octave's units), blended in by amplitude;
// the normalizing bound shrinks the same way.
float voronoi_fractal_distance_to_edge(int dimensions, float randomness, float detail,
                                       float roughness, float lacunarity, float max_distance,
                                       bool normalize_, vec4 coord) {
    float amplitude = 1.0, max_amplitude = max_distance, scale = 1.0, distance_ = 8.0;
    bool single = detail == 0.0 || roughness == 0.0;
    float last = ceil(detail);
    for (int i = 0; float(i) <= last; ++i) {
        float octave = voronoi_distance_to_edge(dimensions, randomness, coord * scale);
        if (single) {
            distance_ = octave;
            break;
        }
        if (float(i) <= detail) {
            max_amplitude = mix(max_amplitude, max_distance / scale, amplitude);
            distance_ = mix(distance_, min(distance_, octave / scale), amplitude);
            scale *= lacunarity;
            amplitude *= roughness;
        } else {
            float fraction = detail - floor(detail);
            if (fraction != 0.0) {
                float blended_bound = mix(max_amplitude, max_distance / scale, amplitude);
                max_amplitude = mix(max_amplitude, blended_bound, fraction);
                float blended = mix(distance_, min(distance_, octave / scale), amplitude);
                distance_ = mix(distance_, min(distance_, blended), fraction);
            }
        }
    }
    if (normalize_) distance_ /= max_amplitude;
    return distance_;
}

void node_tex_voronoi(int dimensions, int feature, int metric, int normalize_,
                      vec3 vector, float w, float scale, float detail, float roughness,
                      float lacunarity, float smoothness, float exponent, float randomness,
                      out float distance_out, out vec3 color_out, out vec3 position_out,
                      out float w_out, out float radius_out) {
    detail = clamp(detail, 0.0, 15.0);
    roughness = clamp(roughness, 0.0, 1.0);
    randomness = clamp(randomness, 0.0, 1.0);
    smoothness = clamp(smoothness / 2.0, 0.0, 0.5);
    vector *= scale;
    w *= scale;
    vec4 coord = dimensions == 1 ? vec4(w, 0.0, 0.0, 0.0)
               : dimensions == 2 ? vec4(vector.xy, 0.0, 0.0)
               : dimensions == 3 ? vec4(vector, 0.0)
                                 : vec4(vector, w);
    distance_out = 0.0; color_out = vec3(0.0); position_out = vec3(0.0);
    w_out = 0.0; radius_out = 0.0;
    if (feature == VORONOI_DISTANCE_TO_EDGE) {
        distance_out = voronoi_fractal_distance_to_edge(dimensions, randomness, detail, roughness,
                                                        lacunarity, 0.5 + 0.5 * randomness,
                                                        normalize_ != 0, coord);
    } else if (feature == VORONOI_N_SPHERE_RADIUS) {
        radius_out = voronoi_n_sphere_radius(dimensions, randomness, coord);
    } else {
        // The largest distance a point can have to its nearest feature point (the corner of
        // the jitter box), which Normalize divides by; F2 reaches twice as far.
        float reach = 0.5 + 0.5 * randomness;
        float max_distance = voronoi_metric(voronoi_mask(vec4(reach), dimensions), dimensions,
                                            metric, exponent)
                           * (feature == VORONOI_F2 ? 2.0 : 1.0);
        VoronoiOctave result = voronoi_fractal(dimensions, feature, metric, exponent, randomness,
                                               smoothness, detail, roughness, lacunarity,
                                               max_distance, normalize_ != 0, coord);
        vec4 position = scale != 0.0 ? result.position / scale : vec4(0.0);
        distance_out = result.distance;
        color_out = result.color;
        position_out = dimensions == 1 ? vec3(0.0) : position.xyz;
        w_out = dimensions == 1 ? position.x : dimensions == 4 ? position.w : 0.0;
    }
}

#endif
