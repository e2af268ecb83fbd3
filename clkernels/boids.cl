// boids.cl: Unity Graphics Programming vol.1 ch.3, "Boids simulation on the GPU"
// (docs/chapters/03-boids.md).
// Kernels, in host call order per step:
//   1. ForceCS        boid_data -> boid_force: separation/alignment/cohesion against all n boids, streamed through
//                     __local tiles of SIMULATION_BLOCK_SIZE boids (two barriers per tile, as the book)
//      ForceCS_naive  the same sums read straight from global memory (reference and benchmark baseline)
//      ForceCS_cpu    the same sums for CPU_LANES boids per work-item in the lanes of float16 vectors, no __local
//                     memory and no barriers (variant=lanes; what variant=auto runs on CPU devices, PoCL)
//      ForceCS_grid   the same sums over the boids in the 27 grid cells around each boid (the chapter's summary:
//                     "a grid would make the neighbour search faster"); the grid comes from grid.cl, built by
//                     ugpcl.grid.UniformGrid on the positions with cell size = the largest radius, and the boids
//                     are read from its cell-ordered copy (GridCopyItemsInCellOrder), one work-item per slot
//   2. IntegrateCS    boid_data, boid_force -> boid_data: wall avoidance, explicit Euler, |velocity| <= max_speed
//   then, for the view only (a large flock drawn a point each):
//   3. PackBoidsHalf  boid_data -> position and velocity as half4 pairs, 16 bytes a boid, and the flock's
//                     bounding box (what a picture frames), reduced in the work-group, then 6 atomics per group
// Build defines: SIMULATION_BLOCK_SIZE = work-group size = tile length (book: 256).
// Differences from the book: n need not be a multiple of the block size (padding work-items run every barrier
// and write nothing); a rule whose average direction is the zero vector steers by 0 instead of normalize(0) = NaN;
// a pair is tested and weighted by its squared distance (no sqrt, one reciprocal, no branch per rule): the same
// sums up to float rounding.
#include "boid.h"  // Boid {float4 velocity, position}: 32 B; numpy mirror BOID_DTYPE
#include "grid.h"  // grid_neighbours: the one neighbour-cell loop of the sorted-key uniform grid
#include "ordered.h"  // ordered_int: PackBoidsHalf's bounding box by integer atomics

#ifndef SIMULATION_BLOCK_SIZE
#error "build with -D SIMULATION_BLOCK_SIZE=<work-group size>"
#endif

// Book: limit(vec, max) - shorten vec to length max_length when it is longer.
inline float3 limit(float3 vec, float max_length) {
    float len = sqrt(dot(vec, vec));
    return (len > max_length && len > 0.0f) ? vec * (max_length / len) : vec;
}

// Book: avoidWall(position) - per axis +1 below the box, -1 above it, 0 inside.
inline float3 avoid_wall(float3 position, float3 wall_center, float3 wall_size) {
    float3 lower = wall_center - wall_size * 0.5f;
    float3 upper = wall_center + wall_size * 0.5f;
    return (float3)(position.x < lower.x ? 1.0f : (position.x > upper.x ? -1.0f : 0.0f),
                    position.y < lower.y ? 1.0f : (position.y > upper.y ? -1.0f : 0.0f),
                    position.z < lower.z ? 1.0f : (position.z > upper.z ? -1.0f : 0.0f));
}

// The three rules' running sums for one boid (the book's sepPosSum/sepCount, aliVelSum/aliCount, cohPosSum/cohCount).
typedef struct {
    float3 sep_pos_sum;
    float3 ali_vel_sum;
    float3 coh_pos_sum;
    float sep_count, ali_count, coh_count;  // whole numbers, exact in float up to 2^24 > the largest max_object_num
} Neighbourhood;

typedef struct {
    float separate_radius2, alignment_radius2, cohesion_radius2;  // squares of the book's radii
    float max_speed, max_steer_force;
    float separate_weight, alignment_weight, cohesion_weight;
    float max_radius2;  // square of the largest radius (not a book variable: the early exit below)
} Rules;

// Book's inner loop body: boid at p_position meets a neighbour; dist > 0 skips itself and coincident boids.
// Branch-free per rule: dist <= radius is tested as dist^2 <= radius^2, and the book's normalize(diff) / dist is
// diff / dist^2, so a pair costs one reciprocal instead of a sqrt, a normalize and three divisions. Each rule adds
// its term times a weight that is 0 outside its radius (one select, then a multiply-add per component, and a float
// count, instead of a select and an add per component and an integer count). native_recip
// is 1/x on PoCL and Oclgrind and within 1 ulp on NVIDIA (rcp.approx), far inside the tests' rtol 1e-4.
inline void meet(Neighbourhood* nb, const Rules* r, float3 p_position, float3 n_position, float3 n_velocity) {
    const float3 diff = p_position - n_position;
    const float dist2 = diff.x * diff.x + diff.y * diff.y + diff.z * diff.z;  // as ForceCS_cpu's lanes, not dot()
    if (dist2 > r->max_radius2) return;  // outside every radius: the common case once the flock spreads out
    const bool near = dist2 > 0.0f;
    const float sep = near && dist2 <= r->separate_radius2 ? 1.0f : 0.0f;  // separation: away, weighted 1/dist
    const float ali = near && dist2 <= r->alignment_radius2 ? 1.0f : 0.0f;  // alignment: the neighbours' velocity
    const float coh = near && dist2 <= r->cohesion_radius2 ? 1.0f : 0.0f;   // cohesion: the neighbours' centroid
    nb->sep_pos_sum += diff * (sep > 0.0f ? native_recip(dist2) : 0.0f);   // never 0 * (1/0)
    nb->ali_vel_sum += n_velocity * ali;
    nb->coh_pos_sum += n_position * coh;
    nb->sep_count += sep;
    nb->ali_count += ali;
    nb->coh_count += coh;
}

// desired direction at full speed minus the current velocity, limited to max_steer_force.
inline float3 steer(float3 desired, float3 p_velocity, const Rules* r) {
    float len = sqrt(dot(desired, desired));
    if (len == 0.0f) return (float3)(0.0f);  // no direction to steer to (book: normalize(0) = NaN)
    return limit(desired * (r->max_speed / len) - p_velocity, r->max_steer_force);
}

inline float4 steering_force(const Neighbourhood* nb, const Rules* r, float3 p_position, float3 p_velocity) {
    float3 force = (float3)(0.0f);
    if (nb->ali_count > 0) force += steer(nb->ali_vel_sum / (float)nb->ali_count, p_velocity, r) * r->alignment_weight;
    if (nb->coh_count > 0) force += steer(nb->coh_pos_sum / (float)nb->coh_count - p_position, p_velocity, r) * r->cohesion_weight;
    if (nb->sep_count > 0) force += steer(nb->sep_pos_sum / (float)nb->sep_count, p_velocity, r) * r->separate_weight;
    return (float4)(force, 0.0f);
}

#define RULES_ARGS                                                                                        \
    float separate_radius, float alignment_radius, float cohesion_radius, float max_speed, float max_steer_force, \
        float separate_weight, float alignment_weight, float cohesion_weight
#define RULES_INIT                                                                                        \
    {separate_radius * separate_radius, alignment_radius * alignment_radius, cohesion_radius * cohesion_radius, \
     max_speed, max_steer_force, separate_weight, alignment_weight, cohesion_weight,                        \
     fmax(separate_radius * separate_radius, fmax(alignment_radius * alignment_radius, cohesion_radius * cohesion_radius))}

// 1/x for ForceCS's pairs. NVIDIA compiles native_recip to div.approx.f32, which keeps subnormal inputs: seven
// instructions around the one MUFU.RCP that rcp.approx.ftz.f32 is. meet_in_tile never passes a subnormal (its near
// test), so on NVIDIA, whose compiler alone defines cl_nv_pragma_unroll, that PTX instruction is used (H200,
// N = 65536: ForceCS 3.7 ms instead of 5.0); every other device gets native_recip.
#ifdef cl_nv_pragma_unroll
inline float pair_recip(float x) {
    float r;
    asm("rcp.approx.ftz.f32 %0, %1;" : "=f"(r) : "f"(x));
    return r;
}
#else
inline float pair_recip(float x) { return native_recip(x); }
#endif

// ForceCS's pair once diff and dist2 are known: meet()'s sums, each under an if that NVIDIA compiles to predicated
// adds (no 0/1 weight to multiply by, no select of the reciprocal). Only cohesion counts its neighbours: separation
// and alignment steer towards their mean's direction, which is their sum's, so ForceCS starts their counts at 1.
// wide_rules: alignment and cohesion share the widest radius (the book's 2, 2 and 1), so one test serves both; it is
// a constant at each call of meet_tile, which is compiled once for each value.
// Book: dist > 0. Here dist2 >= FLT_MIN, which also leaves out pairs closer than 1e-19 (a subnormal dist2).
inline void meet_in_tile(Neighbourhood* nb, const Rules* r, float3 diff, float dist2, float3 n_position,
                         float3 n_velocity, const bool wide_rules) {
    const bool near = dist2 >= FLT_MIN;  // not itself, nor a coincident boid
    const bool sep = near && dist2 <= r->separate_radius2;
    const bool ali = near && dist2 <= r->alignment_radius2;
    const bool coh = wide_rules ? ali : near && dist2 <= r->cohesion_radius2;
    const float inv = pair_recip(dist2);  // before the ifs: NVIDIA's asm would stay inside one, as a branch
    if (sep) nb->sep_pos_sum += diff * inv;  // book: normalize(diff) / dist
    if (ali) nb->ali_vel_sum += n_velocity;
    if (coh) {
        nb->coh_pos_sum += n_position;
        nb->coh_count += 1.0f;
    }
}

// One tile's neighbours in index order, TILE_CHUNK at a time: a chunk's positions are read from __local memory and
// its squared distances computed together (the loads in flight at once), and a work-item whose whole chunk lies
// outside every radius skips its pairs (most chunks once the flock has spread out; a warp skips when all its
// work-items do). 8 keeps ForceCS under 128 registers on NVIDIA: two work-groups of 256 per multiprocessor.
#define TILE_CHUNK 8
inline void meet_tile(Neighbourhood* nb, const Rules* r, float3 p_position, const __local Boid* tile, int tile_len,
                      const bool wide_rules) {
    int t = 0;
    for (; t + TILE_CHUNK <= tile_len; t += TILE_CHUNK) {
        float3 diff[TILE_CHUNK];
        float dist2[TILE_CHUNK];
        bool outside = true;  // every pair of the chunk outside every radius
#pragma unroll
        for (int k = 0; k < TILE_CHUNK; k++) {
            diff[k] = p_position - tile[t + k].position.xyz;
            dist2[k] = diff[k].x * diff[k].x + diff[k].y * diff[k].y + diff[k].z * diff[k].z;
            outside = outside & (dist2[k] > r->max_radius2);  // & (not &&): one compare each, no branch
        }
        if (outside) continue;
#pragma unroll
        for (int k = 0; k < TILE_CHUNK; k++)
            meet_in_tile(nb, r, diff[k], dist2[k], tile[t + k].position.xyz, tile[t + k].velocity.xyz, wide_rules);
    }
    for (; t < tile_len; t++) {  // the end of a last tile that is no whole number of chunks
        const float3 diff = p_position - tile[t].position.xyz;
        const float dist2 = diff.x * diff.x + diff.y * diff.y + diff.z * diff.z;
        meet_in_tile(nb, r, diff, dist2, tile[t].position.xyz, tile[t].velocity.xyz, wide_rules);
    }
}

__kernel __attribute__((reqd_work_group_size(SIMULATION_BLOCK_SIZE, 1, 1)))
void ForceCS(const __global Boid* boid_data, __global float4* boid_force, int n, RULES_ARGS) {
    __local Boid tile[SIMULATION_BLOCK_SIZE];  // book: groupshared BoidData boid_data[SIMULATION_BLOCK_SIZE]
    const Rules rules = RULES_INIT;
    const bool wide_rules = rules.alignment_radius2 == rules.cohesion_radius2 && rules.cohesion_radius2 == rules.max_radius2;
    const int p_id = get_global_id(0);
    const int lid = get_local_id(0);
    const Boid me = boid_data[min(p_id, n - 1)];  // padding work-items (p_id >= n) borrow a real boid, write nothing
    Neighbourhood nb = {(float3)(0.0f), (float3)(0.0f), (float3)(0.0f), 1, 1, 0};  // counts: see meet_in_tile

    Boid next = boid_data[min(lid, n - 1)];  // this work-item's record of the first tile (past n: a duplicate never read)
    for (int base = 0; base < n; base += SIMULATION_BLOCK_SIZE) {
        tile[lid] = next;
        barrier(CLK_LOCAL_MEM_FENCE);  // tile complete before anyone reads it
        // the next tile's record, on its way from global memory while this tile's pairs are met
        if (base + SIMULATION_BLOCK_SIZE < n) next = boid_data[min(base + SIMULATION_BLOCK_SIZE + lid, n - 1)];
        const int tile_len = min(SIMULATION_BLOCK_SIZE, n - base);
        if (wide_rules) meet_tile(&nb, &rules, me.position.xyz, tile, tile_len, true);
        else meet_tile(&nb, &rules, me.position.xyz, tile, tile_len, false);
        barrier(CLK_LOCAL_MEM_FENCE);  // everyone done reading before the next iteration overwrites the tile
    }
    if (p_id < n) boid_force[p_id] = steering_force(&nb, &rules, me.position.xyz, me.velocity.xyz);
}

__kernel void ForceCS_naive(const __global Boid* boid_data, __global float4* boid_force, int n, RULES_ARGS) {
    const int p_id = get_global_id(0);
    if (p_id >= n) return;
    const Rules rules = RULES_INIT;
    const Boid me = boid_data[p_id];
    Neighbourhood nb = {(float3)(0.0f), (float3)(0.0f), (float3)(0.0f), 0, 0, 0};
    for (int j = 0; j < n; j++) meet(&nb, &rules, me.position.xyz, boid_data[j].position.xyz, boid_data[j].velocity.xyz);
    boid_force[p_id] = steering_force(&nb, &rules, me.position.xyz, me.velocity.xyz);
}

// CPU_LANES boids per work-item, one per lane of a float16 (an AVX-512 register, two AVX2 ones); every other boid
// is read once per work-item and broadcast to the lanes. Without barriers PoCL runs no work-group loop per tile, and
// the explicit vectors do not depend on its auto-vectoriser. Lane by lane this is meet() above on the neighbours
// in index order: equal to ForceCS_naive up to contraction. Lanes past n copy boid n-1 and write nothing.
#define CPU_LANES 16
typedef struct {
    float16 sep_x, sep_y, sep_z, ali_x, ali_y, ali_z, coh_x, coh_y, coh_z;
    int16 sep_count, ali_count, coh_count;  // negated: a true vector comparison is -1 (count_lane flips the sign)
} NeighbourhoodLanes;

inline float lane(float16 v, int l) {
    float all[CPU_LANES];
    vstore16(v, 0, all);
    return all[l];
}

inline int count_lane(int16 v, int l) {
    int all[CPU_LANES];
    vstore16(v, 0, all);
    return -all[l];
}

__kernel void ForceCS_cpu(const __global Boid* boid_data, __global float4* boid_force, int n, RULES_ARGS) {
    const int first = get_global_id(0) * CPU_LANES;
    if (first >= n) return;
    const Rules rules = RULES_INIT;
    float own[6][CPU_LANES];  // position xyz, velocity xyz of this work-item's boids
    for (int l = 0; l < CPU_LANES; l++) {
        const Boid b = boid_data[min(first + l, n - 1)];
        own[0][l] = b.position.x, own[1][l] = b.position.y, own[2][l] = b.position.z;
        own[3][l] = b.velocity.x, own[4][l] = b.velocity.y, own[5][l] = b.velocity.z;
    }
    const float16 px = vload16(0, own[0]), py = vload16(0, own[1]), pz = vload16(0, own[2]);
    const float16 zero = 0.0f;
    NeighbourhoodLanes nb = {zero, zero, zero, zero, zero, zero, zero, zero, zero, (int16)(0), (int16)(0), (int16)(0)};
    for (int j = 0; j < n; j++) {
        const float4 n_position = boid_data[j].position;
        const float16 dx = px - n_position.x, dy = py - n_position.y, dz = pz - n_position.z;
        const float16 dist2 = dx * dx + dy * dy + dz * dz;
        if (!any(dist2 <= rules.max_radius2)) continue;  // every lane outside every radius
        const float4 n_velocity = boid_data[j].velocity;
        const int16 near = dist2 > 0.0f;
        const int16 sep = near & (dist2 <= rules.separate_radius2);
        const int16 ali = near & (dist2 <= rules.alignment_radius2);
        const int16 coh = near & (dist2 <= rules.cohesion_radius2);
        const float16 inv = native_recip(dist2);
        nb.sep_x += select(zero, dx * inv, sep), nb.sep_y += select(zero, dy * inv, sep);
        nb.sep_z += select(zero, dz * inv, sep);
        nb.ali_x += select(zero, (float16)n_velocity.x, ali), nb.ali_y += select(zero, (float16)n_velocity.y, ali);
        nb.ali_z += select(zero, (float16)n_velocity.z, ali);
        nb.coh_x += select(zero, (float16)n_position.x, coh), nb.coh_y += select(zero, (float16)n_position.y, coh);
        nb.coh_z += select(zero, (float16)n_position.z, coh);
        nb.sep_count += sep, nb.ali_count += ali, nb.coh_count += coh;
    }
    for (int l = 0; l < CPU_LANES && first + l < n; l++) {
        const Neighbourhood one = {(float3)(lane(nb.sep_x, l), lane(nb.sep_y, l), lane(nb.sep_z, l)),
                                   (float3)(lane(nb.ali_x, l), lane(nb.ali_y, l), lane(nb.ali_z, l)),
                                   (float3)(lane(nb.coh_x, l), lane(nb.coh_y, l), lane(nb.coh_z, l)),
                                   count_lane(nb.sep_count, l), count_lane(nb.ali_count, l),
                                   count_lane(nb.coh_count, l)};
        const float3 p_position = (float3)(own[0][l], own[1][l], own[2][l]);
        const float3 p_velocity = (float3)(own[3][l], own[4][l], own[5][l]);
        boid_force[first + l] = steering_force(&one, &rules, p_position, p_velocity);
    }
}

// Cell size >= every radius, so the 3x3x3 cells around a boid hold every neighbour that counts. Neighbours are
// visited cell by cell (not in index order as above): sums agree with ForceCS up to float rounding.
// sorted_boids = boid_data in the grid's cell order: work-item k takes the boid in slot k (boid grid_item(keys[k]),
// whose force it writes), so the work-items of a cell read the same neighbours from consecutive addresses.
__kernel void ForceCS_grid(const __global Boid* sorted_boids, __global float4* boid_force, int n, RULES_ARGS,
                           float4 origin, float cell_size, int4 dims, const __global ulong* keys,
                           const __global int* cell_start, const __global int* cell_end) {
    const int p_slot = get_global_id(0);
    if (p_slot >= n) return;
    const Rules rules = RULES_INIT;
    const Boid me = sorted_boids[p_slot];
    Neighbourhood nb = {(float3)(0.0f), (float3)(0.0f), (float3)(0.0f), 0, 0, 0};
    const int4 home = grid_cell_coord(me.position.xyz, origin.xyz, cell_size, dims);
    GRID_FOR_EACH_NEIGHBOUR_KEY(k, home, dims, cell_start, cell_end) {
        const Boid other = sorted_boids[k];
        meet(&nb, &rules, me.position.xyz, other.position.xyz, other.velocity.xyz);
    }
    boid_force[grid_item(keys[p_slot])] = steering_force(&nb, &rules, me.position.xyz, me.velocity.xyz);
}

__kernel void IntegrateCS(__global Boid* boid_data, const __global float4* boid_force, int n, float dt,
                          float max_speed, float4 wall_center, float4 wall_size, float avoid_wall_weight) {
    const int p_id = get_global_id(0);
    if (p_id >= n) return;
    Boid b = boid_data[p_id];
    float3 force = boid_force[p_id].xyz + avoid_wall(b.position.xyz, wall_center.xyz, wall_size.xyz) * avoid_wall_weight;
    float3 velocity = limit(b.velocity.xyz + force * dt, max_speed);  // apply steering, then the speed limit
    b.velocity = (float4)(velocity, 0.0f);
    b.position = (float4)(b.position.xyz + velocity * dt, 0.0f);
    boid_data[p_id] = b;
}

// The view's copy of a large flock (viewer/views/boids.py, above POINT_BOIDS boids, drawn a point each): position
// then velocity as half4, 16 bytes a boid instead of 32, since GL takes host data at about 4 GB/s on the lent H200.
// Half floats keep 11 bits: 0.06 units at 100 units from the centre, a fraction of a pixel at that flock's scale.
// bounds = (min x, y, z, max x, y, z) of the positions as ordered ints (the host fills it with INT_MAX x 3, INT_MIN
// x 3 first): numpy took tens of ms to scan a million half floats for a picture's framing.
#define PACK_GROUP 256

__kernel __attribute__((reqd_work_group_size(PACK_GROUP, 1, 1))) void PackBoidsHalf(
    const __global Boid* boid_data, int n, __global half* packed, volatile __global int* bounds) {
    __local float4 lo[PACK_GROUP], hi[PACK_GROUP];
    const int i = get_global_id(0), l = get_local_id(0);
    lo[l] = (float4)(INFINITY);
    hi[l] = (float4)(-INFINITY);
    if (i < n) {
        const float4 p = boid_data[i].position;
        vstore_half4(p, 2 * i, packed);
        vstore_half4(boid_data[i].velocity, 2 * i + 1, packed);
        lo[l] = hi[l] = (float4)(p.xyz, 0.0f);
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    for (int half_size = PACK_GROUP / 2; half_size > 0; half_size /= 2) {
        if (l < half_size) {
            lo[l] = fmin(lo[l], lo[l + half_size]);
            hi[l] = fmax(hi[l], hi[l + half_size]);
        }
        barrier(CLK_LOCAL_MEM_FENCE);
    }
    if (l == 0 && get_group_id(0) * PACK_GROUP < n) {
        atomic_min(&bounds[0], ordered_int(lo[0].x));
        atomic_min(&bounds[1], ordered_int(lo[0].y));
        atomic_min(&bounds[2], ordered_int(lo[0].z));
        atomic_max(&bounds[3], ordered_int(hi[0].x));
        atomic_max(&bounds[4], ordered_int(hi[0].y));
        atomic_max(&bounds[5], ordered_int(hi[0].z));
    }
}
