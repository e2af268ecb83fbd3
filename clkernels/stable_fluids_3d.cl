// stable_fluids_3d.cl: Unity Graphics Programming vol.1 ch.4, "Fluid simulation by lattice method": the 3D solver
// the original ships as Solver3D.compute but never runs (docs/chapters/04-stable-fluids-3d.md).
// Jos Stam, "Stable Fluids", SIGGRAPH 1999: implicit diffusion, projection, semi-Lagrangian advection on a grid.
//
// Fields: row-major w x h x d grids, cell (x, y, z) at index (z*h + y)*w + x, y = 0 at the bottom. float4 fields:
//   velocity (u, v, w, 0); source (velocity source xyz, density source w); solver (u, v, w, density);
//   prev, multiplexed as the book does: xyz = velocity source or copy of velocity, w = density source or copy of
//   density; during the projection x = p and y = div (z, w kept: later kernels read the leftovers).
//   divergence, pressure float (fixed only): the projection's div and p, so a Jacobi sweep reads 8 bytes per cell and
//   writes 4 instead of reading and writing prev's 32; prev.xy ends as (p, div) all the same.
//   prev_z, prev_density float (fixed's step() only): with pressure and divergence, prev split into 4 float fields
//   (x, y, z, w), so that no kernel reads or writes 16 bytes of prev to touch 4 (see DiffuseFields).
// Boundary rules (the book's SetBoundary* helpers): a face cell copies its inner neighbour (the velocity's negates
//   the inner cell's normal component and keeps its own tangential ones), an edge cell is the mean of the 2 face
//   cells beside it, a corner the mean of the 3 edge cells beside it. Every wall cell's value therefore follows from
//   interior cells and face cells' tangential velocity: the cell one step inwards on each wall axis (clamp(c, 1,
//   n-2)) and, for the velocity, the face cells that share all but one of its coordinates with it. "+B(f)" below:
//   the kernel applies f's rule itself, as the book calls SetBoundary* at the end of each kernel, but without
//   reading cells other work-items write: extra work-groups past the grid's layers take one wall cell per work-item
//   and compute the kernel's value at those cells from its inputs; the grid's groups compute the interior (see
//   wall_item). Every value is the one a sweep followed by separate face, edge and corner launches gives, bit for bit.
// Kernels, in host call order per step, and in this file's order:
//   AddSourceBrush3D     -> source: spherical emitter f = clamp(1 - |(uvw - c)/r|^2, 0, 1), source = (dir*f, f);
//                        the host runs it only when the emitter's parameters or the source buffer changed
//   velocity step (skipped when density_only):
//   AddSourceVelocity    velocity += s.xyz*velocityCoef*dt, prev.xyz = s.xyz*velocityCoef*dt   (own cell, in place)
//   DiffuseVelocity      velocity_in, prev.xyz -> velocity_out: one Jacobi sweep (host: gs_iterations times)
//                        +B(Velocity)
//   ProjectStep1         velocity -> prev = (0, div, prev.z, prev.w) (own cell, in place) +B(Div); p = 0 everywhere,
//                        so B(P) would change nothing; fixed: also divergence = div, pressure = 0 (first_sweep = 1:
//                        the pressure solve's first sweep from p = 0), and with write_prev = 0 (a step's first
//                        projection: the velocity's copy after it overwrites prev.xyz) prev left alone, by step 3 too
//   ProjectStep1Rows     fixed's step()'s ProjectStep1 (write_prev = 0, first_sweep = 1) in strips of 1 x 1 x
//                        FIELD_ROWS cells along z, walls included: what the host runs (Simulation._fused_project)
//   ProjectStep2         book: prev_in -> prev_out, fixed: pressure_in, divergence -> pressure_out: one Jacobi sweep
//                        of the Poisson equation for p (gs_iterations) +B(P)
//   ProjectStep2Rows     the same sweep (fixed, w % 4 == 0) in strips of 4 x 1 x ROWS cells along z: what the host
//                        runs where the width allows (Simulation.sweep_kernel)
//   ProjectStep3         velocity -= 0.5*(p(+1) - p(-1))*(w | h | d) per axis (own cell, in place); fixed: prev.x = p
//   SetBoundaryVelocity  after ProjectStep3 (in place: its walls would read cells other work-items write)
//   SwapVelocity         prev.xyz = velocity (a one-way copy despite the name, as the book)
//   AdvectVelocity       prev.xyz -> velocity: back-trace by the cell's own prev.xyz, trilinear +B(Velocity)
//   ProjectStep1..3, SetBoundaryVelocity again
//   density step:
//   AddSourceDensity     density += s.w*densityCoef*dt, prev.w = s.w*densityCoef*dt   (own cell, in place)
//   DiffuseDensity       density_in, prev.w -> density_out: one Jacobi sweep (gs_iterations times) +B(Density)
//   SwapDensity          prev.w = density
//   AdvectDensity        velocity, prev.w -> density: back-trace by the current velocity +B(Density)
//   AdvectDensityFromExt  source.xyz, prev.w -> density: back-trace by the source (density_only) +B(Density)
//   fixed's step() (Simulation.fused_step, prev split) runs the book's step in 12 launches instead of 20
//   (gs_iterations 2, source on), the fields bit for bit the book's kernels' (not in the book; each names the book's
//   kernels it does):
//     gs x DiffuseFields (in strips: DiffuseFieldsRows) -> ProjectStep1Rows (first_sweep) -> (gs - 1) x
//     ProjectStep2Rows -> ProjectStep3 -> SetBoundaryVelocity -> SwapAdvectVelocity -> the same projection
//     -> SwapAdvectDensity
//   DiffuseFields        one sweep of DiffuseVelocity and DiffuseDensity together (velocity = 0: density_only), the
//                        first with the source on also AddSourceVelocity and AddSourceDensity; the centre terms from
//                        the source (on) or the split prev +B(Velocity) +B(Density)
//   DiffuseFieldsRows    the same sweep in strips of 1 x 1 x FIELD_ROWS cells along z: what the host runs
//                        (Simulation.diffuse_kernel), walls by work-groups past the strips' +B(Velocity) +B(Density)
//   SwapAdvectVelocity   SwapVelocity + AdvectVelocity: velocity_in -> velocity_out, prev_z = velocity_in.z
//                        +B(Velocity)
//   SwapAdvectDensity    SwapDensity + AdvectDensity / AdvectDensityFromExt: density_in -> density_out, back-traced
//                        by the carrier; the host keeps density_in as prev.w +B(Density)
//   Draw                 velocity, density -> solver = (u, v, w, density); the host runs it once the solver is read
//                        (state(), solver_field()): nothing in a step reads it
//   DrawVolume           velocity, density -> volume, maxima: the view's packed copy (not in the book; runs when
//                        the view asks, Simulation.draw_volume): the shown field as half floats, max density
//                        and max speed
//   the rules on their own (Simulation.set_boundary_*; step() applies them inside the kernels above):
//   SetBoundaryDensity   density
//   SetBoundaryDiv       the divergence: prev.y, and fixed's divergence field between ProjectStep1 and ProjectStep3
//   SetBoundaryP         p: prev.x, or fixed's pressure field between ProjectStep1 and ProjectStep3
//   The SetBoundary* kernels are one launch of one work-item per wall cell (see boundary_cell): every cell reads
//   interior cells, and SetBoundaryVelocity's face cells write only their normal component while its edges and
//   corners read only the face cells' other components (float pointers, so no byte is read while another work-item
//   writes it).
//   the view's picture (not in the book; Simulation.ray_march, after DrawVolume for the maxima):
//   RayMarchSmoke        velocity, density, maxima -> image: the smoke display of viewer/shaders/stable_fluids_3d.frag
//                        ray-marched per pixel into premultiplied RGBA8: the picture, not the volume, goes to GL
// Build defines: THREAD_X, THREAD_Y, THREAD_Z = work-group shape of the grid kernels (book: numthreads 8, 8, 4);
//   ROWS = cells along z of a ProjectStep2Rows strip, FIELD_ROWS of a DiffuseFieldsRows and ProjectStep1Rows strip
//   (fixed only);
//   BOOK_VARIANT = 1: the original's divergence -0.5*du/w + dv/h + dw/d (operator precedence) and a back-trace that
//   is never clamped (its clamp() discards the result); 0: Stam's -0.5*(du/w + dv/h + dw/d), back-trace clamped
//   to [0.5, n - 1.5], the pressure solve in the float divergence and pressure fields. Bugs of Solver3D.compute
//   fixed in both (docs/chapters/04-stable-fluids-3d.md): `id.x < d`
//   guards, AdvectDensity sampling prev.z, a velocity volume without z (RGHalf), integer-division uvw, the last
//   corner rule without z == d-1, a_v without d.
// Differences from the book: one Jacobi sweep per launch from a read buffer into a write buffer (the book's in-place
// Gauss-Seidel races), boundary values computed from the kernel's inputs (the book's in-kernel SetBoundary* calls
// read neighbours other work-items are writing), guarded global sizes rounded up to the work-group shape (the book
// drops partial groups), every read that may fall outside the grid through ld() (zero there, as D3D's out-of-range
// texture reads), float32 fields.

#ifndef THREAD_X
#error "build with -D THREAD_X=<work-group x> -D THREAD_Y=<y> -D THREAD_Z=<z> (book: 8, 8, 4)"
#endif
#if !defined(THREAD_Y) || !defined(THREAD_Z)
#error "build with -D THREAD_Y=<work-group y> -D THREAD_Z=<work-group z> (book: 8, 4)"
#endif
#ifndef BOOK_VARIANT
#error "build with -D BOOK_VARIANT=1 (the original's arithmetic) or 0 (Stam's equations)"
#endif

#define ONE_THIRD (1.0f / 3.0f)  // corner mean as a product (the book divides by 3): the same rounding as numpy's

// Helpers are always inlined: PoCL keeps a large helper that is called more than once as a call per work-item.
#define INLINE inline __attribute__((always_inline))
#include "ordered.h"  // ordered_int: DrawVolume's maxima by integer atomics

// One work-item per cell; padding items of the rounded-up global size leave at once (no barrier in its kernels).
#define CELL_OR_RETURN(w, h, d)                                                                    \
    const int x = get_global_id(0), y = get_global_id(1), z = get_global_id(2);                    \
    if (x >= (w) || y >= (h) || z >= (d)) return;                                                  \
    const int4 n = (int4)((w), (h), (d), 0);                                                       \
    const int id = cell(x, y, z, n);

// {{{ helpers

INLINE int cell(int x, int y, int z, int4 n) { return (z * n.y + y) * n.x + x; }

INLINE bool in_grid(int x, int y, int z, int4 n) { return x >= 0 && y >= 0 && z >= 0 && x < n.x && y < n.y && z < n.z; }

// The book reads neighbours with texture[] and relies on D3D returning 0 outside the texture; here explicitly.
// `inside` (a literal at every call) says that (x, y, z) is known to lie in the grid (a neighbour of an interior
// cell): then the test is folded away and the read is a plain load.
INLINE float ld(const __global float* f, int x, int y, int z, int4 n, bool inside) {
    return (inside || in_grid(x, y, z, n)) ? f[cell(x, y, z, n)] : 0.0f;
}

INLINE float4 ld4(const __global float4* f, int x, int y, int z, int4 n, bool inside) {
    return (inside || in_grid(x, y, z, n)) ? f[cell(x, y, z, n)] : (float4)(0.0f);
}

// Sum of the 6 face neighbours (the 3D Laplacian stencil without its centre).
INLINE float4 neighbours4(const __global float4* f, int x, int y, int z, int4 n, bool inside) {
    return ld4(f, x - 1, y, z, n, inside) + ld4(f, x + 1, y, z, n, inside) + ld4(f, x, y - 1, z, n, inside) +
           ld4(f, x, y + 1, z, n, inside) + ld4(f, x, y, z - 1, n, inside) + ld4(f, x, y, z + 1, n, inside);
}

INLINE float neighbours(const __global float* f, int x, int y, int z, int4 n, bool inside) {
    return ld(f, x - 1, y, z, n, inside) + ld(f, x + 1, y, z, n, inside) + ld(f, x, y - 1, z, n, inside) +
           ld(f, x, y + 1, z, n, inside) + ld(f, x, y, z - 1, n, inside) + ld(f, x, y, z + 1, n, inside);
}

// Where a back-traced point may lie (book: clamp(x, 0.5, w - 1.5) with its result dropped).
INLINE float3 clamp_back_trace(float3 b, int4 n) {
#if BOOK_VARIANT
    // No clamp, as the book: taps outside read 0. Any coordinate below -1 or at/above n reads only zeros, so pinning
    // b to [-2, n + 1] changes no value; it only keeps the float -> int conversion below defined.
    return clamp(b, (float3)(-2.0f), convert_float3(n.xyz) + 1.0f);
#else
    return clamp(b, (float3)(0.5f), convert_float3(n.xyz) - 1.5f);
#endif
}

// Stam's clamp keeps the 8 taps of a back-traced point in the grid (floor(b) in [0, n-2]); the book's may leave it,
// and its taps outside read 0.
#define TAPS_INSIDE (!BOOK_VARIANT)

// Trilinear interpolation of f at the grid point b (book: s0/s1, t0/t1, u0/u1 weights of the 8 cells around b).
// One body for float4 fields (trilinear) and float fields (trilinear1: fixed's step() samples the density copy from
// a float field), so that a float field gives bit for bit the float4 field's component.
#define TRILINEAR(name, T, LD)                                                                                       \
    INLINE T name(const __global T* f, float3 b, int4 n) {                                                         \
        const float3 b0 = floor(b);                                                                                 \
        const int x0 = (int)b0.x, y0 = (int)b0.y, z0 = (int)b0.z;                                                   \
        const float s1 = b.x - b0.x, t1 = b.y - b0.y, u1 = b.z - b0.z;                                              \
        const float s0 = 1.0f - s1, t0 = 1.0f - t1, u0 = 1.0f - u1;                                                 \
        const bool in = TAPS_INSIDE;                                                                                \
        return s0 * u0 * (t0 * LD(f, x0, y0, z0, n, in) + t1 * LD(f, x0, y0 + 1, z0, n, in)) +                      \
               s1 * u0 * (t0 * LD(f, x0 + 1, y0, z0, n, in) + t1 * LD(f, x0 + 1, y0 + 1, z0, n, in)) +              \
               s0 * u1 * (t0 * LD(f, x0, y0, z0 + 1, n, in) + t1 * LD(f, x0, y0 + 1, z0 + 1, n, in)) +              \
               s1 * u1 * (t0 * LD(f, x0 + 1, y0, z0 + 1, n, in) + t1 * LD(f, x0 + 1, y0 + 1, z0 + 1, n, in));      \
    }
TRILINEAR(trilinear, float4, ld4)
TRILINEAR(trilinear1, float, ld)

// }}}

// {{{ the boundary rules (the book's SetBoundary* helpers), shared by the kernels that apply them

// in = c moved one step inwards on each axis where c is on a wall (c itself inside); returns the number of wall axes:
// 0 inside, 1 a face cell, 2 an edge cell, 3 a corner.
INLINE int inner_cell(const int c[3], int4 n, int in[3]) {
    const int dims[3] = {n.x, n.y, n.z};
    int walls = 0;
    for (int a = 0; a < 3; a++) {
        in[a] = clamp(c[a], 1, dims[a] - 2);
        walls += in[a] != c[a];
    }
    return walls;
}

INLINE int cell_of(const int c[3], int4 n) { return cell(c[0], c[1], c[2], n); }

// 1 <= x <= w-2, 1 <= y <= h-2 and 1 <= z <= d-2 in three unsigned comparisons (padding work-items fail it too).
INLINE bool is_interior(int x, int y, int z, int4 n) {
    return (uint)(x - 1) < (uint)(n.x - 2) && (uint)(y - 1) < (uint)(n.y - 2) && (uint)(z - 1) < (uint)(n.z - 2);
}

// SetBoundaryDensity / Div / P at a cell with `walls` wall axes, `v` = the value of its inner cell: a face cell
// copies v; an edge cell is the mean of its 2 face neighbours, both copies of v; a corner the mean of its 3 edge
// neighbours, each such a mean (the sums and products in the book's order).
INLINE float wall_copy(int walls, float v) {
    if (walls <= 1) return v;
    const float edge = (v + v) * 0.5f;
    return walls == 2 ? edge : (edge + edge + edge) * ONE_THIRD;
}

// The face rule of SetBoundaryVelocity for a face cell normal to `axis`: its own value `own` with the normal
// component replaced by the inner cell's, negated (no flow through the wall).
INLINE float4 face_velocity(int axis, float4 own, float4 inner) {
    own.x = axis == 0 ? -inner.x : own.x;
    own.y = axis == 1 ? -inner.y : own.y;
    own.z = axis == 2 ? -inner.z : own.z;
    return own;
}

// SetBoundaryVelocity at a wall cell c (inner cell `in`, `walls` wall axes) from face[a] = the face rule's value at
// the face cell normal to a that shares c's coordinate a and in's others (c itself when walls == 1), for each wall
// axis a. An edge along axis e is (face[e+2] + face[e+1]) * 0.5 (axes mod 3), a corner the mean of the 3 edges.
INLINE float4 wall_velocity(const int c[3], const int in[3], int walls, const float4 face[3]) {
    if (walls == 1) return face[c[0] != in[0] ? 0 : c[1] != in[1] ? 1 : 2];
    if (walls == 2) {
        const int along = c[0] == in[0] ? 0 : c[1] == in[1] ? 1 : 2;
        return (face[(along + 2) % 3] + face[(along + 1) % 3]) * 0.5f;
    }
    float4 edge[3];
    for (int e = 0; e < 3; e++) edge[e] = (face[(e + 2) % 3] + face[(e + 1) % 3]) * 0.5f;
    return (edge[0] + edge[1] + edge[2]) * ONE_THIRD;
}

// The face cell of wall axis a used by wall_velocity: in with coordinate a taken from c.
INLINE void face_cell(const int c[3], const int in[3], int a, int f[3]) {
    for (int b = 0; b < 3; b++) f[b] = b == a ? c[b] : in[b];
}

INLINE int wall_count(int4 n) { return n.x * n.y * n.z - (n.x - 2) * (n.y - 2) * (n.z - 2); }

// Wall cell k -> c, each wall cell once: the faces x = 0 and x = w-1 whole (h*d cells each), the faces y = 0 and
// y = h-1 without their x ends ((w-2)*d each), the faces z = 0 and z = d-1 without their x and y ends
// ((w-2)*(h-2) each). 0 past the last.
INLINE int boundary_cell(int k, int4 n, int c[3]) {
    const int yz = n.y * n.z, xz = (n.x - 2) * n.z, xy = (n.x - 2) * (n.y - 2);
    if (k < 2 * yz) {
        c[0] = k < yz ? 0 : n.x - 1;
        k %= yz;
        c[1] = k % n.y;
        c[2] = k / n.y;
        return 1;
    }
    k -= 2 * yz;
    if (k < 2 * xz) {
        c[1] = k < xz ? 0 : n.y - 1;
        k %= xz;
        c[0] = 1 + k % (n.x - 2);
        c[2] = k / (n.x - 2);
        return 1;
    }
    k -= 2 * xz;
    if (k < 2 * xy) {
        c[2] = k < xy ? 0 : n.z - 1;
        k %= xy;
        c[0] = 1 + k % (n.x - 2);
        c[1] = 1 + k / (n.x - 2);
        return 1;
    }
    return 0;
}

// The kernels that set walls themselves (+B in the header) are launched with extra layers of work-groups past the
// grid's along z (Simulation._reset: as many as the wall cells fill): the grid's groups compute the interior cells
// and leave the walls alone; work-item k of the extra groups, counted group by group, sets wall cell k, and groups
// past the last wall cell leave at once. A group thus runs one branch for all its work-items, and the interior's
// neighbour reads need no bounds test.
INLINE bool is_wall_group(int d) { return get_group_id(2) * get_local_size(2) >= d; }

// grid_z: the grid's work-items along z (n.z; a strip kernel's number of strips): the wall groups come after them.
INLINE int wall_item_past(int4 n, int c[3], int grid_z) {
    const int size = get_local_size(0) * get_local_size(1) * get_local_size(2);
    const int grid_layers = (grid_z + get_local_size(2) - 1) / get_local_size(2);  // the grid's layers of groups
    const int group =
        ((get_group_id(2) - grid_layers) * get_num_groups(1) + get_group_id(1)) * get_num_groups(0) + get_group_id(0);
    if (group * size >= wall_count(n)) return 0;  // a group past the last wall cell: all its work-items leave
    const int item = (get_local_id(2) * get_local_size(1) + get_local_id(1)) * get_local_size(0) + get_local_id(0);
    return boundary_cell(group * size + item, n, c);
}

INLINE int wall_item(int4 n, int c[3]) { return wall_item_past(n, c, n.z); }

// The copy rule on one float per cell, `stride` floats apart from `offset` (density: 1, 0; prev.x: 4, 0; prev.y: 4, 1),
// one work-item per wall cell. Every work-item reads only an interior cell and writes only its own wall cell.
INLINE void set_boundary_copy(__global float* f, int stride, int offset, int4 n) {
    int c[3], in[3];
    if (!boundary_cell(get_global_id(0), n, c)) return;  // padding of the rounded-up global size
    const int walls = inner_cell(c, n, in);
    f[cell_of(c, n) * stride + offset] = wall_copy(walls, f[cell_of(in, n) * stride + offset]);
}

// }}}

// {{{ external force (source) terms

// The original's 3D source texture has no producer (docs/chapters/04-stable-fluids-3d.md): a spherical emitter at c
// (uvw units) of radius r blowing along dir.
__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, THREAD_Z)))
void AddSourceBrush3D(__global float4* source, int w, int h, int d, float4 center, float4 direction, float radius) {
    CELL_OR_RETURN(w, h, d)
    const float3 uvw = ((float3)(x, y, z) + 0.5f) / convert_float3(n.xyz);
    const float3 q = (uvw - center.xyz) / radius;
    const float f = clamp(1.0f - dot(q, q), 0.0f, 1.0f);
    source[id] = (float4)(direction.xyz * f, f);
}

// What AddSourceVelocity and AddSourceDensity add and leave in prev, rounded before any caller adds it (no FMA
// contraction: fixed's step() adds the term where the book's kernels add the value they stored, and must round alike).
INLINE float3 velocity_source(float4 source, float velocity_coef, float dt) {
#pragma OPENCL FP_CONTRACT OFF
    return source.xyz * velocity_coef * dt;
}

INLINE float density_source(float4 source, float density_coef, float dt) {
#pragma OPENCL FP_CONTRACT OFF
    return source.w * density_coef * dt;
}

__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, THREAD_Z)))
void AddSourceVelocity(__global float4* velocity, __global float4* prev, const __global float4* source,
                       int w, int h, int d, float velocity_coef, float dt) {
    CELL_OR_RETURN(w, h, d)
    const float3 s = velocity_source(source[id], velocity_coef, dt);
    velocity[id] = (float4)(velocity[id].xyz + s, 0.0f);
    prev[id] = (float4)(s, prev[id].w);
}

// }}}

// {{{ velocity step

// Implicit viscosity: (1 + 6a) v - a * sum6(v) = prev.xyz, one Jacobi sweep. Note that the book feeds prev (the
// source, or leftovers of the last projection) where Stam has the previous velocity; with the scene's a ~ 1e5 the
// sweep is effectively "replace by the mean of the 6 neighbours" (reproduced, not corrected). Solver3D.compute
// omits d from a (docs/chapters/04-stable-fluids-3d.md): a = dt*visc*w*h*d here.
INLINE float4 diffuse_velocity_at(const __global float4* velocity_in, const __global float4* prev, int x, int y, int z,
                                  int4 n, float a, bool inside) {
    const float4 sum = neighbours4(velocity_in, x, y, z, n, inside);
    return (float4)((prev[cell(x, y, z, n)].xyz + a * sum.xyz) / (1.0f + 6.0f * a), 0.0f);
}

__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, THREAD_Z)))
void DiffuseVelocity(const __global float4* velocity_in, const __global float4* prev,
                     __global float4* velocity_out, int w, int h, int d, float dt, float visc) {
    const int4 n = (int4)(w, h, d, 0);
    const float a = dt * visc * (float)w * (float)h * (float)d;
    int c[3] = {get_global_id(0), get_global_id(1), get_global_id(2)};
    if (is_wall_group(d)) {  // SetBoundaryVelocity from this sweep's values of the cells the rule reads
        if (!wall_item(n, c)) return;
        int in[3], f[3];
        const int walls = inner_cell(c, n, in);
        const float4 inner = diffuse_velocity_at(velocity_in, prev, in[0], in[1], in[2], n, a, true);
        float4 face[3] = {(float4)(0.0f), (float4)(0.0f), (float4)(0.0f)};
        for (int axis = 0; axis < 3; axis++) {
            if (c[axis] == in[axis]) continue;
            face_cell(c, in, axis, f);
            const float4 own = diffuse_velocity_at(velocity_in, prev, f[0], f[1], f[2], n, a, false);
            face[axis] = face_velocity(axis, own, inner);
        }
        velocity_out[cell_of(c, n)] = wall_velocity(c, in, walls, face);
        return;
    }
    if (!is_interior(c[0], c[1], c[2], n)) return;  // padding, or a wall cell (a wall item sets it)
    velocity_out[cell_of(c, n)] = diffuse_velocity_at(velocity_in, prev, c[0], c[1], c[2], n, a, true);
}

// Divergence into prev.y (walls: the inner cell's, SetBoundaryDiv), p = 0 into prev.x (everywhere: SetBoundaryP has
// nothing to change).
// du, dv, dw: the differences of u, v, w between the cell's two neighbours along x, y, z.
INLINE float divergence_of(float du, float dv, float dw, int4 n) {
    const int w = n.x, h = n.y, d = n.z;
#if BOOK_VARIANT
    return -0.5f * (du / w) + dv / h + dw / d;  // book: -0.5 * (uvd.x * du) + (uvd.y * dv) + (uvd.z * dw)
#else
    return -0.5f * (du / w + dv / h + dw / d);  // Stam: -0.5 * h * (du + dv + dw)
#endif
}

INLINE float divergence_at(const __global float4* velocity, int x, int y, int z, int4 n) {
    // (x, y, z) is interior: all 6 neighbours exist
    const float du = velocity[cell(x + 1, y, z, n)].x - velocity[cell(x - 1, y, z, n)].x;
    const float dv = velocity[cell(x, y + 1, z, n)].y - velocity[cell(x, y - 1, z, n)].y;
    const float dw = velocity[cell(x, y, z + 1, n)].z - velocity[cell(x, y, z - 1, n)].z;
    return divergence_of(du, dv, dw, n);
}

// fixed: the divergence and p = 0 also go to their own float fields, which the sweeps read (12 bytes per cell, not
// the 32 of a float4 read and write); ProjectStep3 writes the solved p back into prev.x. write_prev = 0 leaves prev
// alone in both (the host's first projection of a step: SwapVelocity overwrites prev.xyz before anything reads it).
// fixed, first_sweep = 1 (step()): pressure = the first ProjectStep2 sweep's p instead of 0, so the host runs one
// sweep less. From p = 0 that sweep's sum of the 6 neighbours is +0, so its p is (div + 0) / 6 at the cell's inner
// cell, the wall rule applied (pressure_at's arithmetic: the same bits).
__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, THREAD_Z)))
#if BOOK_VARIANT
void ProjectStep1(const __global float4* velocity, __global float4* prev, int w, int h, int d) {
#else
void ProjectStep1(const __global float4* velocity, __global float4* prev, __global float* divergence,
                  __global float* pressure, int w, int h, int d, int write_prev, int first_sweep) {
#endif
    const int4 n = (int4)(w, h, d, 0);
    int c[3] = {get_global_id(0), get_global_id(1), get_global_id(2)};
    float div, swept;  // swept: the first sweep's p (fixed, first_sweep)
    if (is_wall_group(d)) {  // SetBoundaryDiv: the divergence of the inner cell
        if (!wall_item(n, c)) return;
        int in[3];
        const int walls = inner_cell(c, n, in);
        const float inner = divergence_at(velocity, in[0], in[1], in[2], n);
        div = wall_copy(walls, inner);
        swept = wall_copy(walls, (inner + 0.0f) / 6.0f);
    } else {
        if (!is_interior(c[0], c[1], c[2], n)) return;  // padding, or a wall cell (a wall item sets it)
        div = divergence_at(velocity, c[0], c[1], c[2], n);
        swept = (div + 0.0f) / 6.0f;
    }
    const int id = cell_of(c, n);
#if BOOK_VARIANT
    const bool write_prev = true;  // the book's sweeps solve in prev
#endif
    if (write_prev) {
        const float4 p = prev[id];
        prev[id] = (float4)(0.0f, div, p.z, p.w);
    }
#if !BOOK_VARIANT
    divergence[id] = div;
    pressure[id] = first_sweep ? swept : 0.0f;
#endif
}

// ProjectStep1 as fixed's step() runs it (write_prev = 0, first_sweep = 1) in strips of 1 x 1 x FIELD_ROWS cells
// along z, walls included (Simulation._fused_project): the velocity's z of the cells below and above in registers,
// in DiffuseFieldsRows' work-groups. Every cell, wall or not, is wall_copy(its wall axes, the value at its inner
// cell), as in ProjectStep2Rows; the divergence at (clamp(x), clamp(y), clamp(z)) as divergence_at computes it:
// ProjectStep1's values bit for bit. Global size (w, h, ceil(d / FIELD_ROWS)); no work-group shape is required.
#if !BOOK_VARIANT
#ifndef FIELD_ROWS
#error "build with -D FIELD_ROWS=<cells per strip along z> (the host's FIELD_ROWS)"
#endif
__kernel void ProjectStep1Rows(const __global float4* velocity, __global float* divergence, __global float* pressure,
                               int w, int h, int d) {
    const int4 n = (int4)(w, h, d, 0);
    const int x = get_global_id(0), y = get_global_id(1), z0 = FIELD_ROWS * get_global_id(2);
    if (x >= w || y >= h || z0 >= d) return;  // padding of the rounded-up global size
    const int z1 = min(z0 + FIELD_ROWS, d) - 1;  // the strip's cells z0 .. z1; its z walls copy planes 1 and d-2
    const int r0 = clamp(z0, 1, d - 2), r1 = clamp(z1, 1, d - 2);  // the interior planes it computes
    const int walls = (clamp(x, 1, w - 2) != x) + (clamp(y, 1, h - 2) != y);  // off the z walls
    const int plane = w * h, column = clamp(y, 1, h - 2) * w + clamp(x, 1, w - 2), out = y * w + x;
    float vz_below = velocity[(r0 - 1) * plane + column].z, vz_mid = velocity[r0 * plane + column].z;
    for (int r = r0; r <= r1; r++) {
        const int i = r * plane + column;
        const float vz_above = velocity[i + plane].z;
        const float du = velocity[i + 1].x - velocity[i - 1].x, dv = velocity[i + w].y - velocity[i - w].y;
        const float div = divergence_of(du, dv, vz_above - vz_below, n), swept = (div + 0.0f) / 6.0f;
        if (r >= z0 && r <= z1) {  // not a z wall
            divergence[r * plane + out] = wall_copy(walls, div);
            pressure[r * plane + out] = wall_copy(walls, swept);
        }
        if (r == 1 && z0 == 0) {  // the z = 0 wall
            divergence[out] = wall_copy(walls + 1, div);
            pressure[out] = wall_copy(walls + 1, swept);
        }
        if (r == d - 2 && z1 == d - 1) {  // the z = d-1 wall
            divergence[(d - 1) * plane + out] = wall_copy(walls + 1, div);
            pressure[(d - 1) * plane + out] = wall_copy(walls + 1, swept);
        }
        vz_below = vz_mid;
        vz_mid = vz_above;
    }
}
#endif

// Poisson equation sum6(p) - 6p = -div, one Jacobi sweep: p = (div + sum6(p)) / 6; walls copy the inner cell's new p
// (SetBoundaryP). book: p = prev.x, div = prev.y; fixed: the float fields.
#if BOOK_VARIANT
INLINE float pressure_at(const __global float4* prev_in, int x, int y, int z, int4 n) {
    return (prev_in[cell(x, y, z, n)].y + neighbours4(prev_in, x, y, z, n, true).x) / 6.0f;  // an interior cell
}
#else
INLINE float pressure_at(const __global float* pressure_in, const __global float* divergence, int x, int y, int z,
                         int4 n) {
    // an interior cell; the 6 neighbours' p summed in neighbours4's order: bit for bit the book's p
    return (divergence[cell(x, y, z, n)] + neighbours(pressure_in, x, y, z, n, true)) / 6.0f;
}
#endif

__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, THREAD_Z)))
#if BOOK_VARIANT
void ProjectStep2(const __global float4* prev_in, __global float4* prev_out, int w, int h, int d) {
#define PRESSURE_AT(x, y, z) pressure_at(prev_in, x, y, z, n)
#else
void ProjectStep2(const __global float* pressure_in, __global float* pressure_out, const __global float* divergence,
                  int w, int h, int d) {
#define PRESSURE_AT(x, y, z) pressure_at(pressure_in, divergence, x, y, z, n)
#endif
    const int4 n = (int4)(w, h, d, 0);
    int c[3] = {get_global_id(0), get_global_id(1), get_global_id(2)};
    float p;
    if (is_wall_group(d)) {  // SetBoundaryP: this sweep's p of the inner cell
        if (!wall_item(n, c)) return;
        int in[3];
        const int walls = inner_cell(c, n, in);
        p = wall_copy(walls, PRESSURE_AT(in[0], in[1], in[2]));
    } else {
        if (!is_interior(c[0], c[1], c[2], n)) return;  // padding, or a wall cell (a wall item sets it)
        p = PRESSURE_AT(c[0], c[1], c[2]);
    }
    const int id = cell_of(c, n);
#if BOOK_VARIANT
    prev_out[id] = (float4)(p, prev_in[id].yzw);
#else
    pressure_out[id] = p;
#endif
#undef PRESSURE_AT
}

// ProjectStep2 in strips (fixed, w % 4 == 0): one work-item sweeps a column of 4 x 1 x ROWS cells along z, walls
// included, keeping the planes below and above in registers, with 16-byte loads and stores. Every cell, wall or not,
// is wall_copy(its wall axes, p at its inner cell); the strip computes p at (clamp(x), clamp(y), clamp(z)) as
// pressure_at does (the same sum in the same order): ProjectStep2's values bit for bit. Global size (w / 4, h,
// ceil(d / ROWS)); no work-group shape is required.
#if !BOOK_VARIANT
#ifndef ROWS
#error "build with -D ROWS=<cells per strip along z> (the host's ROWS_PER_ITEM)"
#endif
INLINE float4 wall_copy4(int4 walls, float4 v) {
    return (float4)(wall_copy(walls.s0, v.s0), wall_copy(walls.s1, v.s1), wall_copy(walls.s2, v.s2),
                    wall_copy(walls.s3, v.s3));
}

__kernel void ProjectStep2Rows(const __global float* pressure_in, __global float* pressure_out,
                               const __global float* divergence, int w, int h, int d) {
    const int x0 = 4 * get_global_id(0), y = get_global_id(1), z0 = ROWS * get_global_id(2);
    if (x0 >= w || y >= h || z0 >= d) return;  // padding of the rounded-up global size
    const int z1 = min(z0 + ROWS, d) - 1;  // the strip's cells z0 .. z1; its z walls copy planes 1 and d-2
    const int r0 = clamp(z0, 1, d - 2), r1 = clamp(z1, 1, d - 2);  // the interior planes it computes
    const int cy = clamp(y, 1, h - 2), plane = w * h;
    const bool left = x0 == 0, right = x0 + 4 == w;
    // wall axes of the strip's cells off the z walls: x (the first or last lane of the row), y (a y wall row)
    const int4 walls = (int4)(left, 0, 0, right) + (cy != y);
    const int column = cy * w + x0;  // (x0, cy) in a plane
    float4 below = vload4(0, pressure_in + (r0 - 1) * plane + column);
    float4 mid = vload4(0, pressure_in + r0 * plane + column);
    for (int r = r0; r <= r1; r++) {
        const int i = r * plane + column;
        const float4 above = vload4(0, pressure_in + i + plane);
        const float4 west = (float4)(left ? 0.0f : pressure_in[i - 1], mid.s012);
        const float4 east = (float4)(mid.s123, right ? 0.0f : pressure_in[i + 4]);
        const float4 south = vload4(0, pressure_in + i - w), north = vload4(0, pressure_in + i + w);
        // pressure_at's order: x-1, x+1, y-1, y+1, z-1, z+1
        float4 p = (vload4(0, divergence + i) + (west + east + south + north + below + above)) / 6.0f;
        if (left) p.s0 = p.s1;   // the x walls' inner cells
        if (right) p.s3 = p.s2;
        const int out = y * w + x0;  // (x0, y) in a plane
        if (r >= z0 && r <= z1) vstore4(wall_copy4(walls, p), 0, pressure_out + r * plane + out);  // not a wall
        if (r == 1 && z0 == 0) vstore4(wall_copy4(walls + 1, p), 0, pressure_out + out);  // the z = 0 wall
        if (r == d - 2 && z1 == d - 1) vstore4(wall_copy4(walls + 1, p), 0, pressure_out + (d - 1) * plane + out);
        below = mid;
        mid = above;
    }
}
#endif

// Subtract the gradient of p (central differences, scaled back from uv units: book's / uvd). fixed: p from its
// float field, copied into prev.x, so prev holds (p, div) afterwards as the book's does.
__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, THREAD_Z)))
#if BOOK_VARIANT
void ProjectStep3(__global float4* velocity, const __global float4* prev, int w, int h, int d) {
    CELL_OR_RETURN(w, h, d)
    float4 v = velocity[id];
    v.x -= 0.5f * (ld4(prev, x + 1, y, z, n, false).x - ld4(prev, x - 1, y, z, n, false).x) * (float)w;
    v.y -= 0.5f * (ld4(prev, x, y + 1, z, n, false).x - ld4(prev, x, y - 1, z, n, false).x) * (float)h;
    v.z -= 0.5f * (ld4(prev, x, y, z + 1, n, false).x - ld4(prev, x, y, z - 1, n, false).x) * (float)d;
    velocity[id] = v;
}
#else
void ProjectStep3(__global float4* velocity, __global float4* prev, const __global float* pressure, int w, int h,
                  int d, int write_prev) {
    CELL_OR_RETURN(w, h, d)
    float4 v = velocity[id];
    v.x -= 0.5f * (ld(pressure, x + 1, y, z, n, false) - ld(pressure, x - 1, y, z, n, false)) * (float)w;
    v.y -= 0.5f * (ld(pressure, x, y + 1, z, n, false) - ld(pressure, x, y - 1, z, n, false)) * (float)h;
    v.z -= 0.5f * (ld(pressure, x, y, z + 1, n, false) - ld(pressure, x, y, z - 1, n, false)) * (float)d;
    velocity[id] = v;
    if (write_prev) prev[id].x = pressure[id];
}
#endif

// The velocity's walls, one work-item per wall cell (global >= w*h*d - (w-2)(h-2)(d-2)). A face cell writes only its
// normal component; an edge or corner reads the inner cell and, of each face cell it depends on, only the components
// that face cell does not write (float pointers: no byte is read while another work-item writes it).
__kernel void SetBoundaryVelocity(__global float4* velocity, int w, int h, int d) {
    const int4 n = (int4)(w, h, d, 0);
    int c[3], in[3];
    if (!boundary_cell(get_global_id(0), n, c)) return;  // padding of the rounded-up global size
    const int walls = inner_cell(c, n, in);
    __global float* v = (__global float*)velocity;  // cell j: u, v, w, 0 at v[4j .. 4j + 3]
    const int inner = cell_of(in, n);
    if (walls == 1) {
        const int axis = c[0] != in[0] ? 0 : c[1] != in[1] ? 1 : 2;
        v[4 * cell_of(c, n) + axis] = -v[4 * inner + axis];
        return;
    }
    float4 face[3] = {(float4)(0.0f), (float4)(0.0f), (float4)(0.0f)};
    for (int axis = 0; axis < 3; axis++) {
        if (c[axis] == in[axis]) continue;
        int f[3];
        face_cell(c, in, axis, f);
        const int k = 4 * cell_of(f, n);
        float4 own;  // the face cell's components its own work-item leaves alone (its normal one is set below)
        own.x = axis == 0 ? 0.0f : v[k];
        own.y = axis == 1 ? 0.0f : v[k + 1];
        own.z = axis == 2 ? 0.0f : v[k + 2];
        own.w = v[k + 3];
        face[axis] = face_velocity(axis, own, (float4)(v[4 * inner], v[4 * inner + 1], v[4 * inner + 2], 0.0f));
    }
    velocity[cell_of(c, n)] = wall_velocity(c, in, walls, face);
}

__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, THREAD_Z)))
void SwapVelocity(const __global float4* velocity, __global float4* prev, int w, int h, int d) {
    CELL_OR_RETURN(w, h, d)
    prev[id] = (float4)(velocity[id].xyz, prev[id].w);
}

// Semi-Lagrangian self-advection: back-trace by the cell's own copied velocity, dfdt cells per unit velocity.
INLINE float4 advect_velocity_at(const __global float4* prev, int x, int y, int z, int4 n, float dfdt) {
    const float3 b = clamp_back_trace((float3)(x, y, z) - dfdt * prev[cell(x, y, z, n)].xyz, n);
    return (float4)(trilinear(prev, b, n).xyz, 0.0f);
}

// AdvectVelocity's work-item: the cell it wrote, -1 for none.
INLINE int advect_velocity(const __global float4* prev, __global float4* velocity, int4 n, float dt) {
    const float dfdt = dt * (float)(n.x + n.y + n.z) / 3.0f;
    int c[3] = {get_global_id(0), get_global_id(1), get_global_id(2)};
    if (is_wall_group(n.z)) {  // SetBoundaryVelocity from the advected values of the cells the rule reads
        if (!wall_item(n, c)) return -1;
        int in[3], f[3];
        const int walls = inner_cell(c, n, in);
        const float4 inner = advect_velocity_at(prev, in[0], in[1], in[2], n, dfdt);
        float4 face[3] = {(float4)(0.0f), (float4)(0.0f), (float4)(0.0f)};
        for (int axis = 0; axis < 3; axis++) {
            if (c[axis] == in[axis]) continue;
            face_cell(c, in, axis, f);
            face[axis] = face_velocity(axis, advect_velocity_at(prev, f[0], f[1], f[2], n, dfdt), inner);
        }
        const int id = cell_of(c, n);
        velocity[id] = wall_velocity(c, in, walls, face);
        return id;
    }
    if (!is_interior(c[0], c[1], c[2], n)) return -1;  // padding, or a wall cell (a wall item sets it)
    const int id = cell_of(c, n);
    velocity[id] = advect_velocity_at(prev, c[0], c[1], c[2], n, dfdt);
    return id;
}

__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, THREAD_Z)))
void AdvectVelocity(const __global float4* prev, __global float4* velocity, int w, int h, int d, float dt) {
    advect_velocity(prev, velocity, (int4)(w, h, d, 0), dt);
}

// }}}

// {{{ density step

__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, THREAD_Z)))
void AddSourceDensity(__global float* density, __global float4* prev, const __global float4* source,
                      int w, int h, int d, float density_coef, float dt) {
    CELL_OR_RETURN(w, h, d)
    const float s = density_source(source[id], density_coef, dt);
    density[id] += s;
    prev[id].w = s;
}

// Walls copy the inner cell's new value (SetBoundaryDensity).
INLINE float diffuse_density_at(const __global float* density_in, const __global float4* prev, int x, int y, int z,
                                int4 n, float a) {
    return (prev[cell(x, y, z, n)].w + a * neighbours(density_in, x, y, z, n, true)) / (1.0f + 6.0f * a);  // interior
}

__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, THREAD_Z)))
void DiffuseDensity(const __global float* density_in, const __global float4* prev,
                    __global float* density_out, int w, int h, int d, float dt, float diff) {
    const int4 n = (int4)(w, h, d, 0);
    const float a = dt * diff * (float)w * (float)h * (float)d;
    int c[3] = {get_global_id(0), get_global_id(1), get_global_id(2)};
    float value;
    if (is_wall_group(d)) {  // SetBoundaryDensity: this sweep's value of the inner cell
        if (!wall_item(n, c)) return;
        int in[3];
        const int walls = inner_cell(c, n, in);
        value = wall_copy(walls, diffuse_density_at(density_in, prev, in[0], in[1], in[2], n, a));
    } else {
        if (!is_interior(c[0], c[1], c[2], n)) return;  // padding, or a wall cell (a wall item sets it)
        value = diffuse_density_at(density_in, prev, c[0], c[1], c[2], n, a);
    }
    density_out[cell_of(c, n)] = value;
}

__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, THREAD_Z)))
void SwapDensity(const __global float* density, __global float4* prev, int w, int h, int d) {
    CELL_OR_RETURN(w, h, d)
    prev[id].w = density[id];
}

// Back-trace by `carrier` (the velocity after the second projection, or the source's xyz) and sample the density
// copy in prev.w (the original samples prev.z, the velocity's z: fixed), or, where `copy` is given (fixed's step()),
// in that float field; walls copy the inner cell's value (SetBoundaryDensity).
INLINE float advect_density_at(const __global float4* carrier, const __global float4* prev,
                               const __global float* copy, int x, int y, int z, int4 n, float dfdt) {
    const float3 b = clamp_back_trace((float3)(x, y, z) - dfdt * carrier[cell(x, y, z, n)].xyz, n);
    return copy ? trilinear1(copy, b, n) : trilinear(prev, b, n).w;
}

INLINE void advect_density(const __global float4* carrier, const __global float4* prev, const __global float* copy,
                           __global float* density, int4 n, float dt) {
    const float dfdt = dt * (float)(n.x + n.y + n.z) / 3.0f;
    int c[3] = {get_global_id(0), get_global_id(1), get_global_id(2)};
    float value;
    if (is_wall_group(n.z)) {  // the inner cell's advected value
        if (!wall_item(n, c)) return;
        int in[3];
        const int walls = inner_cell(c, n, in);
        value = wall_copy(walls, advect_density_at(carrier, prev, copy, in[0], in[1], in[2], n, dfdt));
    } else {
        if (!is_interior(c[0], c[1], c[2], n)) return;  // padding, or a wall cell (a wall item sets it)
        value = advect_density_at(carrier, prev, copy, c[0], c[1], c[2], n, dfdt);
    }
    density[cell_of(c, n)] = value;
}

__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, THREAD_Z)))
void AdvectDensity(const __global float4* velocity, const __global float4* prev, __global float* density,
                   int w, int h, int d, float dt) {
    advect_density(velocity, prev, 0, density, (int4)(w, h, d, 0), dt);
}

// density_only: the source's velocity replaces the solved one (the original samples the source at uvw = 0).
__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, THREAD_Z)))
void AdvectDensityFromExt(const __global float4* source, const __global float4* prev,
                          __global float* density, int w, int h, int d, float dt) {
    advect_density(source, prev, 0, density, (int4)(w, h, d, 0), dt);
}

// }}}

// {{{ fixed's step() in fewer passes (Simulation.fused_step): the book's kernels' values bit for bit

// step() keeps prev split into float fields (Simulation.prev_split): x = p (the pressure field), y = div (the
// divergence field), z = prev_z, w = prev_density. The book's writes of prev that a later read sees are kept (the
// second projection's p and div, SwapVelocity's z, SwapDensity's copy); the others (AddSource*'s terms, SwapVelocity's
// x and y) are computed where they are read instead of stored. The first projection is the same as the second,
// ProjectStep1 doing the first sweep (first_sweep = 1), and leaves prev.xy alone as step()'s does.
#if !BOOK_VARIANT

// The inputs of one DiffuseFields sweep, as the book's DiffuseVelocity and DiffuseDensity find them.
typedef struct {
    const __global float4* velocity;  // velocity_in
    const __global float* density;    // density_in
    const __global float4* source;
    const __global float *prev_x, *prev_y, *prev_z, *prev_w;  // the split prev
    float velocity_coef, density_coef, dt;
    int source_on;  // AddSource* ran this step: prev.xyz and prev.w hold their terms
    int add;        // the step's first sweep with the source on: the inputs are AddSource*'s outputs
} Sweep;

// velocity_in at a cell, or with add AddSourceVelocity's output there (velocity + its term, w = 0); 0 outside (ld4).
INLINE float4 sweep_velocity(const Sweep* s, int x, int y, int z, int4 n, bool inside) {
    if (!(inside || in_grid(x, y, z, n))) return (float4)(0.0f);
    const int i = cell(x, y, z, n);
    const float4 v = s->velocity[i];
    return s->add ? (float4)(v.xyz + velocity_source(s->source[i], s->velocity_coef, s->dt), 0.0f) : v;
}

// density_in at a cell of the grid, or with add AddSourceDensity's output there.
INLINE float sweep_density(const Sweep* s, int i) {
    const float rho = s->density[i];
    return s->add ? rho + density_source(s->source[i], s->density_coef, s->dt) : rho;
}

// DiffuseVelocity's centre term prev.xyz: the source's term (source on) or the split prev's x, y, z.
INLINE float3 sweep_velocity_centre(const Sweep* s, int i) {
    return s->source_on ? velocity_source(s->source[i], s->velocity_coef, s->dt)
                        : (float3)(s->prev_x[i], s->prev_y[i], s->prev_z[i]);
}

// DiffuseDensity's centre term prev.w: the source's term (source on) or the split prev's w.
INLINE float sweep_density_centre(const Sweep* s, int i) {
    return s->source_on ? density_source(s->source[i], s->density_coef, s->dt) : s->prev_w[i];
}

// diffuse_velocity_at's and diffuse_density_at's last line, from the centre term and the sum of the 6 neighbours
// (one body for DiffuseFields and DiffuseFieldsRows: the same rounding).
INLINE float4 diffused_velocity(float3 centre, float4 sum, float a) {
    return (float4)((centre + a * sum.xyz) / (1.0f + 6.0f * a), 0.0f);
}

INLINE float diffused_density(float centre, float sum, float a) { return (centre + a * sum) / (1.0f + 6.0f * a); }

// diffuse_velocity_at on the sweep's inputs.
INLINE float4 sweep_velocity_at(const Sweep* s, int x, int y, int z, int4 n, float a, bool inside) {
    const float4 sum = sweep_velocity(s, x - 1, y, z, n, inside) + sweep_velocity(s, x + 1, y, z, n, inside) +
                       sweep_velocity(s, x, y - 1, z, n, inside) + sweep_velocity(s, x, y + 1, z, n, inside) +
                       sweep_velocity(s, x, y, z - 1, n, inside) + sweep_velocity(s, x, y, z + 1, n, inside);
    return diffused_velocity(sweep_velocity_centre(s, cell(x, y, z, n)), sum, a);
}

// diffuse_density_at (an interior cell) on the sweep's inputs.
INLINE float sweep_density_at(const Sweep* s, int x, int y, int z, int4 n, float a) {
    const float sum = sweep_density(s, cell(x - 1, y, z, n)) + sweep_density(s, cell(x + 1, y, z, n)) +
                      sweep_density(s, cell(x, y - 1, z, n)) + sweep_density(s, cell(x, y + 1, z, n)) +
                      sweep_density(s, cell(x, y, z - 1, n)) + sweep_density(s, cell(x, y, z + 1, n));
    return diffused_density(sweep_density_centre(s, cell(x, y, z, n)), sum, a);
}

// A sweep's value at wall cell c (a wall item): SetBoundaryDensity's and SetBoundaryVelocity's rules on this sweep's
// values of the cells they read, as DiffuseDensity's and DiffuseVelocity's wall items.
INLINE void sweep_wall(const Sweep* s, const int c[3], int4 n, float a_v, float a_d, int velocity,
                       __global float4* velocity_out, __global float* density_out) {
    int in[3], f[3];
    const int walls = inner_cell(c, n, in), id = cell_of(c, n);
    density_out[id] = wall_copy(walls, sweep_density_at(s, in[0], in[1], in[2], n, a_d));
    if (!velocity) return;
    const float4 inner = sweep_velocity_at(s, in[0], in[1], in[2], n, a_v, true);
    float4 face[3] = {(float4)(0.0f), (float4)(0.0f), (float4)(0.0f)};
    for (int axis = 0; axis < 3; axis++) {
        if (c[axis] == in[axis]) continue;
        face_cell(c, in, axis, f);
        face[axis] = face_velocity(axis, sweep_velocity_at(s, f[0], f[1], f[2], n, a_v, false), inner);
    }
    velocity_out[id] = wall_velocity(c, in, walls, face);
}

// One sweep of DiffuseVelocity (with velocity = 1; 0 in density_only mode) and DiffuseDensity together (the two
// fields do not meet before the advections); with add_source the step's first, which also does AddSourceVelocity and
// AddSourceDensity; source_on: their terms stand in for prev.xyz and prev.w. +B(Velocity), +B(Density).
__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, THREAD_Z)))
void DiffuseFields(const __global float4* velocity_in, __global float4* velocity_out, const __global float* density_in,
                   __global float* density_out, const __global float4* source, const __global float* prev_x,
                   const __global float* prev_y, const __global float* prev_z, const __global float* prev_w, int w,
                   int h, int d, float dt, float visc, float diff, float velocity_coef, float density_coef,
                   int velocity, int source_on, int add_source) {
    const int4 n = (int4)(w, h, d, 0);
    const float a_v = dt * visc * (float)w * (float)h * (float)d;  // DiffuseVelocity's a
    const float a_d = dt * diff * (float)w * (float)h * (float)d;  // DiffuseDensity's a
    const Sweep s = {velocity_in, density_in, source, prev_x, prev_y, prev_z, prev_w,
                     velocity_coef, density_coef, dt, source_on, add_source};
    int c[3] = {get_global_id(0), get_global_id(1), get_global_id(2)};
    if (is_wall_group(d)) {  // SetBoundaryDensity and SetBoundaryVelocity, as DiffuseDensity's and DiffuseVelocity's
        if (wall_item(n, c)) sweep_wall(&s, c, n, a_v, a_d, velocity, velocity_out, density_out);
        return;
    }
    if (!is_interior(c[0], c[1], c[2], n)) return;  // padding, or a wall cell (a wall item sets it)
    const int id = cell_of(c, n);
    density_out[id] = sweep_density_at(&s, c[0], c[1], c[2], n, a_d);
    if (velocity) velocity_out[id] = sweep_velocity_at(&s, c[0], c[1], c[2], n, a_v, true);
}

// DiffuseFields in strips (what step() runs, Simulation.diffuse_kernel): one work-item sweeps the interior cells of a
// column of FIELD_ROWS cells along z at (x, y), keeping the sweep's inputs (velocity, density; with add_source the
// source's terms added) of the planes below and above in registers: of a cell's 6 neighbours 4 come from the cache
// and one from memory, in work-groups whose rows of x read whole lines (the book's 8 x 8 x 4 groups read single
// floats poorly). The walls are set by work-groups past the strips', as DiffuseFields' (sweep_wall). The same sums in
// the same order: DiffuseFields' values bit for bit. Global size (w, h, ceil(d / FIELD_ROWS)) + the wall groups.
#ifndef FIELD_ROWS
#error "build with -D FIELD_ROWS=<cells per strip along z> (the host's FIELD_ROWS)"
#endif
__kernel void DiffuseFieldsRows(const __global float4* velocity_in, __global float4* velocity_out,
                                const __global float* density_in, __global float* density_out,
                                const __global float4* source, const __global float* prev_x,
                                const __global float* prev_y, const __global float* prev_z,
                                const __global float* prev_w, int w, int h, int d, float dt, float visc, float diff,
                                float velocity_coef, float density_coef, int velocity, int source_on, int add_source) {
    const int4 n = (int4)(w, h, d, 0);
    const float a_v = dt * visc * (float)w * (float)h * (float)d;  // DiffuseVelocity's a
    const float a_d = dt * diff * (float)w * (float)h * (float)d;  // DiffuseDensity's a
    const Sweep s = {velocity_in, density_in, source, prev_x, prev_y, prev_z, prev_w,
                     velocity_coef, density_coef, dt, source_on, add_source};
    const int strips = (d + FIELD_ROWS - 1) / FIELD_ROWS;
    int c[3] = {get_global_id(0), get_global_id(1), get_global_id(2)};
    if (is_wall_group(strips)) {
        if (wall_item_past(n, c, strips)) sweep_wall(&s, c, n, a_v, a_d, velocity, velocity_out, density_out);
        return;
    }
    const int x = c[0], y = c[1];
    const int r0 = max(FIELD_ROWS * c[2], 1), r1 = min(FIELD_ROWS * (c[2] + 1), d - 1) - 1;  // its interior planes
    if (!is_interior(x, y, r0, n)) return;  // padding, or a wall column (wall items set it)
    const int plane = w * h;
    int i = cell(x, y, r0, n);
    float4 v_below = (float4)(0.0f), v_mid = (float4)(0.0f);
    if (velocity) {
        v_below = sweep_velocity(&s, x, y, r0 - 1, n, true);
        v_mid = sweep_velocity(&s, x, y, r0, n, true);
    }
    float d_below = sweep_density(&s, i - plane), d_mid = sweep_density(&s, i);
    for (int r = r0; r <= r1; r++, i += plane) {
        // sweep_density_at's and sweep_velocity_at's order: x-1, x+1, y-1, y+1, z-1, z+1
        const float d_above = sweep_density(&s, i + plane);
        const float d_sum = sweep_density(&s, i - 1) + sweep_density(&s, i + 1) + sweep_density(&s, i - w) +
                            sweep_density(&s, i + w) + d_below + d_above;
        density_out[i] = diffused_density(sweep_density_centre(&s, i), d_sum, a_d);
        d_below = d_mid;
        d_mid = d_above;
        if (velocity) {
            const float4 v_above = sweep_velocity(&s, x, y, r + 1, n, true);
            const float4 v_sum = sweep_velocity(&s, x - 1, y, r, n, true) + sweep_velocity(&s, x + 1, y, r, n, true) +
                                 sweep_velocity(&s, x, y - 1, r, n, true) + sweep_velocity(&s, x, y + 1, r, n, true) +
                                 v_below + v_above;
            velocity_out[i] = diffused_velocity(sweep_velocity_centre(&s, i), v_sum, a_v);
            v_below = v_mid;
            v_mid = v_above;
        }
    }
}

// SwapVelocity + AdvectVelocity: the book copies the velocity into prev.xyz and advects the copy; this advects the
// velocity itself (the same values) into the pair's other buffer, and keeps of the copy what the step leaves in
// prev: its z (the second projection puts p and div into prev.xy). +B(Velocity)
__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, THREAD_Z)))
void SwapAdvectVelocity(const __global float4* velocity_in, __global float4* velocity_out, __global float* prev_z,
                        int w, int h, int d, float dt) {
    const int id = advect_velocity(velocity_in, velocity_out, (int4)(w, h, d, 0), dt);
    if (id >= 0) prev_z[id] = velocity_in[id].z;
}

// SwapDensity + AdvectDensity (AdvectDensityFromExt with the source as carrier): the book copies the density into
// prev.w and advects the copy; this advects the density itself into the pair's other buffer, and the host keeps the
// buffer it read as prev's w (no copy made). +B(Density)
__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, THREAD_Z)))
void SwapAdvectDensity(const __global float4* carrier, const __global float* density_in, __global float* density_out,
                       int w, int h, int d, float dt) {
    advect_density(carrier, 0, density_in, density_out, (int4)(w, h, d, 0), dt);
}

#endif

// }}}

__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, THREAD_Z)))
void Draw(const __global float4* velocity, const __global float* density, __global float4* solver, int w,
          int h, int d) {
    CELL_OR_RETURN(w, h, d)
    solver[id] = (float4)(velocity[id].xyz, density[id]);
}

// Not in the book: what the ray-marching view samples, 2 bytes a cell where Draw's solver has 16, so that a frame
// moves 8x fewer bytes to the host and to GL. volume = the shown field (0: density, 1: speed |(u, v, w)|) as half
// floats (vstore_half, rounded to nearest; clamped to half's range, where a float beyond it would turn inf); maxima =
// the largest density and speed of the grid (Draw's values: solver.w and |solver.xyz|), as ordered_int(), reduced
// in the work-group and then by one atomic_max per group (the host fills maxima with INT_MIN before the launch).
#define GROUP_SIZE (THREAD_X * THREAD_Y * THREAD_Z)
#define HALF_MAX 65504.0f

__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, THREAD_Z)))
void DrawVolume(const __global float4* velocity, const __global float* density, __global half* volume,
                volatile __global int* maxima, int field, int w, int h, int d) {
    __local int top_density[GROUP_SIZE], top_speed[GROUP_SIZE];
    const int x = get_global_id(0), y = get_global_id(1), z = get_global_id(2);
    const int l = (get_local_id(2) * THREAD_Y + get_local_id(1)) * THREAD_X + get_local_id(0);
    top_density[l] = top_speed[l] = INT_MIN;  // padding items of the rounded-up global size keep these
    if (x < w && y < h && z < d) {
        const int id = cell(x, y, z, (int4)(w, h, d, 0));
        const float4 v = velocity[id];
        const float rho = density[id], speed = sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
        vstore_half(clamp(field == 0 ? rho : speed, -HALF_MAX, HALF_MAX), id, volume);
        top_density[l] = ordered_int(rho);
        top_speed[l] = ordered_int(speed);
    }
    for (int s = 1; s < GROUP_SIZE; s *= 2) {  // item l takes l + s's maximum while l is a multiple of 2s
        barrier(CLK_LOCAL_MEM_FENCE);
        if (l % (2 * s) == 0 && l + s < GROUP_SIZE) {
            top_density[l] = max(top_density[l], top_density[l + s]);
            top_speed[l] = max(top_speed[l], top_speed[l + s]);
        }
    }
    if (l == 0) {  // the last round's write is its own
        atomic_max(&maxima[0], top_density[0]);
        atomic_max(&maxima[1], top_speed[0]);
    }
}

// {{{ the other boundary rules on their own (Simulation.set_boundary_*; the kernels above apply them in step())

// One work-item per wall cell for each (global >= w*h*d - (w-2)(h-2)(d-2)).
__kernel void SetBoundaryDensity(__global float* density, int w, int h, int d) {
    set_boundary_copy(density, 1, 0, (int4)(w, h, d, 0));
}

// the divergence: prev.y (stride 4), or fixed's divergence field (stride 1) during a solve.
__kernel void SetBoundaryDiv(__global float* div, int stride, int w, int h, int d) {
    set_boundary_copy(div, stride, stride > 1 ? 1 : 0, (int4)(w, h, d, 0));
}

// p, every `stride`-th float of `p` (prev.x: 4; fixed's pressure field during a solve: 1).
__kernel void SetBoundaryP(__global float* p, int stride, int w, int h, int d) {
    set_boundary_copy(p, stride, 0, (int4)(w, h, d, 0));
}

// }}}

// {{{ the view's smoke (not in the book): RayMarchSmoke

// viewer/shaders/stable_fluids_3d.frag's smoke display, one work-item per pixel of a width x height picture: a ray
// from the eye through the pixel's centre, the box's entry and exit, half-cell steps front to back with
// alpha = 1 - exp(-k value ds), one shadow ray towards the light per sample of smoke (density) or the heat ramp
// (speed), an early exit once 99 % opaque; the same steps, constants and order as the shader. Why on the device: a
// frame then moves the picture to GL (3.7 MB at 1280x720) instead of the half-float volume (32 MB at 256^3), and the
// march runs on the whole GPU, where a compute GPU gives its graphics pipeline a few of its multiprocessors. The
// field is read from the solver's own fields, filtered as GL's linear filter reads the shader's texture (texel
// centres at (i + 0.5) / n, taps clamped to the edge); the speed display scales by DrawVolume's max speed, read
// from maxima on the device. Output: premultiplied RGBA8, row 0 the bottom row (GL's order).
#define SMOKE_MAX_STEPS 1024
#define SMOKE_SHADOW_STEPS 8
#define SMOKE_ALBEDO 0.95f
#define SMOKE_AMBIENT 0.55f

// The shown field at cell index id: its density (field 0) or its speed |(u, v, w)| (field 1), as DrawVolume writes.
INLINE float shown_value(const __global float4* velocity, const __global float* density, int field, int id) {
    if (field == 0) return density[id];
    const float4 v = velocity[id];
    return sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
}

// GL's linear filter (clamp to edge) of the shown field at texture coordinate uvw ([0, 1] across the grid). The
// texel coordinates (cell i's centre at i) are clamped to [-1, n - 1], which changes no value (beyond, both taps are
// the edge cell) and keeps every tap in the grid.
INLINE float filtered(const __global float4* velocity, const __global float* density, int field, float3 uvw,
                      int4 n) {
    const float3 size = convert_float3(n.xyz);
    const float3 c = clamp(uvw * size - 0.5f, (float3)(-1.0f), size - 1.0f);
    const float3 c0 = floor(c), f = c - c0;
    const int x = (int)c0.x, y = (int)c0.y, z = (int)c0.z;
    const int x0 = max(x, 0), y0 = max(y, 0), z0 = max(z, 0);
    const int i = cell(x0, y0, z0, n);  // the lower tap; the upper one cell on, or the same at the grid's edge
    const int dx = min(x + 1, n.x - 1) - x0, dy = (min(y + 1, n.y - 1) - y0) * n.x;
    const int dz = (min(z + 1, n.z - 1) - z0) * n.x * n.y;
#define TAP(offset) shown_value(velocity, density, field, i + (offset))
    const float v00 = mix(TAP(0), TAP(dx), f.x), v10 = mix(TAP(dy), TAP(dy + dx), f.x);
    const float v01 = mix(TAP(dz), TAP(dz + dx), f.x), v11 = mix(TAP(dz + dy), TAP(dz + dy + dx), f.x);
#undef TAP
    return mix(mix(v00, v10, f.y), mix(v01, v11, f.y), f.z);
}

// Black-body-like ramp for speeds: blue -> red -> yellow -> white (the shader's heat()).
INLINE float3 heat(float t) {
    t = clamp(t, 0.0f, 1.0f);
    const float blue = 0.6f - 1.5f * fabs(t - 0.25f) + 2.0f * max(t - 0.75f, 0.0f);
    return clamp((float3)(3.0f * t - 0.6f, 3.0f * t - 1.6f, blue), 0.0f, 1.0f);
}

// A row-major 4x4 matrix times (v, 1).
INLINE float4 transform(float16 m, float3 v) {
    const float4 p = (float4)(v, 1.0f);
    return (float4)(dot(m.s0123, p), dot(m.s4567, p), dot(m.s89ab, p), dot(m.scdef, p));
}

__kernel void RayMarchSmoke(const __global float4* velocity, const __global float* density,
                            const __global int* maxima, __global uchar4* image, int field, int width, int height,
                            float16 inv_view_proj, float4 eye, float4 light_dir, float absorption, int w, int h,
                            int d) {
    const int px = get_global_id(0), py = get_global_id(1);
    if (px >= width || py >= height) return;  // padding work-items of the rounded-up global size
    const int4 n = (int4)(w, h, d, 0);
    const float3 box = convert_float3(n.xyz) / (float)max(w, max(h, d));  // world size: cubic cells, largest edge 1
    const float box_length = max(box.x, max(box.y, box.z));
    const float ds = 0.5f / (float)max(w, max(h, d));  // half a cell
    // the pixel centre's ray (the shader's v_ndc), from the eye
    const float2 ndc = (float2)(((float)px + 0.5f) / (float)width, ((float)py + 0.5f) / (float)height) * 2.0f - 1.0f;
    const float4 near = transform(inv_view_proj, (float3)(ndc, -1.0f));
    const float4 far = transform(inv_view_proj, (float3)(ndc, 1.0f));
    const float3 dir = normalize(far.xyz / far.w - near.xyz / near.w), o = eye.xyz;
    // entry and exit distances through the box (no division by an exact 0)
    const float3 inv = 1.0f / select(dir, (float3)(1e-8f), isless(fabs(dir), (float3)(1e-8f)));
    const float3 t0 = (-0.5f * box - o) * inv, t1 = (0.5f * box - o) * inv;
    const float3 lo = fmin(t0, t1), hi = fmax(t0, t1);
    const float t_near = max(max(lo.x, lo.y), max(lo.z, 0.0f)), t_far = min(min(hi.x, hi.y), hi.z);
    uchar4 out = (uchar4)(0);
    if (t_far > t_near) {  // a hit (false for NaN too)
        float value_scale = 1.0f;  // speed: 1 / the max speed, so that the fastest cell reads 1
        if (field == 1) {
            const int bits = maxima[1];
            const float top = ordered_float(bits);
            if (top > 0.0f) value_scale = 1.0f / top;
        }
        const float k = absorption / box_length;  // extinction per unit value per world unit
        const float shadow_step = 0.5f * box_length / (float)SMOKE_SHADOW_STEPS;
        float3 color = (float3)(0.0f);
        float transmittance = 1.0f;
        const int steps = min((int)ceil((t_far - t_near) / ds), SMOKE_MAX_STEPS);
        for (int i = 0; i < steps; i++) {
            const float3 p = o + (t_near + ((float)i + 0.5f) * ds) * dir;
            const float value = filtered(velocity, density, field, p / box + 0.5f, n) * value_scale;
            if (value <= 1e-5f) continue;  // empty space: nothing to absorb or light
            const float alpha = 1.0f - exp(-k * value * ds);
            float3 albedo = (float3)(SMOKE_ALBEDO);
            float light = 1.0f;
            if (field == 0) {  // one shadow ray: how much smoke lies between p and the light
                float depth = 0.0f;
                for (int j = 1; j <= SMOKE_SHADOW_STEPS; j++) {
                    const float3 q = p + (float)j * shadow_step * light_dir.xyz;
                    if (any(isgreater(fabs(q), 0.5f * box))) break;
                    depth += filtered(velocity, density, field, q / box + 0.5f, n) * shadow_step;
                }
                light = SMOKE_AMBIENT + (1.0f - SMOKE_AMBIENT) * exp(-k * depth);
            } else {
                albedo = heat(value);
            }
            color += transmittance * alpha * albedo * light;
            transmittance *= 1.0f - alpha;
            if (transmittance < 0.01f) break;  // opaque enough: what lies behind cannot show
        }
        out = convert_uchar4_sat_rte((float4)(color, 1.0f - transmittance) * 255.0f);
    }
    image[py * width + px] = out;
}

// }}}
