// poisson_disk.cl: Unity Graphics Programming vol.4 ch.7, "Poisson Disk Sampling" (docs/chapters/18-poisson-disk.md).
// Host: ugpcl/scenes/poisson_disk.py (Simulation, method=gpu). The book samples on the CPU with Bridson's algorithm,
// which it notes has no parallel form; this is multi-phase parallel dart throwing (L.-Y. Wei, "Parallel Poisson disk
// sampling", SIGGRAPH 2008) on the book's background grid of cells r/sqrt(n), one sample per cell at most.
// Kernels, in host call order (reset: nothing but zeroed buffers; each step = one round of darts):
//   1. ThrowDarts      cell_used, cell_pts -> the same: one dart into every empty cell of one phase; a dart no
//                      stored sample of the +-2 cells is within r of is written into its cell
//                      (the host launches it for each of the 3^n phases, then the next round, k rounds in all)
//   fill=true, then fill rounds t = 0, 1, ... until MarkUncovered keeps no box (see Fill):
//   2. MarkUncovered   cell_used, cell_pts, boxes_in -> boxes_out (Append), choice: the boxes of round t that
//                      no single sample covers whole, and per cell the one its dart goes to (atomic_min)
//   3. FillDarts       boxes_out, choice, cell_used, cell_pts -> cell_used, cell_pts: per phase, the chosen box
//                      of each cell, if no sample covers its centre, throws FILL_TRIES darts (a finest box then
//                      its centre); the first that no sample is within r of is kept
//   4. CompactSamples  cell_used, cell_pts -> samples, sample_cells (Append): every filled cell, in any order
//                      (the host sorts by cell; w = 1 marks the fill's samples)
// Build defines: DIM = 2 or 3 (the dimension).
// Phases: cell (i, j[, l]) belongs to phase (i mod 3, j mod 3[, l mod 3]). Cells of one phase are 3 apart on some
// axis, so their darts are more than 2 cells = 2r/sqrt(n) > r apart (n <= 3), and a dart's +-2 cell scan (enough:
// a sample within r is at most sqrt(n) <= 2 cells away per axis) only reads cells of other phases, which earlier
// launches wrote. Launch order is the only synchronisation: no barrier, no atomic in ThrowDarts.
// Random numbers: Philox-4x32-10 under key_of_seed(seed) (random.h), counters (cell id, round, 0, 0) for ThrowDarts,
// (cell id, t, 0, FILL_TAG) for a cell's box choice and (cell id, sub-cell, t, FILL_TAG + 1 + try) for FillDarts:
// the same darts on every device and every run (the fill's choice is a least key, not the first to come).
// Fill (Ebeida et al. 2011, "Efficient maximal Poisson-disk sampling", on the same grid and phases): the empty
// cells are split into boxes, level L boxes being the 2^L x 2^L[ x 2^L] sub-cells of a cell (sub-cell coordinates
// packed SUB_BITS a axis). Round 0 takes every empty cell whole (level 0); round t > 0 splits each box of round
// t - 1 whose cell is still empty into its 2^n children (the same box once level MAX_LEVEL is reached). A box is
// dropped when one sample has all of it (its farthest corner) within r (1 + 2^-20), the radius a dart is
// rejected in, so a dropped box could never take a dart; at MAX_LEVEL also when a sample covers its centre. Each
// cell's darts go to one of its kept boxes, the least of a random permutation of their indices among those whose
// centre no sample covers (a dart there is likely kept); a cell whose kept boxes all have covered centres throws
// none and waits for their children (a box the union of several discs covers whole would take none anyway).
// When a round keeps no box, every point of the domain is within r (1 + 2^-20) of a sample, but in the finest
// boxes: within r (1 + 2^-20) plus half their diagonal, r 2^-16 (2-D) or r 2^-11 (3-D). That is the maximality
// promised (in float32 geometry: a gap narrower than a float32 step can hold no sample); the host caps the rounds
// and says so when the cap is hit.
// Atomics: pool_append (MarkUncovered's boxes: a full pool refuses, and the host runs the round again into a larger
// one; CompactSamples' samples: capacity = the cell count, so it never refuses); MarkUncovered's atomic_min on
// choice[cell].
// Races: none (see Phases: FillDarts reads only its own cell's choice, written by MarkUncovered, and the +-2 cells
// of other phases).
// Differences from the book: not in the book. Positions are float32 relative to the domain's min corner; a dart is
// rejected within r2_reject = (r (1 + 2^-20))^2, so rounding never lets two samples come closer than r in float64.
#include "pool.h"    // pool_append: the fill's boxes and the compaction's samples
#include "random.h"  // philox_uniform4: the darts

#ifndef DIM
#error "build with -D DIM=2 or -D DIM=3"
#endif

#define WINDOW 2  // the +-2 cell scan: ceil(sqrt(DIM)) for DIM <= 3 (docs/chapters/18-poisson-disk.md)
#define SUB_BITS (30 / DIM)  // bits of a sub-cell coordinate: the packed index stays a non-negative int
#define MAX_LEVEL SUB_BITS   // the finest boxes: 2^-15 (2-D) or 2^-10 (3-D) of a cell
#define FILL_TRIES 4         // darts a chosen box throws in one round (the first kept ends it)
#define FILL_TAG 0x100u      // Philox counter word 3 of the fill's numbers (ThrowDarts' is 0)

// Cell id of grid coordinates (x fastest), the host's np.ravel_multi_index(order="F").
inline int cell_id(int4 c, int4 dims) { return c.x + dims.x * (c.y + dims.y * c.z); }

inline int4 cell_coords(int id, int4 dims) {
    return (int4)(id % dims.x, (id / dims.x) % dims.y, id / (dims.x * dims.y), 0);
}

// A stored sample of the +-2 cells around cell c within sqrt(r2_reject) of p (as GetNextPoint: <= rejects)?
inline bool near_sample(const __global int* cell_used, const __global float4* cell_pts, int4 c, int4 dims, float4 p,
                        float r2_reject) {
    const int4 lo = max(c - WINDOW, (int4)(0)), hi = min(c + WINDOW, dims - 1);
    for (int z = DIM == 3 ? lo.z : 0; z <= (DIM == 3 ? hi.z : 0); z++)
        for (int y = lo.y; y <= hi.y; y++)
            for (int x = lo.x; x <= hi.x; x++) {
                const int nb = cell_id((int4)(x, y, z, 0), dims);
                if (!cell_used[nb]) continue;
                const float4 d = cell_pts[nb] - p;
                const float d2 = d.x * d.x + d.y * d.y + (DIM == 3 ? d.z * d.z : 0.0f);
                if (d2 <= r2_reject) return true;
            }
    return false;
}

__kernel void ThrowDarts(__global int* cell_used, __global float4* cell_pts, int4 dims, int4 phase,
                         int4 phase_dims, int phase_cells, uint round, uint2 key, float cell, float4 extent,
                         float r2_reject) {
    const int i = get_global_id(0);
    if (i >= phase_cells) return;
    // The i-th cell of the phase: phase + 3 * (its coordinates in the phase's own grid phase_dims)
    const int4 q = (int4)(i % phase_dims.x, (i / phase_dims.x) % phase_dims.y, i / (phase_dims.x * phase_dims.y), 0);
    const int4 c = phase + 3 * q;
    const int id = cell_id(c, dims);
    if (cell_used[id]) return;  // one sample per cell: its diagonal is r

    const float4 u = philox_uniform4((uint4)(id, round, 0u, 0u), key);
    const float4 p = (convert_float4(c) + u) * cell;  // uniform in the cell (rounding may put it on the upper face)
#if DIM == 3
    if (p.z >= extent.z) return;
#endif
    if (p.x >= extent.x || p.y >= extent.y) return;  // the domain is [0, extent)

    if (near_sample(cell_used, cell_pts, c, dims, p, r2_reject)) return;  // as GetNextPoint: r rejects the dart
    cell_pts[id] = (float4)(p.x, p.y, DIM == 3 ? p.z : 0.0f, 0.0f);
    cell_used[id] = 1;
}

// {{{ the fill

// Packed sub-cell coordinates (x in the low SUB_BITS, then y[, z]) and back.
inline int pack_sub(int4 s) { return s.x | s.y << SUB_BITS | (DIM == 3 ? s.z << (2 * SUB_BITS) : 0); }

inline int4 unpack_sub(int sub) {
    const int m = (1 << SUB_BITS) - 1;
    return (int4)(sub & m, (sub >> SUB_BITS) & m, DIM == 3 ? sub >> (2 * SUB_BITS) : 0, 0);
}

// Edge s (0 .. 2^level) of the level's boxes along one axis of cell c: both boxes beside an edge compute it alike,
// the last edge is the next cell's first, and none passes it (rounding), so the boxes tile the cells in float32.
inline float box_edge(int c, int s, int level, float cell) {
    const float top = (float)(c + 1) * cell;
    return s == (1 << level) ? top : fmin((float)c * cell + (float)s * ldexp(cell, -level), top);
}

// [lo, hi) of box s along one axis of cell c, clipped to the domain [0, extent): the top box of the last cell
// reaches extent even where dims * cell rounds below it.
inline float2 box_axis(int c, int s, int dims, int level, float cell, float extent) {
    const bool top = c == dims - 1 && s + 1 == (1 << level);
    return (float2)(box_edge(c, s, level, cell), top ? extent : fmin(box_edge(c, s + 1, level, cell), extent));
}

// The box of sub-cell s of cell c at `level`: its min corner in lo, its max corner in hi.
inline void box_bounds(int4 c, int4 s, int level, int4 dims, float cell, float4 extent, float4* lo, float4* hi) {
    const float2 x = box_axis(c.x, s.x, dims.x, level, cell, extent.x);
    const float2 y = box_axis(c.y, s.y, dims.y, level, cell, extent.y);
    const float2 z = DIM == 3 ? box_axis(c.z, s.z, dims.z, level, cell, extent.z) : (float2)(0.0f);
    *lo = (float4)(x.s0, y.s0, z.s0, 0.0f);
    *hi = (float4)(x.s1, y.s1, z.s1, 0.0f);
}

// The random mask of a cell's box choice in fill round t.
inline uint choice_mask(int id, uint fill_round, uint2 key) {
    return philox4x32_10((uint4)(id, fill_round, 0u, FILL_TAG), key).x;
}

// A box's rank in its cell's choice: a random permutation of the packed sub-cells (XOR with the cell's mask, then
// odd multiplies and an xor-shift, each one-to-one mod 2^30), so no two boxes of a cell tie and the least is any.
inline int box_rank(int sub, uint mask) {
    const uint m = (1u << 30) - 1u;
    uint x = ((uint)sub ^ mask) & m;
    x = (x * 0x2545F491u) & m;
    x ^= x >> 15;
    return (int)((x * 0x4F6CDD1Du) & m);
}

// Round t of the fill: level 0 (t = 0) takes cell i whole for i < n_in = the cell count; later rounds take box
// boxes_in[i] of round t - 1 and test its 2^n children (split) or itself again (past MAX_LEVEL). Each box of an
// empty cell that no sample of the +-2 cells has wholly within r2_reject is appended to boxes_out, and enters the
// cell's atomic_min in choice (reset to INT_MAX by the host) with its key: box_rank, plus 2^30 when a sample covers
// its centre, so a box whose centre is surely uncovered wins, and a choice of 2^30 or more tells FillDarts to wait.
__kernel void MarkUncovered(const __global int* cell_used, const __global float4* cell_pts, int4 dims,
                            const __global int2* boxes_in, int n_in, int level, int split, __global int2* boxes_out,
                            volatile __global int* counter, int capacity, volatile __global int* choice,
                            uint fill_round, uint2 key, float cell, float4 extent, float r2_reject) {
    const int i = get_global_id(0);
    if (i >= n_in) return;
    const int2 parent = level == 0 ? (int2)(i, 0) : boxes_in[i];
    const int id = parent.x;
    if (cell_used[id]) return;  // a sample's cell is covered whole: its diagonal is r
    const int4 c = cell_coords(id, dims);
    const bool children = level > 0 && split;  // else the box itself (j = 0 only)
    const int4 ps = unpack_sub(parent.y);
    float4 lo[1 << DIM], hi[1 << DIM];
    int sub[1 << DIM];
    uint open = 0;     // bit j: box j lies in the domain and no sample seen so far covers it whole
    uint centred = 0;  // bit j: a sample covers box j's centre
    for (int j = 0; j < (1 << DIM); j++) {
        // child j of (sx, sy[, sz]): (2 sx + bit 0 of j, 2 sy + bit 1[, 2 sz + bit 2])
        const int4 s = children ? 2 * ps + (int4)(j & 1, (j >> 1) & 1, DIM == 3 ? (j >> 2) & 1 : 0, 0) : ps;
        sub[j] = pack_sub(s);
        box_bounds(c, s, level, dims, cell, extent, &lo[j], &hi[j]);
        const bool outside = lo[j].x >= extent.x || lo[j].y >= extent.y || (DIM == 3 && lo[j].z >= extent.z);
        if ((children || j == 0) && !outside) open |= 1u << j;
    }
    const int4 wlo = max(c - WINDOW, (int4)(0)), whi = min(c + WINDOW, dims - 1);
    for (int z = DIM == 3 ? wlo.z : 0; z <= (DIM == 3 ? whi.z : 0) && open; z++)
        for (int y = wlo.y; y <= whi.y && open; y++)
            for (int x = wlo.x; x <= whi.x && open; x++) {
                const int nb = cell_id((int4)(x, y, z, 0), dims);
                if (!cell_used[nb]) continue;
                const float4 q = cell_pts[nb];
                for (int j = 0; j < (1 << DIM); j++) {
                    if (!(open & (1u << j))) continue;
                    const float4 far = fmax(q - lo[j], hi[j] - q);  // to the box's farthest corner, per axis
                    const float d2 = far.x * far.x + far.y * far.y + (DIM == 3 ? far.z * far.z : 0.0f);
                    if (d2 <= r2_reject) open &= ~(1u << j);
                    const float4 mid = q - 0.5f * (lo[j] + hi[j]);
                    const float m2 = mid.x * mid.x + mid.y * mid.y + (DIM == 3 ? mid.z * mid.z : 0.0f);
                    if (m2 <= r2_reject) centred |= 1u << j;
                }
            }
    if (level == MAX_LEVEL) open &= ~centred;  // the finest boxes: settled once a sample covers the centre
    if (!open) return;
    const uint mask = choice_mask(id, fill_round, key);
    for (int j = 0; j < (1 << DIM); j++) {
        if (!(open & (1u << j))) continue;
        const int slot = pool_append(counter, capacity);  // old count = this box's slot; -1: full (the host
        if (slot < 0) return;                              // runs the round again into a larger pool)
        boxes_out[slot] = (int2)(id, sub[j]);
        atomic_min(&choice[id], box_rank(sub[j], mask) | (centred & (1u << j) ? 1 << 30 : 0));
    }
}

// One launch per phase: box i of round t, if its cell is in the phase and choice names it (its centre uncovered),
// throws up to FILL_TRIES darts uniform in the box (Philox counter (cell, sub-cell, t, FILL_TAG + 1 + try)); the
// first that no sample of the +-2 cells is within r of becomes the cell's sample (w = 1: the fill's).
__kernel void FillDarts(__global int* cell_used, __global float4* cell_pts, int4 dims, int4 phase,
                        const __global int2* boxes, int n, int level, const __global int* choice, uint fill_round,
                        uint2 key, float cell, float4 extent, float r2_reject) {
    const int i = get_global_id(0);
    if (i >= n) return;
    const int2 box = boxes[i];
    const int id = box.x;
    const int4 c = cell_coords(id, dims);
    if (c.x % 3 != phase.x || c.y % 3 != phase.y || c.z % 3 != phase.z) return;
    const int rank = box_rank(box.y, choice_mask(id, fill_round, key));
    if (rank != choice[id]) return;  // one box per cell throws (none while its choice has the covered-centre bit)
    float4 lo, hi;
    box_bounds(c, unpack_sub(box.y), level, dims, cell, extent, &lo, &hi);
    for (uint t = 0; t <= FILL_TRIES; t++) {  // FILL_TRIES random darts, then (finest boxes) the centre
        if (t == FILL_TRIES && level < MAX_LEVEL) return;
        const float4 u = philox_uniform4((uint4)(id, box.y, fill_round, FILL_TAG + 1u + t), key);
        float4 p = t < FILL_TRIES ? lo + u * (hi - lo) : 0.5f * (lo + hi);  // the centre: as MarkUncovered's
        p.w = 0.0f;
        if (p.x >= extent.x || p.y >= extent.y || (DIM == 3 && p.z >= extent.z)) continue;  // rounded onto the top
        if (near_sample(cell_used, cell_pts, c, dims, p, r2_reject)) continue;
        cell_pts[id] = (float4)(p.x, p.y, DIM == 3 ? p.z : 0.0f, 1.0f);
        cell_used[id] = 1;
        return;
    }
}

// }}}

__kernel void CompactSamples(const __global int* cell_used, const __global float4* cell_pts, int cell_count,
                             __global float4* samples, __global int* sample_cells, volatile __global int* counter) {
    const int id = get_global_id(0);
    if (id >= cell_count || !cell_used[id]) return;
    const int slot = pool_append(counter, cell_count);  // old count = this sample's slot (never refused)
    if (slot < 0) return;
    samples[slot] = cell_pts[id];
    sample_cells[slot] = id;
}
