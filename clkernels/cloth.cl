// cloth.cl: Unity Graphics Programming vol.4 ch.3, "GPU-Based Cloth Simulation" (docs/chapters/14-cloth.md).
// A W x H mass-spring grid: each particle is tied to 12 neighbours (4 structural, 4 shear, 4 "bend" springs that
// are 2-step diagonals), integrated with position Verlet; the top row is pinned; a sphere pushes particles out.
// Kernels (the book's Kernels.compute), in host call order:
//   1. CSInit        -> pos0, prev0, normal: the flat grid in the x-y plane, prev = pos, normal (0, 0, -1)
//                    (on reset; the host then copies pos0 -> pos1 and prev0 -> prev1, the book's Blits)
//   2. CSSimulation  pos_ro, prev_ro -> pos_rw, prev_rw, normal: one Verlet substep with spring forces, sphere
//                    collision and the ring normal; run VerletIterationNum times per frame, the host swapping the
//                    ro/rw pairs after each launch (ping-pong: never reads what it writes)
//      CSSimulation_cpu  the same substep for CPU_LANES particles of a row per work-item, in the lanes of float16
//                    vectors (structure of arrays inside the work-item): what the host runs on CPU devices (PoCL),
//                    whose work-group vectorizer gives up on CSSimulation's per-neighbour control flow
//   then, for the surface view only (Simulation.pack_surface; not in the book):
//   3. PackSurface   pos, normal -> surface: position and normal in 16 bytes a particle for GL
// Buffers are float4 per particle, row-major, index y * W + x (y = H - 1 is the pinned top row), w = 1.
// Build defines: NUM_THREADS_XY = work-group edge (book: 32; the host picks 16 where the device allows it)
//                FIX_NAN = 1 guards the book's two normalize(0) cases (variant=fixed), 0 keeps them (variant=book,
//                with HLSL's normalize, which gives NaN there).
// Differences from the book: sizes need not be multiples of NUM_THREADS_XY (padding work-items return at once);
// the pinned row copies its ro values to the rw buffers instead of writing nothing (same result, and the rw
// buffers hold no stale data whatever the host did); the FIX_NAN guards; the normal is written on a frame's last
// substep only (write_normal; the book writes it every substep, and only the last one's is drawn). The same sums up to float rounding, with
// less arithmetic: rest lengths from a table, one rsqrt per spring for its length and direction, the stiffness
// and the damping (book: vel * damp once per spring) applied once after the neighbour loop.

#ifndef NUM_THREADS_XY
#error "build with -D NUM_THREADS_XY=<work-group edge>"
#endif
#ifndef FIX_NAN
#error "build with -D FIX_NAN=0 (book) or 1 (fixed)"
#endif

#define NEIGHBOURS 12  // book: m_Directions[12]
#define RING 8         // the first 8 neighbours surround the particle: they estimate the normal
#define MIN_SPRING_LENGTH2 1e-24f  // FIX_NAN: a spring shorter than 1e-12 (coincident particles) has no direction
#define CPU_LANES 16   // particles per work-item of CSSimulation_cpu: the lanes of a float16 (CPU_LANES in cloth.py)
#define CPU_WINDOW (CPU_LANES + 4)  // a row's columns x0 - 2 .. x0 + CPU_LANES + 1: every dx of DIRECTIONS

// HLSL's normalize: v * rsqrt(dot(v, v)), NaN for v = 0 (the book's behaviour; OpenCL's normalize returns 0 there).
inline float3 hlsl_normalize(float3 v) { return v * rsqrt(dot(v, v)); }

// Book: m_Directions. k = 0..7 run counter-clockwise round the particle from (-1, -1) (the normal needs this order),
// k = 8..11 are the 2-step diagonal bend springs.
__constant int2 DIRECTIONS[NEIGHBOURS] = {
    (int2)(-1, -1), (int2)(0, -1), (int2)(1, -1), (int2)(1, 0),   (int2)(1, 1),  (int2)(0, 1),
    (int2)(-1, 1),  (int2)(-1, 0), (int2)(-2, -2), (int2)(2, -2), (int2)(2, 2), (int2)(-2, 2)};

// |DIRECTIONS[k]|: rest length of spring k in structural rest lengths (book: length(m_Directions[k] * rest) per
// spring, two multiplies and a sqrt).
__constant float REST_SCALE[NEIGHBOURS] = {
    M_SQRT2_F, 1.0f, M_SQRT2_F, 1.0f, M_SQRT2_F, 1.0f, M_SQRT2_F, 1.0f,
    2.0f * M_SQRT2_F, 2.0f * M_SQRT2_F, 2.0f * M_SQRT2_F, 2.0f * M_SQRT2_F};

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
// collider's centre and sphere.w its radius; dt is one substep (TimeStep / VerletIterationNum). write_normal = 0
// skips the normal's store (the host sets it on a frame's last substep only: the normal feeds no force, only the
// renderer, and its 16 bytes are a fifth of a substep's traffic).
// The book's force sums, per spring on the cloth, curr_diff * (len - rest_length) * stiffness - vel * damp; here the
// loop sums curr_diff * (len - rest_length) and counts the springs, and the force is formed once after it.
__kernel __attribute__((reqd_work_group_size(NUM_THREADS_XY, NUM_THREADS_XY, 1)))
void CSSimulation(const __global float4* pos_ro, const __global float4* prev_ro, __global float4* pos_rw,
                  __global float4* prev_rw, __global float4* normal_rw, int2 res, float rest, float4 gravity,
                  float stiffness, float damp, float inv_mass, float dt, int collide, float4 sphere,
                  int write_normal) {
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

    // two or more particles from every edge, all 12 neighbours exist: only particles near the border test them
    const bool interior = idx.x >= 2 && idx.x < res.x - 2 && idx.y >= 2 && idx.y < res.y - 2;
    float3 stretch = (float3)(0.0f);    // sum of curr_diff * (len - rest_length): the spring force / stiffness
    float springs = 0.0f;               // springs on the cloth: each one damps by vel * damp in the book
    float3 n = (float3)(0.0f);          // book: normal
    float3 last_diff = (float3)(0.0f);  // book: lastDiff, direction to the previous ring neighbour
    float iters = 0.0f;                 // ring neighbours seen so far

    for (int k = 0; k < NEIGHBOURS; k++) {
        const int2 neigh = idx + DIRECTIONS[k];
        if (!interior && (neigh.x < 0 || neigh.x > res.x - 1 || neigh.y < 0 || neigh.y > res.y - 1)) continue;
        const float3 pos_diff = pos_ro[neigh.y * res.x + neigh.x].xyz - pos;
        const float len2 = dot(pos_diff, pos_diff);
        // one rsqrt gives the spring's length and direction (book: length(), then normalize's rsqrt)
#if FIX_NAN
        const float inv_len = len2 > MIN_SPRING_LENGTH2 ? rsqrt(len2) : 0.0f;  // coincident: no direction, no force
#else
        const float inv_len = rsqrt(len2);  // book: NaN for coincident particles
#endif
        const float3 curr_diff = pos_diff * inv_len;
        const float len = len2 * inv_len;
        // normal: sum the cross products of consecutive ring directions less than 90 degrees apart
        if (write_normal && iters > 0.0f && k < RING && dot(curr_diff, last_diff) > 0.0f)
            n += cross(last_diff, curr_diff);
        last_diff = curr_diff;
        stretch += curr_diff * (len - rest * REST_SCALE[k]);  // rest_length: rest, rest*sqrt2 or 2*sqrt2*rest
        springs += 1.0f;
        if (k < RING) iters += 1.0f;
    }

    // the Verlet velocity vel = (pos - pos_prev) / dt damps by vel * damp per spring: one division, not three
    const float3 vel_damp = (pos - pos_prev) * (damp * springs / dt);
    const float3 force = gravity.xyz + stretch * stiffness - vel_damp;  // springs + damping
    const float3 acc = force * inv_mass;
    const float3 pos_next = pos * 2.0f - pos_prev + acc * (dt * dt);  // position Verlet

    float3 p = pos_next;
    if (collide) {
        const float3 center = sphere.xyz;
        const float radius = sphere.w;
        const float3 offset = p - center;
        if (dot(offset, offset) < radius * radius) p = center + normalize(offset) * radius;  // out to the surface
    }
    pos_rw[i] = (float4)(p, 1.0f);
    prev_rw[i] = (float4)(pos, 1.0f);
    if (!write_normal) return;  // (the normal's sums above were skipped too)
    // book: n / -(iters - 1); iters >= 3 (a corner has 3 ring neighbours), so only the sign survives the normalize
    n = -n;
#if FIX_NAN
    n = dot(n, n) > 0.0f ? normalize(n) : normal_rw[i].xyz;  // every ring pair >= 90 degrees apart: keep the last
#else
    n = hlsl_normalize(n);  // book: NaN when n = 0
#endif
    normal_rw[i] = (float4)(n, 1.0f);
}

// CSSimulation for CPU_LANES particles x0 .. x0 + CPU_LANES - 1 of row y per work-item (global size
// (ceil(W / CPU_LANES), H), any work-group): each float16 holds one coordinate of those particles, so every line
// of the book's step below runs on 16 particles at once. Neighbours off the cloth are masked with select, not
// skipped; the sums run over k in the same order as CSSimulation.
__kernel void CSSimulation_cpu(const __global float4* pos_ro, const __global float4* prev_ro, __global float4* pos_rw,
                               __global float4* prev_rw, __global float4* normal_rw, int2 res, float rest,
                               float4 gravity, float stiffness, float damp, float inv_mass, float dt, int collide,
                               float4 sphere, int write_normal) {
    const int x0 = get_global_id(0) * CPU_LANES, y = get_global_id(1);
    if (x0 >= res.x || y >= res.y) return;  // a launch larger than the cloth
    const int lanes = min(CPU_LANES, res.x - x0);  // the row's last work-item may hold fewer particles
    const int first = y * res.x + x0;

    if (y == res.y - 1) {  // top row: pinned (the book returns here and writes nothing)
        for (int l = 0; l < lanes; l++) {
            pos_rw[first + l] = pos_ro[first + l];
            prev_rw[first + l] = prev_ro[first + l];
        }
        return;  // normal_rw keeps its value, as in the book
    }

    // positions of rows y - 2 .. y + 2, columns x0 - 2 .. x0 + CPU_LANES + 1, one array per coordinate; indices
    // clamped onto the cloth (what a clamped index reads is masked out below)
    float wx[5][CPU_WINDOW], wy[5][CPU_WINDOW], wz[5][CPU_WINDOW];
    for (int r = 0; r < 5; r++) {
        const int line = clamp(y + r - 2, 0, res.y - 1) * res.x;
        for (int c = 0; c < CPU_WINDOW; c++) {
            const float4 p = pos_ro[line + clamp(x0 + c - 2, 0, res.x - 1)];
            wx[r][c] = p.x, wy[r][c] = p.y, wz[r][c] = p.z;
        }
    }
    float own[6][CPU_LANES];  // prev xyz, the last normal xyz (lanes past the row's end repeat its last particle)
    for (int l = 0; l < CPU_LANES; l++) {
        const int j = first + min(l, lanes - 1);
        const float4 q = prev_ro[j];
        own[0][l] = q.x, own[1][l] = q.y, own[2][l] = q.z;
#if FIX_NAN
        const float4 m = normal_rw[j];
        own[3][l] = m.x, own[4][l] = m.y, own[5][l] = m.z;
#endif
    }
    const float16 px = vload16(0, wx[2] + 2), py = vload16(0, wy[2] + 2), pz = vload16(0, wz[2] + 2);  // pos
    const float16 prev_x = vload16(0, own[0]), prev_y = vload16(0, own[1]), prev_z = vload16(0, own[2]);
    const int16 x = x0 + (int16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);  // each lane's column

    const float16 zero = 0.0f;
    float16 sx = zero, sy = zero, sz = zero;  // stretch: sum of curr_diff * (len - rest_length)
    float16 springs = zero;                    // springs on the cloth
    float16 nx = zero, ny = zero, nz = zero;   // book: normal
    float16 lx = zero, ly = zero, lz = zero;   // book: lastDiff
    int16 iters = 0;                           // ring neighbours seen so far
    for (int k = 0; k < NEIGHBOURS; k++) {
        const int2 d = DIRECTIONS[k];
        const int row_on = y + d.y >= 0 && y + d.y < res.y;
        const int16 on_cloth = (x + d.x >= 0) & (x + d.x < res.x) & (int16)(-row_on);  // -1: the neighbour exists
        const float16 dx = vload16(0, wx[d.y + 2] + d.x + 2) - px;  // pos_diff
        const float16 dy = vload16(0, wy[d.y + 2] + d.x + 2) - py;
        const float16 dz = vload16(0, wz[d.y + 2] + d.x + 2) - pz;
        const float16 len2 = dx * dx + dy * dy + dz * dz;
#if FIX_NAN
        const float16 inv_len = select(zero, rsqrt(len2), len2 > MIN_SPRING_LENGTH2);  // coincident: no force
#else
        const float16 inv_len = rsqrt(len2);  // book: NaN for coincident particles
#endif
        const float16 cx = dx * inv_len, cy = dy * inv_len, cz = dz * inv_len;  // curr_diff
        const float16 len = len2 * inv_len;
        if (k < RING) {  // normal: cross(last_diff, curr_diff) where the two are less than 90 degrees apart
            const int16 add = on_cloth & (iters > 0) & (cx * lx + cy * ly + cz * lz > 0.0f);
            nx += select(zero, ly * cz - lz * cy, add);
            ny += select(zero, lz * cx - lx * cz, add);
            nz += select(zero, lx * cy - ly * cx, add);
            iters -= on_cloth;
        }
        lx = select(lx, cx, on_cloth), ly = select(ly, cy, on_cloth), lz = select(lz, cz, on_cloth);
        const float16 s = len - rest * REST_SCALE[k];  // len - rest_length
        sx += select(zero, cx * s, on_cloth);
        sy += select(zero, cy * s, on_cloth);
        sz += select(zero, cz * s, on_cloth);
        springs -= convert_float16(on_cloth);
    }
    // book: normalize(n / -(iters - 1)): only the sign survives. Scaled by the largest |component| first, as OpenCL's
    // normalize does (it takes no float16), so the squares cannot underflow; n = 0 gives NaN (0 / 0), as the book.
    const float16 n2 = nx * nx + ny * ny + nz * nz;
    const float16 to_unit = -1.0f / fmax(fmax(fabs(nx), fabs(ny)), fabs(nz));
    nx *= to_unit, ny *= to_unit, nz *= to_unit;
    const float16 inv_n = rsqrt(nx * nx + ny * ny + nz * nz);
    nx *= inv_n, ny *= inv_n, nz *= inv_n;
#if FIX_NAN
    const int16 has_normal = n2 > 0.0f;  // every ring pair >= 90 degrees apart: keep the last
    nx = select(vload16(0, own[3]), nx, has_normal);
    ny = select(vload16(0, own[4]), ny, has_normal);
    nz = select(vload16(0, own[5]), nz, has_normal);
#endif

    // as CSSimulation: vel_damp = (pos - prev) * (damp * springs / dt), force = gravity + stretch * stiffness -
    // vel_damp, position Verlet pos * 2 - prev + force * inv_mass * dt^2
    const float16 damping = damp * springs / dt;
    float16 qx = px * 2.0f - prev_x + (gravity.x + sx * stiffness - (px - prev_x) * damping) * inv_mass * (dt * dt);
    float16 qy = py * 2.0f - prev_y + (gravity.y + sy * stiffness - (py - prev_y) * damping) * inv_mass * (dt * dt);
    float16 qz = pz * 2.0f - prev_z + (gravity.z + sz * stiffness - (pz - prev_z) * damping) * inv_mass * (dt * dt);
    if (collide) {  // inside the sphere: out to the surface (a particle at the centre stays there, as normalize(0))
        const float16 ox = qx - sphere.x, oy = qy - sphere.y, oz = qz - sphere.z;
        const float16 o2 = ox * ox + oy * oy + oz * oz;
        const int16 inside = o2 < sphere.w * sphere.w;
        const float16 to_surface = select(zero, sphere.w * rsqrt(o2), o2 > 0.0f);
        qx = select(qx, sphere.x + ox * to_surface, inside);
        qy = select(qy, sphere.y + oy * to_surface, inside);
        qz = select(qz, sphere.z + oz * to_surface, inside);
    }

    float out[6][CPU_LANES];
    vstore16(qx, 0, out[0]), vstore16(qy, 0, out[1]), vstore16(qz, 0, out[2]);
    vstore16(nx, 0, out[3]), vstore16(ny, 0, out[4]), vstore16(nz, 0, out[5]);
    for (int l = 0; l < lanes; l++) {
        pos_rw[first + l] = (float4)(out[0][l], out[1][l], out[2][l], 1.0f);
        prev_rw[first + l] = (float4)(wx[2][l + 2], wy[2][l + 2], wz[2][l + 2], 1.0f);
        if (write_normal) normal_rw[first + l] = (float4)(out[3][l], out[4][l], out[5][l], 1.0f);
    }
}

// What the views fetch (viewer/views/cloth.py), 16 bytes a particle where pos and normal hold 32, since GL takes
// host memory at about 4-5 GB/s on the lent H200: xyz = the position's float32 bits (a 1024^2 cloth 3.2 m wide has
// 3 mm spacing, which half floats would merge), w = the normal as 10-bit signed normalised components, round(n * 511)
// + 511 in 0..1022 (x in bits 0-9, y in 10-19, z in 20-29): 0 and -n exact mirrors of n (two-sided lighting flips
// it), steps of 0.11 degrees where 8 bits' 0.45 would step the specular highlight (Blinn-Phong exponent 64). The
// shaders decode both (uintBitsToFloat, shifts). A NaN component (variant=book) packs as 0.
__kernel void PackSurface(const __global float4* pos, const __global float4* normal, __global uint4* surface,
                          int n) {
    const int i = get_global_id(0);
    if (i >= n) return;
    const float3 p = pos[i].xyz;
    // vector bounds: Oclgrind's clamp(int3, int, int) clamps only the first component
    const int3 q = clamp(convert_int3_sat_rte(normal[i].xyz * 511.0f), (int3)(-511), (int3)(511)) + 511;
    surface[i] = (uint4)(as_uint(p.x), as_uint(p.y), as_uint(p.z), (uint)(q.x | (q.y << 10) | (q.z << 20)));
}
