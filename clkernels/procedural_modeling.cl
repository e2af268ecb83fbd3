// procedural_modeling.cl: Unity Graphics Programming vol.1 ch.1, "Procedural Modeling Beginning with Unity"
// (docs/chapters/01-procedural-modeling.md). Host: ugpcl/scenes/procedural_modeling.py; numpy twins of every
// kernel: ugpcl/geometry/procedural.py. The book builds its meshes in C# on the CPU and has no kernels; these
// build the two meshes that grow large (ugpcl's additions, named by rule 3 of docs/conventions.md).
// Kernels, in host call order:
//   the plane scenes with builder=opencl (Plane.cs + ParametricPlaneBase.Build), global size (W, H):
//   1. GridVertices   -> positions, uvs of vertex k = y W + x: ((rx - 0.5) width, Depth(rx, ry), (0.5 - ry) height)
//   2. GridNormals    positions -> normals: the normalised sum of the cross products of the (up to 6) triangles
//                     around the vertex, read from the implicit grid (Unity's RecalculateNormals, area-weighted)
//   3. GridTriangles  -> triangles: (a, b, c), (c, d, a) of cell (x, y), global size (W - 1, H - 1)
//   the tree scenes with builder=opencl (ProceduralTree.Build), every branch of every tree in one launch:
//   4. TubeRings      ring centres, tangents, normals, binormals, radii, v -> positions, normals, tangents, uvs;
//                     one work-item per ring vertex (the ring frames come from the host: their transport is
//                     sequential along each branch)
//   5. TubeTriangles  -> triangles of tubes of equal ring counts stored one after another; one work-item per quad
// Build defines: DEPTH_FN selects GridVertices' Depth(u, v): 0 flat (Plane.cs), 1 MountainPlane.cs, 2 TerrainPlane.cs.
// Buffers of 3-vectors are plain float arrays read with vload3/vstore3 (12-byte stride, numpy's (N, 3) float32).
// Atomics: none. Races: none (each work-item writes only its own vertex, cell or quad).
// Differences from the book: Unity's Mathf.PerlinNoise is replaced by improved Perlin noise over a permutation
// drawn from the run's seed (its table is not published).

#ifndef DEPTH_FN
#define DEPTH_FN 0
#endif

#define PI2 6.28318530717958647692f

// {{{ Depth functions (MountainPlane.cs, TerrainPlane.cs)

// Gradient of a lattice corner: entry hash & 7 (the same table as procedural.PERLIN_GRADIENTS).
__constant float2 PERLIN_GRADIENTS[8] = {(float2)(1.0f, 1.0f),  (float2)(-1.0f, 1.0f), (float2)(1.0f, -1.0f),
                                         (float2)(-1.0f, -1.0f), (float2)(1.0f, 0.0f),  (float2)(-1.0f, 0.0f),
                                         (float2)(0.0f, 1.0f),  (float2)(0.0f, -1.0f)};

// The gradient of corner hash h dotted with the offset (x, y) from that corner.
inline float perlin_grad(int h, float x, float y) { return dot(PERLIN_GRADIENTS[h & 7], (float2)(x, y)); }

inline float perlin_fade(float t) { return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f); }

// Improved 2D gradient noise mapped to [0, 1] (procedural.perlin); perm holds 512 entries (256 repeated).
inline float perlin(float x, float y, __global const int* perm) {
    const float fx = floor(x), fy = floor(y);
    const int xi = ((int)fx) & 255, yi = ((int)fy) & 255;
    const float xf = x - fx, yf = y - fy;
    const float u = perlin_fade(xf), v = perlin_fade(yf);
    const int aa = perm[perm[xi] + yi], ab = perm[perm[xi] + yi + 1];
    const int ba = perm[perm[xi + 1] + yi], bb = perm[perm[xi + 1] + yi + 1];
    const float g_aa = perlin_grad(aa, xf, yf), g_ba = perlin_grad(ba, xf - 1.0f, yf);
    const float g_ab = perlin_grad(ab, xf, yf - 1.0f), g_bb = perlin_grad(bb, xf - 1.0f, yf - 1.0f);
    const float bottom = g_aa + u * (g_ba - g_aa);
    const float top = g_ab + u * (g_bb - g_ab);
    return 0.5f * (bottom + v * (top - bottom) + 1.0f);
}

// MountainPlane.Distance: (0.5 - |0.5 - t|)^power
inline float mountain_distance(float t, float power) { return pow(0.5f - fabs(0.5f - t), power); }

// }}}

// {{{ plane

// shape = (power, u_scale, v_scale, u_offset), shape2 = (v_offset, depth, width, height)
__kernel void GridVertices(__global float* positions, __global float* uvs, __global const int* perm, int W, int H,
                           float4 shape, float4 shape2) {
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= W || y >= H) return;
    const int k = y * W + x;
    const float rx = (float)x / (float)(W - 1), ry = (float)y / (float)(H - 1);
    const float depth = shape2.y;
#if DEPTH_FN == 1
    const float height = mountain_distance(rx, shape.x) * mountain_distance(ry, shape.x) * depth;
#elif DEPTH_FN == 2
    const float height = perlin(rx * shape.y + shape.w, ry * shape.z + shape2.x, perm) * depth;
#else
    const float height = 0.0f;
#endif
    vstore3((float3)((rx - 0.5f) * shape2.z, height, (0.5f - ry) * shape2.w), k, positions);
    vstore2((float2)(rx, ry), k, uvs);
}

inline float3 grid_point(__global const float* positions, int W, int x, int y) { return vload3(y * W + x, positions); }

inline float3 triangle_cross(float3 a, float3 b, float3 c) { return cross(b - a, c - a); }

__kernel void GridNormals(__global const float* positions, __global float* normals, int W, int H) {
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= W || y >= H) return;
    const float3 p = grid_point(positions, W, x, y);
    float3 sum = (float3)(0.0f);
    // the cells around the vertex, with the vertex as their a, b, c or d (Plane.cs: (a, b, c), (c, d, a))
    if (x < W - 1 && y < H - 1) {  // cell (x, y): the vertex is a
        const float3 b = grid_point(positions, W, x + 1, y), c = grid_point(positions, W, x + 1, y + 1);
        const float3 d = grid_point(positions, W, x, y + 1);
        sum += triangle_cross(p, b, c) + triangle_cross(c, d, p);
    }
    if (x > 0 && y < H - 1) {  // cell (x - 1, y): the vertex is b of (a, b, c)
        const float3 a = grid_point(positions, W, x - 1, y), c = grid_point(positions, W, x, y + 1);
        sum += triangle_cross(a, p, c);
    }
    if (x > 0 && y > 0) {  // cell (x - 1, y - 1): the vertex is c of both
        const float3 a = grid_point(positions, W, x - 1, y - 1), b = grid_point(positions, W, x, y - 1);
        const float3 d = grid_point(positions, W, x - 1, y);
        sum += triangle_cross(a, b, p) + triangle_cross(p, d, a);
    }
    if (x < W - 1 && y > 0) {  // cell (x, y - 1): the vertex is d of (c, d, a)
        const float3 a = grid_point(positions, W, x, y - 1), c = grid_point(positions, W, x + 1, y);
        sum += triangle_cross(c, p, a);
    }
    const float len = length(sum);
    vstore3(len > 0.0f ? sum / len : (float3)(0.0f), y * W + x, normals);
}

__kernel void GridTriangles(__global int* triangles, int W, int H) {
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= W - 1 || y >= H - 1) return;
    const int a = y * W + x, b = a + 1, c = a + 1 + W, d = a + W;
    const int cell = y * (W - 1) + x;
    vstore3((int3)(a, b, c), 2 * cell, triangles);
    vstore3((int3)(c, d, a), 2 * cell + 1, triangles);
}

// }}}

// {{{ tubes

// Tubular.GenerateSegment / ProceduralTree.Build's ring loop: vertex j of ring r at angle 2 pi j / R.
__kernel void TubeRings(__global const float* centers, __global const float* ring_tangents,
                        __global const float* ring_normals, __global const float* ring_binormals,
                        __global const float* radii, __global const float* ring_v, int rings, int radial,
                        __global float* positions, __global float* normals, __global float* tangents,
                        __global float* uvs) {
    const int k = get_global_id(0);
    if (k >= rings * (radial + 1)) return;
    const int ring = k / (radial + 1), j = k - ring * (radial + 1);
    const float u = (float)j / (float)radial;
    const float angle = u * PI2;
    const float3 n = normalize(cos(angle) * vload3(ring, ring_normals) + sin(angle) * vload3(ring, ring_binormals));
    vstore3(vload3(ring, centers) + radii[ring] * n, k, positions);
    vstore3(n, k, normals);
    vstore4((float4)(vload3(ring, ring_tangents), 0.0f), k, tangents);  // w = 0, as the book
    vstore2((float2)(u, ring_v[ring]), k, uvs);
}

// Tubular.cs's sides: a = (R+1)(j-1) + (i-1), b = (R+1) j + (i-1), c = (R+1) j + i, d = (R+1)(j-1) + i
// -> (a, d, b), (b, d, c), for every tube of segments + 1 rings.
__kernel void TubeTriangles(__global int* triangles, int tubes, int segments, int radial) {
    const int q = get_global_id(0);
    const int per_tube = segments * radial;
    if (q >= tubes * per_tube) return;
    const int tube = q / per_tube, rest = q - tube * per_tube;
    const int j = rest / radial + 1, i = rest - (j - 1) * radial + 1;
    const int base = tube * (segments + 1) * (radial + 1);
    const int a = base + (radial + 1) * (j - 1) + (i - 1), b = base + (radial + 1) * j + (i - 1);
    const int c = base + (radial + 1) * j + i, d = base + (radial + 1) * (j - 1) + i;
    vstore3((int3)(a, d, b), 2 * q, triangles);
    vstore3((int3)(b, d, c), 2 * q + 1, triangles);
}

// }}}
