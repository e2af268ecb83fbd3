// poisson_disk.cl: Unity Graphics Programming vol.4 ch.7, "Poisson Disk Sampling" (docs/chapters/18-poisson-disk.md).
// Host: ugpcl/scenes/poisson_disk.py (Simulation, method=gpu). The book samples on the CPU with Bridson's algorithm,
// which it notes has no parallel form; this is multi-phase parallel dart throwing (L.-Y. Wei, "Parallel Poisson disk
// sampling", SIGGRAPH 2008) on the book's background grid of cells r/sqrt(n), one sample per cell at most.
// Kernels, in host call order (reset: nothing but zeroed buffers; each step = one round of darts):
//   1. ThrowDarts      cell_used, cell_pts -> the same: one dart into every empty cell of one phase; a dart no
//                      stored sample of the +-2 cells is within r of is written into its cell
//                      (the host launches it for each of the 3^n phases, then the next round, k rounds in all)
//   2. CompactSamples  cell_used, cell_pts -> samples, sample_cells (Append): every filled cell, in any order
//                      (the host sorts by cell)
// Build defines: DIM = 2 or 3 (the dimension).
// Phases: cell (i, j[, l]) belongs to phase (i mod 3, j mod 3[, l mod 3]). Cells of one phase are 3 apart on some
// axis, so their darts are more than 2 cells = 2r/sqrt(n) > r apart (n <= 3), and a dart's +-2 cell scan (enough:
// a sample within r is at most sqrt(n) <= 2 cells away per axis) only reads cells of other phases, which earlier
// launches wrote. Launch order is the only synchronisation: no barrier, no atomics but the compaction's.
// Random numbers: Philox-4x32-10 of counter (cell id, round, 0, 0) under key_of_seed(seed) (random.h): the same
// darts on every device and every run.
// Atomics: CompactSamples' pool_append (old count = the slot; capacity = the cell count, so it never refuses).
// Races: none (see Phases).
// Differences from the book: not in the book. Positions are float32 relative to the domain's min corner; a dart is
// rejected within r2_reject = (r (1 + 2^-20))^2, so rounding never lets two samples come closer than r in float64.
#include "pool.h"    // pool_append: the compaction's counter
#include "random.h"  // philox_uniform4: the darts

#ifndef DIM
#error "build with -D DIM=2 or -D DIM=3"
#endif

#define WINDOW 2  // the +-2 cell scan: ceil(sqrt(DIM)) for DIM <= 3 (docs/chapters/18-poisson-disk.md)

// Cell id of grid coordinates (x fastest), the host's np.ravel_multi_index(order="F").
inline int cell_id(int4 c, int4 dims) { return c.x + dims.x * (c.y + dims.y * c.z); }

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

    const int4 lo = max(c - WINDOW, (int4)(0)), hi = min(c + WINDOW, dims - 1);
    for (int z = DIM == 3 ? lo.z : 0; z <= (DIM == 3 ? hi.z : 0); z++)
        for (int y = lo.y; y <= hi.y; y++)
            for (int x = lo.x; x <= hi.x; x++) {
                const int nb = cell_id((int4)(x, y, z, 0), dims);
                if (!cell_used[nb]) continue;
                const float4 d = cell_pts[nb] - p;
                const float d2 = d.x * d.x + d.y * d.y + (DIM == 3 ? d.z * d.z : 0.0f);
                if (d2 <= r2_reject) return;  // as GetNextPoint: a sample within r rejects the dart
            }
    cell_pts[id] = (float4)(p.x, p.y, DIM == 3 ? p.z : 0.0f, 0.0f);
    cell_used[id] = 1;
}

__kernel void CompactSamples(const __global int* cell_used, const __global float4* cell_pts, int cell_count,
                             __global float4* samples, __global int* sample_cells, volatile __global int* counter) {
    const int id = get_global_id(0);
    if (id >= cell_count || !cell_used[id]) return;
    const int slot = pool_append(counter, cell_count);  // old count = this sample's slot (never refused)
    if (slot < 0) return;
    samples[slot] = cell_pts[id];
    sample_cells[slot] = id;
}
