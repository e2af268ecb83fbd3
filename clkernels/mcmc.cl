// mcmc.cl: Unity Graphics Programming vol.1 ch.8, "3D Spatial Sampling with MCMC" (docs/chapters/08-mcmc.md),
// the sample's Metropolis3d.cs, Rejection3d.cs and the chapter's Monte Carlo pi listing (section 8.4.1).
// Host: ugpcl/scenes/mcmc.py (Simulation); its numpy twin (noise_numpy, density_numpy, sequence_numpy) redraws
// every random number below from the same Philox counters.
// Kernels, in host call order (reset: Prepare, then the mode's kernel; the view's slice and the tests: *At):
//   1. Prepare            noise table T -> lattice W[z][y][x] = noise(x, y, z) (book: Metropolis3d.Prepare)
//   2. DensityGrid        W -> Dgrid: the exact density on a grid of spacing 1/oversample (density=grid only)
//   3. Sequence           W | Dgrid | Gaussian -> samples (C, S, 3), accepted, reset_tries, init_density, palette:
//                         one chain per work-item: Reset, burn-in Next steps, then S times (emit, Next)
//   4. RejectionSequence  candidates first_id + gid -> points, cand_id (Append), counter: uniform points whose
//                         clamped noise exceeds the threshold (book: Rejection3d.Sequence)
//   5. MonteCarloPi       m points per work-item -> hits: x^2 + y^2 <= 1, summed per work-group in __local memory
//                         (tree reduction), one atomic_add per group (book: section 8.4.1)
//   NoiseAt, DensityAt    points -> noise / density at each (the view's density slice, the tests)
// Build defines: PI_GROUP_SIZE (power of two: the work-group size of MonteCarloPi's tree reduction).
// Random numbers: Philox-4x32-10 (random.h), key = the seed, counter = (item, index, batch, PURPOSE_*), so every
// number is fixed by what it is for and the numpy twin draws the same ones.
// Atomics: RejectionSequence's atomic_inc on the append counter (an overflowing append still counts, so the host
// learns the true total); MonteCarloPi's one atomic_add per group. Order of appended points: nondeterministic
// (the host sorts by cand_id).
// Races: none; every other kernel writes only its own item's records.
// Differences from the book (docs/chapters/08-mcmc.md): the density is the exact exp(-d^2)-weighted sum of the
// lattice weights truncated at d^2 <= 25 (density=exact; the book's 500 random picks are density=legacy); chains
// are independent (the book's Reset never clears _currDensity, so its chains continue one another); uniforms for
// Box-Muller and the acceptance test are in (0, 1) (Unity's Random.value is [0, 1]: ln 0); the acceptance rule
// keeps the code's `>=` (the text says `>`).
#include "random.h"  // philox4x32_10, uniform01

// No fused a*b+c: GPU compilers contract by default, which moves the noise off its numpy twin by a few 1e-6.
#pragma OPENCL FP_CONTRACT OFF

#define PURPOSE_STEP_XY 0u  // the Box-Muller uniforms of x and y of step `index`
#define PURPOSE_STEP_Z 1u   // those of z, then the acceptance uniform
#define PURPOSE_RESET 2u    // the uniform start point of reset try `index`
#define PURPOSE_PALETTE 3u  // the chain's cube colour
#define PURPOSE_REJECTION 4u
#define PURPOSE_PI 5u
#define PURPOSE_LEGACY 6u  // + block: the lattice picks of density=legacy, four per block

#define DENSITY_EXACT 0
#define DENSITY_LEGACY 1
#define DENSITY_GRID 2
#define DENSITY_GAUSSIAN 3

#define TRUNCATION_RADIUS 5.0f  // lattice points with d^2 > 25 are left out: exp(-25) = 1.4e-11
#define SAFE_COORDINATE 1.0e6f  // positions are clamped to this before float -> int (a lost chain stays defined)

// {{{ Perlin's reference simplex noise (SimplexNoiseGenerator.cs; K. Perlin, "Noise hardware", 2001)

// fastfloor as the C# code: n > 0 ? (int)n : (int)n - 1 (so fastfloor(0) = -1; noise is continuous there)
inline int fastfloor(float n) { return n > 0.0f ? (int)n : (int)n - 1; }

inline int shuffle_bit(int n, int b) { return (int)(((uint)n >> b) & 1u); }  // uint: no signed right shift

inline int shuffle(int i, int j, int k, __constant int* T) {
    int h = 0;
    for (int b = 0; b < 8; b++) {  // (i, j, k) cycles to (j, k, i), (k, i, j) with b mod 3
        const int r = b % 3;
        const int p = r == 0 ? i : (r == 1 ? j : k), q = r == 0 ? j : (r == 1 ? k : i), s = r == 0 ? k : (r == 1 ? i : j);
        h += T[shuffle_bit(p, b) << 2 | shuffle_bit(q, b) << 1 | shuffle_bit(s, b)];
    }
    return h;
}

// One corner's contribution; A is the corner offset so far, incremented on axis a afterwards (Perlin's K(a)).
inline float simplex_corner(int a, int* A, float u, float v, float w, int i, int j, int k, __constant int* T) {
    const float s = (float)(A[0] + A[1] + A[2]) * 0.166666667f;
    const float x = u - (float)A[0] + s, y = v - (float)A[1] + s, z = w - (float)A[2] + s;
    float t = 0.6f - x * x - y * y - z * z;
    const int h = shuffle(i + A[0], j + A[1], k + A[2], T);
    A[a]++;
    if (t < 0.0f) return 0.0f;
    const int b5 = (h >> 5) & 1, b4 = (h >> 4) & 1, b3 = (h >> 3) & 1, b2 = (h >> 2) & 1, b = h & 3;
    float p = b == 1 ? x : (b == 2 ? y : z), q = b == 1 ? y : (b == 2 ? z : x), r = b == 1 ? z : (b == 2 ? x : y);
    p = b5 == b3 ? -p : p;
    q = b5 == b4 ? -q : q;
    r = b5 != (b4 ^ b3) ? -r : r;
    t *= t;
    return 8.0f * t * t * (p + (b == 0 ? q + r : (b2 == 0 ? q : r)));
}

inline float simplex_noise(float x, float y, float z, __constant int* T) {
    float s = (x + y + z) * 0.333333333f;
    const int i = fastfloor(x + s), j = fastfloor(y + s), k = fastfloor(z + s);
    s = (float)(i + j + k) * 0.166666667f;
    const float u = x - (float)i + s, v = y - (float)j + s, w = z - (float)k + s;
    int A[3] = {0, 0, 0};
    const int hi = u >= w ? (u >= v ? 0 : 1) : (v >= w ? 1 : 2);
    const int lo = u < w ? (u < v ? 0 : 1) : (v < w ? 1 : 2);
    float n = simplex_corner(hi, A, u, v, w, i, j, k, T);  // left to right: each corner moves A
    n += simplex_corner(3 - hi - lo, A, u, v, w, i, j, k, T);
    n += simplex_corner(lo, A, u, v, w, i, j, k, T);
    return n + simplex_corner(0, A, u, v, w, i, j, k, T);
}

// }}}

// {{{ random numbers: Philox by purpose

inline uint4 draw(uint item, uint index, uint batch, uint purpose, uint2 key) {
    return philox4x32_10((uint4)(item, index, batch, purpose), key);
}

// (0, 1), never 0 or 1: 23 bits plus a half step, exact in float32 (Box-Muller takes a log)
inline float uniform_open01(uint x) { return ((float)(x >> 9) + 0.5f) * 0x1.0p-23f; }

// RandomGenerator.rand_gaussian: sqrt(-2 ln u1) sin(2 pi u2), one normal per pair of uniforms as the book
inline float box_muller(uint a, uint b) {
    return sqrt(-2.0f * log(uniform_open01(a))) * sin(2.0f * M_PI_F * uniform_open01(b));
}

// }}}

// {{{ the target density

inline float3 safe(float3 x) { return clamp(x, -SAFE_COORDINATE, SAFE_COORDINATE); }

// sum over lattice points p with |x - p|^2 <= 25 of exp(-|x - p|^2) W[p], as nested row sums (exp separates per
// axis): 33 exps and at most 11^3 multiply-adds instead of the book's O(L^3)
inline float density_exact(const __global float* W, int L, float3 x) {
    x = safe(x);
    const float R = TRUNCATION_RADIUS, R2 = R * R;
    const int x0 = max(0, (int)ceil(x.x - R)), x1 = min(L - 1, (int)floor(x.x + R));
    const int y0 = max(0, (int)ceil(x.y - R)), y1 = min(L - 1, (int)floor(x.y + R));
    const int z0 = max(0, (int)ceil(x.z - R)), z1 = min(L - 1, (int)floor(x.z + R));
    float ex[11], dy2[11], ey[11];
    for (int i = x0; i <= x1; i++) {
        const float d = x.x - (float)i;
        ex[i - x0] = exp(-d * d);
    }
    for (int j = y0; j <= y1; j++) {
        const float d = x.y - (float)j;
        dy2[j - y0] = d * d;
        ey[j - y0] = exp(-d * d);
    }
    float sum = 0.0f;
    for (int k = z0; k <= z1; k++) {
        const float dz = x.z - (float)k, dz2 = dz * dz;
        float plane = 0.0f;
        for (int j = y0; j <= y1; j++) {
            const float dyz2 = dy2[j - y0] + dz2;
            if (dyz2 > R2) continue;
            const __global float* row = W + ((size_t)k * L + j) * L;
            const float half_chord = sqrt(R2 - dyz2);  // the row's points inside the ball
            const int i0 = max(x0, (int)ceil(x.x - half_chord)), i1 = min(x1, (int)floor(x.x + half_chord));
            float line = 0.0f;
            for (int i = i0; i <= i1; i++) line += ex[i - x0] * row[i];
            plane += ey[j - y0] * line;
        }
        sum += exp(-dz2) * plane;
    }
    return sum;
}

// The book's Density: K lattice points picked uniformly (index floor(U (L^3 - 1)): never the last one), a noisy
// estimate of K / (L^3 - 1) times the exact sum.
inline float density_legacy(const __global float* W, int L, float3 x, int picks, uint chain, uint index, uint batch,
                            uint2 key) {
    const int count = L * L * L;
    float sum = 0.0f;
    for (int m = 0; m < picks; m += 4) {
        const uint4 bits = draw(chain, index, batch, PURPOSE_LEGACY + (uint)(m / 4), key);
        const uint b[4] = {bits.x, bits.y, bits.z, bits.w};
        for (int n = 0; n < 4 && m + n < picks; n++) {
            const int id = (int)floor(uniform01(b[n]) * (float)(count - 1));
            const float3 p = (float3)((float)(id % L), (float)((id / L) % L), (float)(id / (L * L)));
            const float3 d = x - p;
            sum += exp(-dot(d, d)) * W[id];
        }
    }
    return sum;
}

// Trilinear lookup in Dgrid (M^3 points from `origin` with spacing 1/oversample); 0 outside it.
inline float density_grid(const __global float* G, int M, float origin, float oversample, float3 x) {
    const float3 g = (safe(x) - origin) * oversample;
    const float3 f = floor(g);
    const int i = (int)f.x, j = (int)f.y, k = (int)f.z;
    if (i < 0 || j < 0 || k < 0 || i >= M - 1 || j >= M - 1 || k >= M - 1) return 0.0f;
    const float3 t = g - f;
    const __global float* c = G + ((size_t)k * M + j) * M + i;
    const size_t dy = M, dz = (size_t)M * M;
    const float c00 = mix(c[0], c[1], t.x), c10 = mix(c[dy], c[dy + 1], t.x);
    const float c01 = mix(c[dz], c[dz + 1], t.x), c11 = mix(c[dz + dy], c[dz + dy + 1], t.x);
    return mix(mix(c00, c10, t.y), mix(c01, c11, t.y), t.z);
}

// The test target: an isotropic Gaussian exp(-|x - mean|^2 / (2 sigma^2)), unnormalised
inline float density_gaussian(float3 x, float4 target) {
    const float3 d = x - target.xyz;
    return exp(-dot(d, d) / (2.0f * target.w * target.w));
}

// Every mode's arguments, passed through unchanged (W or Dgrid is the `field`)
#define DENSITY_ARGS \
    int mode, const __global float *field, int L, int M, float grid_origin, float oversample, int picks, float4 target

inline float density(DENSITY_ARGS, float3 x, uint chain, uint index, uint batch, uint2 key) {
    switch (mode) {
        case DENSITY_LEGACY: return density_legacy(field, L, x, picks, chain, index, batch, key);
        case DENSITY_GRID: return density_grid(field, M, grid_origin, oversample, x);
        case DENSITY_GAUSSIAN: return density_gaussian(x, target);
        default: return density_exact(field, L, x);
    }
}

// }}}

__kernel void Prepare(__global float* W, int L, __constant int* T) {
    const int x = get_global_id(0), y = get_global_id(1), z = get_global_id(2);
    if (x >= L || y >= L || z >= L) return;
    W[((size_t)z * L + y) * L + x] = simplex_noise((float)x, (float)y, (float)z, T);
}

__kernel void DensityGrid(const __global float* W, int L, __global float* G, int M, float origin, float spacing) {
    const int i = get_global_id(0), j = get_global_id(1), k = get_global_id(2);
    if (i >= M || j >= M || k >= M) return;
    const float3 x = origin + spacing * (float3)((float)i, (float)j, (float)k);
    G[((size_t)k * M + j) * M + i] = density_exact(W, L, x);
}

// Metropolis3d.Sequence for chain c = get_global_id(0): Reset, n_init burn-in Next steps, then S times (emit, Next).
// Next (book): x' = x + Lc z; accept iff (D(x) <= 0 || min(1, D(x') / D(x)) >= U) && D(x') > threshold.
__kernel void Sequence(DENSITY_ARGS, uint2 key, uint batch, int chains, int n_init, int S, float threshold,
                       int reset_limit, float start_edge, float8 cholesky, __global float* samples,
                       __global uint* accepted, __global uint* reset_tries, __global float* init_density,
                       __global uchar* palette) {
    const int c = get_global_id(0);
    if (c >= chains) return;
    const uint chain = (uint)c;
    palette[c] = (uchar)mul_hi(draw(chain, 0u, batch, PURPOSE_PALETTE, key).x, 9u);  // one of 9 colours

    // Reset: uniform points in [0, L)^3 until one has positive density (at most reset_limit draws)
    float3 cur = (float3)(0.0f);
    float cur_density = 0.0f;
    int tries = 0;
    for (; cur_density <= 0.0f && tries < reset_limit; tries++) {
        const float4 u = philox_uniform4((uint4)(chain, (uint)tries, batch, PURPOSE_RESET), key);
        cur = start_edge * u.xyz;
        cur_density = density(mode, field, L, M, grid_origin, oversample, picks, target, cur, chain,
                              0x80000000u + (uint)tries, batch, key);  // legacy picks of resets: their own indices
    }
    reset_tries[c] = (uint)tries;
    init_density[c] = cur_density;

    uint accepts = 0;
    const int steps = n_init + S;
    for (int s = 0; s < steps; s++) {
        if (s >= n_init) vstore3(cur, (size_t)c * S + (s - n_init), samples);
        const uint4 xy = draw(chain, (uint)s, batch, PURPOSE_STEP_XY, key);
        const uint4 zu = draw(chain, (uint)s, batch, PURPOSE_STEP_Z, key);
        const float3 z = (float3)(box_muller(xy.x, xy.y), box_muller(xy.z, xy.w), box_muller(zu.x, zu.y));
        // proposal cur + Lc z, Lc lower triangular: (l00, l10, l11, l20, l21, l22) in s0..s5
        const float3 step = (float3)(cholesky.s0 * z.x, cholesky.s1 * z.x + cholesky.s2 * z.y,
                                     cholesky.s3 * z.x + cholesky.s4 * z.y + cholesky.s5 * z.z);
        const float3 next = cur + step;
        const float next_density =
            density(mode, field, L, M, grid_origin, oversample, picks, target, next, chain, (uint)s, batch, key);
        const bool metropolis = cur_density <= 0.0f || fmin(1.0f, next_density / cur_density) >= uniform_open01(zu.z);
        if (metropolis && next_density > threshold) {
            cur = next;
            cur_density = next_density;
            accepts++;
        }
    }
    accepted[c] = accepts;
}

// Rejection3d.Sequence: candidate g = first_id + gid is a uniform u in [0, 1)^3; kept when
// clamp(noise(u * noise_scale), 0, 1) > threshold, stored as u * l_edge with its id.
__kernel void RejectionSequence(uint2 key, uint first_id, int n, float noise_scale, float threshold, float l_edge,
                                __constant int* T, __global float* points, __global uint* cand_id,
                                volatile __global uint* counter, uint cap) {
    const int gid = get_global_id(0);
    if (gid >= n) return;
    const uint g = first_id + (uint)gid;
    const float3 u = philox_uniform4((uint4)(g, 0u, 0u, PURPOSE_REJECTION), key).xyz;
    const float3 q = u * noise_scale;
    const float v = clamp(simplex_noise(q.x, q.y, q.z, T), 0.0f, 1.0f);
    if (!(v > threshold)) return;
    const uint slot = atomic_inc(counter);  // counts past cap too: the host reads the true total
    if (slot >= cap) return;
    vstore3(u * l_edge, slot, points);
    cand_id[slot] = g;
}

// Section 8.4.1: work-item g tests points 2 g m' .. (two points per Philox draw), m' = m / 2 draws, the last item
// stopping at n; the group sums its hits in __local memory (tree reduction, one barrier per level).
__kernel void MonteCarloPi(uint2 key, uint batch, int m, ulong n, volatile __global uint* hits) {
    __local uint partial[PI_GROUP_SIZE];
    const size_t g = get_global_id(0);
    const int l = get_local_id(0);
    uint count = 0;
    for (int d = 0; d < m / 2; d++) {
        const ulong first = (ulong)g * (ulong)m + 2ul * (ulong)d;
        const float4 u = philox_uniform4((uint4)((uint)g, (uint)d, batch, PURPOSE_PI), key);
        if (first < n && u.x * u.x + u.y * u.y <= 1.0f) count++;
        if (first + 1 < n && u.z * u.z + u.w * u.w <= 1.0f) count++;
    }
    partial[l] = count;
    barrier(CLK_LOCAL_MEM_FENCE);
    for (int stride = PI_GROUP_SIZE / 2; stride > 0; stride /= 2) {
        if (l < stride) partial[l] += partial[l + stride];
        barrier(CLK_LOCAL_MEM_FENCE);
    }
    if (l == 0) atomic_add(hits, partial[0]);
}

__kernel void NoiseAt(const __global float* points, int n, __constant int* T, __global float* noise) {
    const int i = get_global_id(0);
    if (i >= n) return;
    const float3 p = vload3(i, points);
    noise[i] = simplex_noise(p.x, p.y, p.z, T);
}

// the density of `mode` at each point (legacy: the picks of chain i, index 0 of `batch`)
__kernel void DensityAt(DENSITY_ARGS, uint2 key, uint batch, const __global float* points, int n,
                        __global float* out) {
    const int i = get_global_id(0);
    if (i >= n) return;
    out[i] = density(mode, field, L, M, grid_origin, oversample, picks, target, vload3(i, points), (uint)i, 0u, batch,
                     key);
}
