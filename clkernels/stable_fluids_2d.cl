// stable_fluids_2d.cl: Unity Graphics Programming vol.1 ch.4, "Fluid simulation by lattice method" (the 2D solver;
// docs/chapters/04-stable-fluids-2d.md). Jos Stam, "Stable Fluids", SIGGRAPH 1999: implicit diffusion, projection,
// semi-Lagrangian advection on a grid. The original is Assets/StableFluids/ComputeShaders/Solver2D.compute; vol.4
// ch.6 (Tessellation) drives a stripped copy of it, which is this file run without pressure sweeps and without
// AdvectVelocity (docs/chapters/17-tessellation.md).
//
// Fields: row-major w x h grids, cell (x, y) at index y*w + x, row y = 0 at the bottom (as the book's uv).
//   velocity float2 (u, v); density float; source float4 (velocity source xy, density source z);
//   solver float4 (u, v, density, 1) for the renderer;
//   prev float4, multiplexed as the book does: xy = velocity source or copy of velocity, z = density source or copy
//   of density; during the projection x = p and y = div (z kept: later kernels read the leftovers).
//   divergence, pressure float (fixed only): the projection's div and p, so a Jacobi sweep reads 8 bytes per cell
//   and writes 4 instead of reading and writing prev's 16; prev.xy ends as (p, div) all the same.
// Boundary rules (the book's SetBoundary* helpers): a wall cell copies its inner neighbour (the cell one step
//   inwards, clamp(x, 1, w-2), clamp(y, 1, h-2)); the velocity's wall cell negates the inner cell's normal component
//   and keeps its own tangential one; a corner is the mean of the two edge cells beside it. "+B(f)" below: the
//   kernel applies f's rule itself, as the book calls SetBoundary* at the end of each kernel, but without reading
//   cells other work-items write: extra work-groups past the grid's rows take one wall cell per work-item and
//   compute the kernel's value at the cells the rule reads (the inner cell, and for a velocity wall the cell itself
//   and, at a corner, the two edge cells beside it) from the kernel's inputs; the grid's groups compute the interior
//   (see wall_item). Every value is the one a sweep followed by an edges launch and a corners launch gives, bit for
//   bit.
// Kernels, in host call order per step, and in this file's order:
//   AddSourceBrush       -> source: f = clamp(1 - |(uv - c)/r|^2, 0, 1), source = (m.x*f, m.y*f, f, 0) (brush held)
//   velocity step (skipped when density_only):
//   AddSourceVelocity    velocity += s.xy*velocityCoef*dt, prev.xy = the same amount           (own cell, in place)
//   DiffuseVelocity      velocity_in, prev.xy -> velocity_out: one Jacobi sweep (host: gs_iterations times)
//                        +B(Velocity)
//   ProjectStep1         velocity -> prev = (0, div, prev.z, 0) (own cell of prev, in place) +B(Divergence); p = 0
//                        everywhere, so B(DivPositive) would change nothing; fixed: also divergence = div, pressure = 0
//   ProjectStep2         book: prev_in -> prev_out, fixed: pressure_in, divergence -> pressure_out: one Jacobi sweep
//                        of the Poisson equation for p +B(DivPositive)
//   ProjectStep2Rows     the same sweep (fixed, w % 4 == 0) in strips of 4 cells x ROWS rows: what GPUs run
//                        (Simulation.sweep_kernel), about 1.2x ProjectStep2's speed on an H100 at 4096^2
//   ProjectStep3         velocity -= 0.5*(p(+1) - p(-1))*(w | h) per axis (own cell, in place); fixed: prev.x = p
//   SetBoundaryVelocity  after ProjectStep3 (in place: its walls would read cells other work-items write)
//   SwapVelocity         prev.xy = velocity (a one-way copy despite the name, as the book)
//   AdvectVelocity       prev.xy -> velocity: back-trace by the cell's own prev.xy, bilinear +B(Velocity)
//   ProjectStep1..3, SetBoundaryVelocity again
//   density step:
//   AddSourceDensity     density += s.z*densityCoef*dt, prev.z = the same amount               (own cell, in place)
//   DiffuseDensity       density_in, prev.z -> density_out: one Jacobi sweep (gs_iterations times) +B(Density)
//   SwapDensity          prev.z = density
//   AdvectDensity        velocity, prev.z -> density: back-trace by the current velocity, bilinear +B(Density)
//   AdvectDensityFromExt  source.xy, prev.z -> density: back-trace by the brush velocity (density_only) +B(Density)
//   Draw                 velocity, density -> solver = (u, v, density, 1)
//   DrawTexture          velocity, density -> texture, top: the view's copy (not in the book; runs when the view
//                        asks, Simulation.draw_texture): only the field its display mode shows, as half floats,
//                        and that field's largest magnitude
//   the rules on their own (Simulation.set_boundary_*; step() applies them inside the kernels above):
//   SetBoundaryDensity   density
//   SetBoundaryDivergence  prev.y (the divergence)
//   SetBoundaryDivPositive  p: prev.x, or fixed's pressure field between ProjectStep1 and ProjectStep3
//   The SetBoundary* kernels are one launch of 2*(w-2) + 2*(h-2) + 4 work-items (edges, then corners): an edge
//   reads its inner cell, a corner the interior cell both its edge neighbours copy, and SetBoundaryVelocity's edges
//   write only their normal component while its corners read only the edges' tangential ones (float pointers, so no
//   byte is read while another work-item writes it).
// Build defines: THREAD_X, THREAD_Y = work-group shape of the grid kernels (book: numthreads(32, 32, 1)); ROWS = rows
//   of a ProjectStep2Rows strip (fixed only);
//   BOOK_VARIANT = 1: the original's divergence -0.5*du/w + dv/h (operator precedence) and a back-trace that is
//   never clamped (its clamp() discards the result); 0: Stam's -0.5*(du/w + dv/h), back-trace clamped to
//   [0.5, n - 1.5], the pressure solve in the float divergence and pressure fields. The original's divergence
//   corner (0, h-1) reads (1, h-2) instead of (1, h-1) (a typo); the rule here reads (1, h-2), which (1, h-1)
//   copies, so the typo changes no value in either variant.
// Differences from the book: one Jacobi sweep per launch from a read buffer into a write buffer (the book's in-place
// Gauss-Seidel races), boundary values computed from the kernel's inputs (the book's in-kernel SetBoundary* calls
// read neighbours other work-items are writing), global sizes rounded up to the work-group shape and guarded (the
// book drops partial groups), every read that may fall outside the grid through ld*() (zero there, as D3D's
// out-of-range texture reads), float32 fields. Grids must be at least 3 x 3 (the boundary rules need an interior).

#ifndef THREAD_X
#error "build with -D THREAD_X=<work-group x> -D THREAD_Y=<work-group y> (book: 32, 32)"
#endif
#ifndef THREAD_Y
#error "build with -D THREAD_Y=<work-group y> (book: 32)"
#endif
#ifndef BOOK_VARIANT
#error "build with -D BOOK_VARIANT=1 (the original's arithmetic) or 0 (Stam's equations)"
#endif

// Helpers are always inlined: PoCL keeps a large helper that is called twice as a call per work-item.
#define INLINE inline __attribute__((always_inline))

// One work-item per cell; padding items of the rounded-up global size leave at once (no kernel has a barrier).
#define CELL_OR_RETURN(w, h)              \
    const int x = get_global_id(0);       \
    const int y = get_global_id(1);       \
    if (x >= (w) || y >= (h)) return;     \
    const int i = y * (w) + x;

// {{{ neighbour reads: D3D returns 0 for a texture read outside the grid; OpenCL has no bounds check. `inside` (a
// literal at every call) says that (x, y) is known to lie in the grid (a neighbour of an interior cell): then the
// test is folded away and the read is a plain load.

INLINE float ld1(const __global float* f, int x, int y, int w, int h, bool inside) {
    return (inside || (x >= 0 && x < w && y >= 0 && y < h)) ? f[y * w + x] : 0.0f;
}

INLINE float2 ld2(const __global float2* f, int x, int y, int w, int h, bool inside) {
    return (inside || (x >= 0 && x < w && y >= 0 && y < h)) ? f[y * w + x] : (float2)(0.0f);
}

INLINE float4 ld4(const __global float4* f, int x, int y, int w, int h, bool inside) {
    return (inside || (x >= 0 && x < w && y >= 0 && y < h)) ? f[y * w + x] : (float4)(0.0f);
}

// }}}

// {{{ the boundary rules (the book's SetBoundary* helpers), shared by the kernels that apply them

// The cell a wall cell copies: one step inwards on each axis where (x, y) is on a wall; (x, y) itself inside.
INLINE int2 inner_cell(int x, int y, int w, int h) { return (int2)(clamp(x, 1, w - 2), clamp(y, 1, h - 2)); }

INLINE bool is_corner(int x, int y, int2 in) { return x != in.x && y != in.y; }

// 1 <= x <= w-2 and 1 <= y <= h-2, in two unsigned comparisons (padding work-items fail it too).
INLINE bool is_interior(int x, int y, int w, int h) {
    return (uint)(x - 1) < (uint)(w - 2) && (uint)(y - 1) < (uint)(h - 2);
}

// SetBoundaryDensity / Divergence / DivPositive at (x, y), `v` = the value of its inner cell: a wall cell copies v;
// a corner is the mean of the two edge cells beside it, which both copy v (the sum and the halving as the book's).
INLINE float wall_copy(int x, int y, int2 in, float v) { return is_corner(x, y, in) ? 0.5f * (v + v) : v; }

// SetBoundaryVelocity at a wall cell (x, y): own = its value, inner = its inner cell's, row_x = the x component of the
// edge cell (in.x, y) beside a corner, column_y = the y component of the edge cell (x, in.y) (both unused off corners).
INLINE float2 wall_velocity(int x, int y, int2 in, float2 own, float2 inner, float row_x, float column_y) {
    if (y == in.y) return (float2)(-inner.x, own.y);  // left or right wall: the normal (x) component mirrored
    if (x == in.x) return (float2)(own.x, -inner.y);  // bottom or top wall: the normal (y) component mirrored
    // a corner: the mean of the row's edge cell (row_x, -inner.y) and the column's (-inner.x, column_y)
    return 0.5f * ((float2)(row_x, -inner.y) + (float2)(-inner.x, column_y));
}

// Wall cell k -> (x, y): the left column, right column, bottom row and top row without their ends (2(h-2) + 2(w-2)
// edge cells), then the corners (0,0), (0,h-1), (w-1,0), (w-1,h-1). 0 past the last.
INLINE int boundary_cell(int k, int w, int h, int* x, int* y) {
    const int rows = h - 2, cols = w - 2;
    if (k < rows) { *x = 0; *y = k + 1; return 1; }
    k -= rows;
    if (k < rows) { *x = w - 1; *y = k + 1; return 1; }
    k -= rows;
    if (k < cols) { *x = k + 1; *y = 0; return 1; }
    k -= cols;
    if (k < cols) { *x = k + 1; *y = h - 1; return 1; }
    k -= cols;
    if (k < 4) { *x = (k < 2) ? 0 : w - 1; *y = (k % 2 == 0) ? 0 : h - 1; return 1; }
    return 0;
}

// The kernels that set walls themselves (+B in the header) are launched with extra rows of work-groups past the
// grid's (Simulation._configure: as many as the 2(w-2) + 2(h-2) + 4 wall cells fill): the grid's groups compute the
// interior cells and leave the walls alone; work-item k of the extra groups, counted group by group, sets wall cell
// k, and groups past the last wall cell leave at once. A group thus runs one branch for all its work-items, and the
// interior's neighbour reads need no bounds test: PoCL runs those groups as fast as a kernel without walls.
INLINE bool is_wall_group(int h) { return get_group_id(1) * get_local_size(1) >= h; }

INLINE int wall_item(int w, int h, int* x, int* y) {
    const int size = get_local_size(0) * get_local_size(1);
    const int grid_rows = (h + get_local_size(1) - 1) / get_local_size(1);  // the grid's rows of groups
    const int group = (get_group_id(1) - grid_rows) * get_num_groups(0) + get_group_id(0);
    if (group * size >= 2 * w + 2 * h - 4) return 0;  // a group past the last wall cell: all its work-items leave
    return boundary_cell(group * size + get_local_id(1) * get_local_size(0) + get_local_id(0), w, h, x, y);
}

// The copy rule on one float per cell, `stride` floats apart from `offset` (density: 1, 0; prev.x: 4, 0; prev.y: 4, 1),
// one work-item per wall cell. Every work-item reads only an interior cell and writes only its own wall cell.
INLINE void set_boundary_copy(__global float* f, int stride, int offset, int w, int h) {
    int x, y;
    if (!boundary_cell(get_global_id(0), w, h, &x, &y)) return;  // padding of the rounded-up global size
    const int2 in = inner_cell(x, y, w, h);
    f[(y * w + x) * stride + offset] = wall_copy(x, y, in, f[(in.y * w + in.x) * stride + offset]);
}

// }}}

// {{{ back-trace (AdvectVelocity, AdvectDensity): the point a cell's content came from, in cells

INLINE float2 back_trace(int x, int y, float2 velocity, float dfdt, int w, int h) {
    float2 b = (float2)((float)x - dfdt * velocity.x, (float)y - dfdt * velocity.y);
#if BOOK_VARIANT
    // The book calls clamp(x, 0.5, w + 0.5) and drops the result: the back-trace may leave the grid and the
    // bilinear reads there return 0. Clamping to [-2, n + 1] gives the same zeros (both taps stay outside) and keeps
    // floor() within int range for any velocity.
    b = clamp(b, (float2)(-2.0f), (float2)((float)w + 1.0f, (float)h + 1.0f));
#else
    // Stam: stay inside the grid, half a cell away from the boundary cells' centres.
    b = clamp(b, (float2)(0.5f), (float2)((float)w - 1.5f, (float)h - 1.5f));
#endif
    return b;
}

// Bilinear interpolation of prev.xy and of prev.z at the back-traced point b. Stam's clamp keeps the 4 taps in the
// grid (floor(b) in [0, n-2]); the book's back-trace may leave it, and its taps outside read 0.
#define TAPS_INSIDE (!BOOK_VARIANT)

INLINE float2 bilinear_xy(const __global float4* prev, float2 b, int w, int h) {
    const int x0 = (int)floor(b.x), y0 = (int)floor(b.y);
    const float s1 = b.x - (float)x0, s0 = 1.0f - s1;
    const float t1 = b.y - (float)y0, t0 = 1.0f - t1;
    const bool in = TAPS_INSIDE;
    return s0 * (t0 * ld4(prev, x0, y0, w, h, in).xy + t1 * ld4(prev, x0, y0 + 1, w, h, in).xy) +
           s1 * (t0 * ld4(prev, x0 + 1, y0, w, h, in).xy + t1 * ld4(prev, x0 + 1, y0 + 1, w, h, in).xy);
}

INLINE float bilinear_z(const __global float4* prev, float2 b, int w, int h) {
    const int x0 = (int)floor(b.x), y0 = (int)floor(b.y);
    const float s1 = b.x - (float)x0, s0 = 1.0f - s1;
    const float t1 = b.y - (float)y0, t0 = 1.0f - t1;
    const bool in = TAPS_INSIDE;
    return s0 * (t0 * ld4(prev, x0, y0, w, h, in).z + t1 * ld4(prev, x0, y0 + 1, w, h, in).z) +
           s1 * (t0 * ld4(prev, x0 + 1, y0, w, h, in).z + t1 * ld4(prev, x0 + 1, y0 + 1, w, h, in).z);
}

// }}}

// 0. The brush (the original blits Shaders/AddSource.shader into `source` while the mouse button is held).
// center = brush centre in uv (bottom-left origin), move = mouse delta in pixels (length <= mouse clamp),
// radius in uv units on both axes, so the brush is an ellipse on a non-square grid, as the original's.
__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, 1)))
void AddSourceBrush(__global float4* source, int w, int h, float2 center, float2 move, float radius) {
    CELL_OR_RETURN(w, h)
    const float2 uv = (float2)(((float)x + 0.5f) / (float)w, ((float)y + 0.5f) / (float)h);
    const float2 q = (uv - center) / radius;
    const float f = clamp(1.0f - dot(q, q), 0.0f, 1.0f);  // parabolic fall-off, 1 at the centre, 0 at radius
    source[i] = (float4)(move.x * f, move.y * f, f, 0.0f);
}

// {{{ velocity step

// 1. External force term: velocity += source.xy*velocityCoef*dt; prev.xy remembers that amount (diffusion reads it).
__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, 1)))
void AddSourceVelocity(__global float2* velocity, __global float4* prev, const __global float4* source,
                       int w, int h, float velocity_coef, float dt) {
    CELL_OR_RETURN(w, h)
    const float2 s = source[i].xy * velocity_coef * dt;
    velocity[i] += s;
    prev[i] = (float4)(s, prev[i].z, 0.0f);
}

// 2. Viscosity, one Jacobi sweep of (1 + 4a) v = prev.xy + a * (sum of the 4 neighbours), a = dt*visc*w*h.
INLINE float2 diffuse_velocity_at(const __global float2* velocity_in, const __global float4* prev, int x, int y, int w,
                                  int h, float a, bool inside) {
    const float2 sum = ld2(velocity_in, x - 1, y, w, h, inside) + ld2(velocity_in, x + 1, y, w, h, inside) +
                       ld2(velocity_in, x, y - 1, w, h, inside) + ld2(velocity_in, x, y + 1, w, h, inside);
    return (prev[y * w + x].xy + a * sum) / (1.0f + 4.0f * a);
}

__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, 1)))
void DiffuseVelocity(const __global float2* velocity_in, __global float2* velocity_out,
                     const __global float4* prev, int w, int h, float a) {
    int x = get_global_id(0), y = get_global_id(1);
    if (is_wall_group(h)) {  // SetBoundaryVelocity from this sweep's values of the cells the rule reads
        if (!wall_item(w, h, &x, &y)) return;
        const int2 in = inner_cell(x, y, w, h);
        const bool corner = is_corner(x, y, in);
        velocity_out[y * w + x] =
            wall_velocity(x, y, in, diffuse_velocity_at(velocity_in, prev, x, y, w, h, a, false),
                          diffuse_velocity_at(velocity_in, prev, in.x, in.y, w, h, a, true),
                          corner ? diffuse_velocity_at(velocity_in, prev, in.x, y, w, h, a, false).x : 0.0f,
                          corner ? diffuse_velocity_at(velocity_in, prev, x, in.y, w, h, a, false).y : 0.0f);
        return;
    }
    if (!is_interior(x, y, w, h)) return;  // padding, or a wall cell (a wall item sets it)
    velocity_out[y * w + x] = diffuse_velocity_at(velocity_in, prev, x, y, w, h, a, true);
}

// 3. Projection step 1: the divergence of the velocity into prev.y (walls: the inner cell's, SetBoundaryDivergence),
// p = prev.x starts at 0 (everywhere, so SetBoundaryDivPositive has nothing to change), prev.z kept.
INLINE float divergence_at(const __global float2* velocity, int x, int y, int w, int h) {
    const float du = velocity[y * w + x + 1].x - velocity[y * w + x - 1].x;  // (x, y) is interior: all 4 exist
    const float dv = velocity[(y + 1) * w + x].y - velocity[(y - 1) * w + x].y;
#if BOOK_VARIANT
    return -0.5f * (du / (float)w) + (dv / (float)h);  // the original's precedence: -0.5 on x only
#else
    return -0.5f * (du / (float)w + dv / (float)h);  // Stam: -0.5*h*(du + dv) with h = 1/n per axis
#endif
}

// fixed: the divergence and p = 0 also go to their own float fields, which the sweeps read (12 bytes per cell, not
// the 32 of a float4 read and write); ProjectStep3 writes the solved p back into prev.x.
__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, 1)))
#if BOOK_VARIANT
void ProjectStep1(const __global float2* velocity, __global float4* prev, int w, int h) {
#else
void ProjectStep1(const __global float2* velocity, __global float4* prev, __global float* divergence,
                  __global float* pressure, int w, int h) {
#endif
    int x = get_global_id(0), y = get_global_id(1);
    float div;
    if (is_wall_group(h)) {  // SetBoundaryDivergence: the divergence of the inner cell
        if (!wall_item(w, h, &x, &y)) return;
        const int2 in = inner_cell(x, y, w, h);
        div = wall_copy(x, y, in, divergence_at(velocity, in.x, in.y, w, h));
    } else {
        if (!is_interior(x, y, w, h)) return;  // padding, or a wall cell (a wall item sets it)
        div = divergence_at(velocity, x, y, w, h);
    }
    const int i = y * w + x;
    prev[i] = (float4)(0.0f, div, prev[i].z, 0.0f);
#if !BOOK_VARIANT
    divergence[i] = div;
    pressure[i] = 0.0f;
#endif
}

// 4. Projection step 2, one Jacobi sweep of the Poisson equation 4p - (sum of the 4 neighbours' p) = div; walls
// copy the inner cell's new p (SetBoundaryDivPositive). book: p = prev.x, div = prev.y; fixed: the float fields.
#if BOOK_VARIANT
INLINE float pressure_at(const __global float4* prev_in, int x, int y, int w) {
    const int i = y * w + x;  // an interior cell: all 4 neighbours exist
    const float sum = prev_in[i - 1].x + prev_in[i + 1].x + prev_in[i - w].x + prev_in[i + w].x;
    return (prev_in[i].y + sum) / 4.0f;
}
#else
INLINE float pressure_at(const __global float* pressure_in, const __global float* divergence, int x, int y, int w) {
    const int i = y * w + x;  // an interior cell: all 4 neighbours exist
    const float sum = pressure_in[i - 1] + pressure_in[i + 1] + pressure_in[i - w] + pressure_in[i + w];
    return (divergence[i] + sum) / 4.0f;  // the book's arithmetic on the same values: bit for bit its p
}
#endif

__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, 1)))
#if BOOK_VARIANT
void ProjectStep2(const __global float4* prev_in, __global float4* prev_out, int w, int h) {
#define PRESSURE_AT(x, y) pressure_at(prev_in, x, y, w)
#else
void ProjectStep2(const __global float* pressure_in, __global float* pressure_out, const __global float* divergence,
                  int w, int h) {
#define PRESSURE_AT(x, y) pressure_at(pressure_in, divergence, x, y, w)
#endif
    int x = get_global_id(0), y = get_global_id(1);
    float p;
    if (is_wall_group(h)) {  // SetBoundaryDivPositive: this sweep's p of the inner cell
        if (!wall_item(w, h, &x, &y)) return;
        const int2 in = inner_cell(x, y, w, h);
        p = wall_copy(x, y, in, PRESSURE_AT(in.x, in.y));
    } else {
        if (!is_interior(x, y, w, h)) return;  // padding, or a wall cell (a wall item sets it)
        p = PRESSURE_AT(x, y);
    }
    const int i = y * w + x;
#if BOOK_VARIANT
    prev_out[i] = (float4)(p, prev_in[i].yzw);
#else
    pressure_out[i] = p;
#endif
#undef PRESSURE_AT
}

// ProjectStep2 for GPUs (fixed, w % 4 == 0): one work-item sweeps a strip of 4 cells x ROWS rows, walls included,
// keeping the rows above and below in registers (a cell's p is loaded once per strip, not five times), with 16-byte
// loads and stores. Every value is ProjectStep2's, bit for bit: the same sum in the same order, the same wall rules.
// Global size (w / 4, ceil(h / ROWS)); no work-group shape is required.
#if !BOOK_VARIANT
#ifndef ROWS
#error "build with -D ROWS=<rows per strip> (the host's ROWS_PER_ITEM)"
#endif
__kernel void ProjectStep2Rows(const __global float* pressure_in, __global float* pressure_out,
                               const __global float* divergence, int w, int h) {
    const int x0 = 4 * get_global_id(0), y0 = ROWS * get_global_id(1);
    if (x0 >= w || y0 >= h) return;  // padding of the rounded-up global size
    const int y1 = min(y0 + ROWS, h) - 1;  // the strip's rows y0 .. y1; its walls copy rows 1 and h-2
    const int r0 = clamp(y0, 1, h - 2), r1 = clamp(y1, 1, h - 2);  // the interior rows it computes
    const bool left = x0 == 0, right = x0 + 4 == w;
    float4 below = vload4(0, pressure_in + (r0 - 1) * w + x0), mid = vload4(0, pressure_in + r0 * w + x0);
    for (int r = r0; r <= r1; r++) {
        const int i = r * w + x0;
        const float4 above = vload4(0, pressure_in + i + w);
        const float4 west = (float4)(left ? 0.0f : pressure_in[i - 1], mid.s012);
        const float4 east = (float4)(mid.s123, right ? 0.0f : pressure_in[i + 4]);
        float4 p = (vload4(0, divergence + i) + (west + east + below + above)) / 4.0f;  // pressure_at's order
        if (left) p.s0 = p.s1;   // SetBoundaryDivPositive: the left wall copies its inner cell
        if (right) p.s3 = p.s2;  // and the right wall
        if (r >= y0 && r <= y1) vstore4(p, 0, pressure_out + i);  // (rows 1 and h-2 may lie outside the strip)
        if (r == 1 && y0 == 0) {  // the bottom wall copies row 1; its corners are the mean of their two edge cells
            if (left) p.s0 = wall_copy(0, 0, (int2)(1, 1), p.s0);
            if (right) p.s3 = wall_copy(w - 1, 0, (int2)(w - 2, 1), p.s3);
            vstore4(p, 0, pressure_out + x0);
        }
        if (r == h - 2 && y1 == h - 1) {  // the top wall copies row h-2
            if (left) p.s0 = wall_copy(0, h - 1, (int2)(1, h - 2), p.s0);
            if (right) p.s3 = wall_copy(w - 1, h - 1, (int2)(w - 2, h - 2), p.s3);
            vstore4(p, 0, pressure_out + (h - 1) * w + x0);
        }
        below = mid;
        mid = above;
    }
}
#endif

// 5. Projection step 3: subtract the gradient of p (central differences, in cells scaled by the grid size). fixed:
// p from its float field, copied into prev.x, so prev holds (p, div) afterwards as the book's does.
__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, 1)))
#if BOOK_VARIANT
void ProjectStep3(__global float2* velocity, const __global float4* prev, int w, int h) {
    CELL_OR_RETURN(w, h)
    float2 v = velocity[i];
    v.x -= 0.5f * (ld4(prev, x + 1, y, w, h, false).x - ld4(prev, x - 1, y, w, h, false).x) * (float)w;
    v.y -= 0.5f * (ld4(prev, x, y + 1, w, h, false).x - ld4(prev, x, y - 1, w, h, false).x) * (float)h;
    velocity[i] = v;
}
#else
void ProjectStep3(__global float2* velocity, __global float4* prev, const __global float* pressure, int w, int h) {
    CELL_OR_RETURN(w, h)
    float2 v = velocity[i];
    v.x -= 0.5f * (ld1(pressure, x + 1, y, w, h, false) - ld1(pressure, x - 1, y, w, h, false)) * (float)w;
    v.y -= 0.5f * (ld1(pressure, x, y + 1, w, h, false) - ld1(pressure, x, y - 1, w, h, false)) * (float)h;
    velocity[i] = v;
    prev[i].x = pressure[i];
}
#endif

// Walls: the normal component is the negated inner one (no flow through the wall), the tangential one is kept
// (not Stam's copy of the inner tangential component: the book keeps the cell's own). Global >= 2(w-2) + 2(h-2) + 4.
// An edge writes only its normal component and a corner reads only the edges' tangential ones (float pointers).
__kernel void SetBoundaryVelocity(__global float2* velocity, int w, int h) {
    int x, y;
    if (!boundary_cell(get_global_id(0), w, h, &x, &y)) return;  // padding of the rounded-up global size
    __global float* f = (__global float*)velocity;  // cell j: u at f[2j], v at f[2j + 1]
    const int2 in = inner_cell(x, y, w, h);
    const int j = y * w + x, inner = in.y * w + in.x;
    if (y == in.y) {
        f[2 * j] = -f[2 * inner];  // left or right wall
    } else if (x == in.x) {
        f[2 * j + 1] = -f[2 * inner + 1];  // bottom or top wall
    } else {
        const float2 v = wall_velocity(x, y, in, (float2)(0.0f), (float2)(f[2 * inner], f[2 * inner + 1]),
                                       f[2 * (y * w + in.x)], f[2 * (in.y * w + x) + 1]);
        f[2 * j] = v.x;
        f[2 * j + 1] = v.y;
    }
}

// 6. prev.xy = velocity: the field AdvectVelocity carries along (the book's "swap" is this copy).
__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, 1)))
void SwapVelocity(const __global float2* velocity, __global float4* prev, int w, int h) {
    CELL_OR_RETURN(w, h)
    prev[i] = (float4)(velocity[i], prev[i].zw);
}

// 7. Advection term: back-trace by the cell's own (copied) velocity and interpolate prev.xy bilinearly.
INLINE float2 advect_velocity_at(const __global float4* prev, int x, int y, int w, int h, float dfdt) {
    return bilinear_xy(prev, back_trace(x, y, prev[y * w + x].xy, dfdt, w, h), w, h);
}

__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, 1)))
void AdvectVelocity(const __global float4* prev, __global float2* velocity, int w, int h, float dfdt) {
    int x = get_global_id(0), y = get_global_id(1);
    if (is_wall_group(h)) {  // SetBoundaryVelocity from the advected values of the cells the rule reads
        if (!wall_item(w, h, &x, &y)) return;
        const int2 in = inner_cell(x, y, w, h);
        const bool corner = is_corner(x, y, in);
        velocity[y * w + x] = wall_velocity(x, y, in, advect_velocity_at(prev, x, y, w, h, dfdt),
                                            advect_velocity_at(prev, in.x, in.y, w, h, dfdt),
                                            corner ? advect_velocity_at(prev, in.x, y, w, h, dfdt).x : 0.0f,
                                            corner ? advect_velocity_at(prev, x, in.y, w, h, dfdt).y : 0.0f);
        return;
    }
    if (!is_interior(x, y, w, h)) return;  // padding, or a wall cell (a wall item sets it)
    velocity[y * w + x] = advect_velocity_at(prev, x, y, w, h, dfdt);
}

// }}}

// {{{ density step

// 8. Source term S of the density: density += source.z*densityCoef*dt; prev.z remembers that amount.
__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, 1)))
void AddSourceDensity(__global float* density, __global float4* prev, const __global float4* source, int w,
                      int h, float density_coef, float dt) {
    CELL_OR_RETURN(w, h)
    const float s = source[i].z * density_coef * dt;
    density[i] += s;
    prev[i].z = s;
}

// 9. Diffusion, one Jacobi sweep of (1 + 4a) d = prev.z + a * (sum of the 4 neighbours), a = dt*diff*w*h; walls copy
// the inner cell's new value (SetBoundaryDensity).
INLINE float diffuse_density_at(const __global float* density_in, const __global float4* prev, int x, int y, int w,
                                float a) {
    const int i = y * w + x;  // an interior cell: all 4 neighbours exist
    const float sum = density_in[i - 1] + density_in[i + 1] + density_in[i - w] + density_in[i + w];
    return (prev[i].z + a * sum) / (1.0f + 4.0f * a);
}

__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, 1)))
void DiffuseDensity(const __global float* density_in, __global float* density_out,
                    const __global float4* prev, int w, int h, float a) {
    int x = get_global_id(0), y = get_global_id(1);
    float d;
    if (is_wall_group(h)) {  // SetBoundaryDensity: this sweep's value of the inner cell
        if (!wall_item(w, h, &x, &y)) return;
        const int2 in = inner_cell(x, y, w, h);
        d = wall_copy(x, y, in, diffuse_density_at(density_in, prev, in.x, in.y, w, a));
    } else {
        if (!is_interior(x, y, w, h)) return;  // padding, or a wall cell (a wall item sets it)
        d = diffuse_density_at(density_in, prev, x, y, w, a);
    }
    density_out[y * w + x] = d;
}

// 10. prev.z = density: the field AdvectDensity carries along.
__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, 1)))
void SwapDensity(const __global float* density, __global float4* prev, int w, int h) {
    CELL_OR_RETURN(w, h)
    prev[i].z = density[i];
}

// 11. Advection of the density by `carrier` (AdvectDensity: the current, projected velocity; AdvectDensityFromExt:
// the brush's source.xy, read as the first float2 of each float4: stride 2), prev.z sampled bilinearly; walls copy
// the inner cell's value (SetBoundaryDensity).
INLINE void advect_density(const __global float2* carrier, int stride, const __global float4* prev,
                           __global float* density, int w, int h, float dfdt) {
    int x = get_global_id(0), y = get_global_id(1);
    if (is_wall_group(h)) {
        if (!wall_item(w, h, &x, &y)) return;
        const int2 in = inner_cell(x, y, w, h);
        const float2 b = back_trace(in.x, in.y, carrier[(in.y * w + in.x) * stride], dfdt, w, h);
        density[y * w + x] = wall_copy(x, y, in, bilinear_z(prev, b, w, h));
        return;
    }
    if (!is_interior(x, y, w, h)) return;  // padding, or a wall cell (a wall item sets it)
    density[y * w + x] = bilinear_z(prev, back_trace(x, y, carrier[(y * w + x) * stride], dfdt, w, h), w, h);
}

__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, 1)))
void AdvectDensity(const __global float2* velocity, const __global float4* prev, __global float* density,
                   int w, int h, float dfdt) {
    advect_density(velocity, 1, prev, density, w, h, dfdt);
}

// 11'. density_only (book: isDensityOnly): advect by the brush's velocity instead of a simulated one.
__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, 1)))
void AdvectDensityFromExt(const __global float4* source, const __global float4* prev,
                          __global float* density, int w, int h, float dfdt) {
    advect_density((const __global float2*)source, 2, prev, density, w, h, dfdt);
}

// }}}

// 12. Output for the renderer (the original writes the RenderTexture the ink post effect samples).
__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, 1)))
void Draw(const __global float2* velocity, const __global float* density, __global float4* solver, int w, int h) {
    CELL_OR_RETURN(w, h)
    solver[i] = (float4)(velocity[i], density[i], 1.0f);
}

// Not in the book: what the view (viewer/views/stable_fluids_2d.py) samples, where Draw's solver has 16 bytes a cell:
// GL takes host memory at about 4-5 GB/s on the lent H200, so a 2048^2 frame moves 8 or 16 MB instead of 67.
// shown: 0 = density (ink, density display; 2 bytes a cell), 1 = (u, v) (velocity; 4 bytes), 2 = the divergence
// du/dx + dv/dy by central differences over a domain of length 1, zero outside the grid (divergence; 2 bytes; as
// ugpcl.scenes.stable_fluids_2d.central_divergence, which the view's shader used to take itself). Written as half
// floats (vstore_half, rounded to nearest), clamped to half's range where a float beyond it would turn inf.
// top[0] = the largest |value| of the float field (of u and v for velocity; not taken for the density, which no
// display scales), as the bits of a non-negative float, which order as ints: a column, then a row of the work-group,
// then one atomic_max per group (the host zeroes top first).
#define GROUP_SIZE (THREAD_X * THREAD_Y)
#define HALF_MAX 65504.0f

__kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, 1)))
void DrawTexture(const __global float2* velocity, const __global float* density, __global half* texture,
                 volatile __global int* top, int shown, int w, int h) {
    __local int group_top[GROUP_SIZE];
    const int x = get_global_id(0), y = get_global_id(1);
    const int l = get_local_id(1) * THREAD_X + get_local_id(0);
    float largest = 0.0f;  // padding items of the rounded-up global size keep 0 (and run every barrier)
    if (x < w && y < h) {
        const int i = y * w + x;
        if (shown == 1) {
            const float2 v = velocity[i];
            vstore_half2(clamp(v, -HALF_MAX, HALF_MAX), i, texture);
            largest = fmax(fabs(v.x), fabs(v.y));
        } else {
            float value;
            if (shown == 2) {
                const float du = ld2(velocity, x + 1, y, w, h, false).x - ld2(velocity, x - 1, y, w, h, false).x;
                const float dv = ld2(velocity, x, y + 1, w, h, false).y - ld2(velocity, x, y - 1, w, h, false).y;
                value = 0.5f * (du * w + dv * h);
            } else {
                value = density[i];
            }
            vstore_half(clamp(value, -HALF_MAX, HALF_MAX), i, texture);
            largest = fabs(value);
        }
    }
    if (shown == 0) return;  // no display scales the density (the same for the whole launch: no barrier is split)
    group_top[l] = as_int(largest);
    barrier(CLK_LOCAL_MEM_FENCE);
    if (l < THREAD_X) {  // item l takes column l's maximum into row 0
        int column = group_top[l];
        for (int r = 1; r < THREAD_Y; r++) column = max(column, group_top[r * THREAD_X + l]);
        group_top[l] = column;
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    if (l == 0) {
        int row = group_top[0];
        for (int c = 1; c < THREAD_X; c++) row = max(row, group_top[c]);
        atomic_max(top, row);
    }
}

// {{{ the other boundary rules on their own (Simulation.set_boundary_*; the kernels above apply them in step())

// Global >= 2(w-2) + 2(h-2) + 4 for each.
__kernel void SetBoundaryDensity(__global float* density, int w, int h) { set_boundary_copy(density, 1, 0, w, h); }

// prev.y (the divergence): copy the inner value; corners average.
__kernel void SetBoundaryDivergence(__global float4* prev, int w, int h) {
    set_boundary_copy((__global float*)prev, 4, 1, w, h);
}

// p, every `stride`-th float of `p` (prev.x: 4; fixed's pressure field during a solve: 1): copy the inner value
// (zero normal derivative at the walls); corners average.
__kernel void SetBoundaryDivPositive(__global float* p, int stride, int w, int h) {
    set_boundary_copy(p, stride, 0, w, h);
}

// }}}
