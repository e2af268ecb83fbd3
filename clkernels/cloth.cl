// cloth.cl: Unity Graphics Programming vol.4 ch.3, "GPU-Based Cloth Simulation" (docs/chapters/14-cloth.md).
// A W x H mass-spring grid: each particle is tied to 12 neighbours (4 structural, 4 shear, 4 "bend" springs that
// are 2-step diagonals), integrated with position Verlet; the top row is pinned; a sphere pushes particles out.
// Kernels (the book's Kernels.compute), in host call order:
//   1. CSInit        -> pos0, prev0, normal: the flat grid in the x-y plane, prev = pos, normal (0, 0, -1)
//                    (on reset; the host then copies pos0 -> pos1 and prev0 -> prev1, the book's Blits)
//   2. CSSimulation  pos_ro, prev_ro -> pos_rw, prev_rw, normal: one Verlet substep with spring forces, sphere
//                    collision and the ring normal; run VerletIterationNum times per frame, the host swapping the
//                    ro/rw pairs after each launch (ping-pong: never reads what it writes)
// Buffers are float4 per particle, row-major, index y * W + x (y = H - 1 is the pinned top row), w = 1.
// Build defines: NUM_THREADS_XY = work-group edge (book: 32; the host picks 16 where the device allows it)
//                FIX_NAN = 1 guards the book's two normalize(0) cases (variant=fixed), 0 keeps them (variant=book,
//                with HLSL's normalize, which gives NaN there).
// Differences from the book: sizes need not be multiples of NUM_THREADS_XY (padding work-items return at once);
// the pinned row copies its ro values to the rw buffers instead of writing nothing (same result, and the rw
// buffers hold no stale data whatever the host did); the FIX_NAN guards.

#ifndef NUM_THREADS_XY
#error "build with -D NUM_THREADS_XY=<work-group edge>"
#endif
#ifndef FIX_NAN
#error "build with -D FIX_NAN=0 (book) or 1 (fixed)"
#endif

#define NEIGHBOURS 12  // book: m_Directions[12]
#define RING 8         // the first 8 neighbours surround the particle: they estimate the normal
#define MIN_SPRING_LENGTH 1e-12f  // FIX_NAN: a shorter spring (coincident particles) has no direction

// HLSL's normalize: v * rsqrt(dot(v, v)), NaN for v = 0 (the book's behaviour; OpenCL's normalize returns 0 there).
inline float3 hlsl_normalize(float3 v) { return v * rsqrt(dot(v, v)); }

// Book: m_Directions. k = 0..7 run counter-clockwise round the particle from (-1, -1) (the normal needs this order),
// k = 8..11 are the 2-step diagonal bend springs.
__constant int2 DIRECTIONS[NEIGHBOURS] = {
    (int2)(-1, -1), (int2)(0, -1), (int2)(1, -1), (int2)(1, 0),   (int2)(1, 1),  (int2)(0, 1),
    (int2)(-1, 1),  (int2)(-1, 0), (int2)(-2, -2), (int2)(2, -2), (int2)(2, 2), (int2)(-2, 2)};

// Book: CSInit. total_len = rest * res (book: _TotalClothLength): x runs from -W*rest/2 to (W-1)*rest - W*rest/2, so
// the grid is one rest length short of centred on the + side, as in the book.
__kernel __attribute__((reqd_work_group_size(NUM_THREADS_XY, NUM_THREADS_XY, 1)))
void CSInit(__global float4* pos, __global float4* prev, __global float4* normal, int2 res, float2 total_len,
            float rest) {
    const int2 idx = (int2)(get_global_id(0), get_global_id(1));
    if (idx.x >= res.x || idx.y >= res.y) return;  // padding of the last groups
    const int i = idx.y * res.x + idx.x;
    float3 p = (float3)(idx.x * rest, idx.y * rest, 0.0f);
    p.xy -= total_len * 0.5f;
    pos[i] = (float4)(p, 1.0f);
    prev[i] = (float4)(p, 1.0f);
    normal[i] = (float4)(0.0f, 0.0f, -1.0f, 1.0f);
}

// Book: CSSimulation. gravity.xyz is added to the force (then scaled by inv_mass, as the book does); sphere.xyz is the
// collider's centre and sphere.w its radius; dt is one substep (TimeStep / VerletIterationNum).
__kernel __attribute__((reqd_work_group_size(NUM_THREADS_XY, NUM_THREADS_XY, 1)))
void CSSimulation(const __global float4* pos_ro, const __global float4* prev_ro, __global float4* pos_rw,
                  __global float4* prev_rw, __global float4* normal_rw, int2 res, float rest, float4 gravity,
                  float stiffness, float damp, float inv_mass, float dt, int collide, float4 sphere) {
    const int2 idx = (int2)(get_global_id(0), get_global_id(1));
    if (idx.x >= res.x || idx.y >= res.y) return;  // padding of the last groups
    const int i = idx.y * res.x + idx.x;
    const float3 pos = pos_ro[i].xyz;
    const float3 pos_prev = prev_ro[i].xyz;

    if (idx.y == res.y - 1) {  // top row: pinned (the book returns here and writes nothing)
        pos_rw[i] = pos_ro[i];
        prev_rw[i] = prev_ro[i];
        return;  // normal_rw keeps its value, as in the book
    }

    const float3 vel = (pos - pos_prev) / dt;  // Verlet velocity, only used for damping
    float3 force = gravity.xyz;
    float3 n = (float3)(0.0f);         // book: normal
    float3 last_diff = (float3)(0.0f);  // book: lastDiff, direction to the previous ring neighbour
    float iters = 0.0f;                 // ring neighbours seen so far

    for (int k = 0; k < NEIGHBOURS; k++) {
        const int2 neigh = idx + DIRECTIONS[k];
        if (neigh.x < 0 || neigh.x > res.x - 1 || neigh.y < 0 || neigh.y > res.y - 1) continue;  // off the cloth
        const float3 pos_diff = pos_ro[neigh.y * res.x + neigh.x].xyz - pos;
        const float len = length(pos_diff);
#if FIX_NAN
        const float3 curr_diff = len > MIN_SPRING_LENGTH ? pos_diff / len : (float3)(0.0f);
#else
        const float3 curr_diff = hlsl_normalize(pos_diff);  // book: NaN for coincident particles
#endif
        // normal: sum the cross products of consecutive ring directions less than 90 degrees apart
        if (iters > 0.0f && k < RING && dot(curr_diff, last_diff) > 0.0f) n += cross(last_diff, curr_diff);
        last_diff = curr_diff;
        const float rest_length = length(convert_float2(DIRECTIONS[k]) * rest);  // rest, rest*sqrt2 or 2*sqrt2*rest
        force += curr_diff * (len - rest_length) * stiffness - vel * damp;  // spring + damping, once per neighbour
        if (k < RING) iters += 1.0f;
    }
    n = n / -(iters - 1.0f);  // iters >= 3 (a corner has 3 ring neighbours): only flips the sign towards the camera
#if FIX_NAN
    n = dot(n, n) > 0.0f ? normalize(n) : normal_rw[i].xyz;  // every ring pair >= 90 degrees apart: keep the last
#else
    n = hlsl_normalize(n);  // book: NaN when n = 0
#endif

    const float3 acc = force * inv_mass;
    const float3 pos_next = pos * 2.0f - pos_prev + acc * (dt * dt);  // position Verlet

    float3 p = pos_next;
    if (collide) {
        const float3 center = sphere.xyz;
        const float radius = sphere.w;
        if (length(p - center) < radius) p = center + normalize(p - center) * radius;  // out to the surface
    }
    pos_rw[i] = (float4)(p, 1.0f);
    prev_rw[i] = (float4)(pos, 1.0f);
    normal_rw[i] = (float4)(n, 1.0f);
}
