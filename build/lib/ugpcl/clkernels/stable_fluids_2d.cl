// stable_fluids_2d.cl: Unity Graphics Programming vol.1 ch.4, "Fluid simulation by lattice method" (spec 04, 2D).
// Jos Stam, "Stable Fluids", SIGGRAPH 1999: implicit diffusion, projection, semi-Lagrangian advection on a grid.
// The original is Assets/StableFluids/ComputeShaders/Solver2D.compute; vol.4 ch.6 (Tessellation) drives a
// stripped copy of it, which is this file run without pressure sweeps and without AdvectVelocity (spec 17).
//
// Fields: row-major w x h grids, cell (x, y) at index y*w + x, row y = 0 at the bottom (as the book's uv).
//   velocity float2 (u, v); density float; source float4 (velocity source xy, density source z);
//   solver float4 (u, v, density, 1) for the renderer;
//   prev float4, multiplexed as the book does: xy = velocity source or copy of velocity, z = density source or copy
//   of density; during the projection x = p and y = div (z kept: later kernels read the leftovers).
// Kernels, in host call order per step (B(f) = SetBoundary<f> launched twice: BOUNDARY_EDGES, BOUNDARY_CORNERS):
//   AddSourceBrush       -> source: f = clamp(1 - |(uv - c)/r|^2, 0, 1), source = (m.x*f, m.y*f, f, 0) (brush held)
//   velocity step (skipped when density_only):
//   AddSourceVelocity    velocity += s.xy*velocityCoef*dt, prev.xy = the same amount           (own cell, in place)
//   DiffuseVelocity      velocity_in, prev.xy -> velocity_out: one Jacobi sweep (host: gs_iterations times), B(Velocity)
//   ProjectStep1         velocity -> prev = (0, div, prev.z, 0) (own cell of prev, in place); B(Divergence), B(DivPositive)
//   ProjectStep2         prev_in -> prev_out: one Jacobi sweep of the Poisson equation for p = prev.x; B(DivPositive)
//   ProjectStep3         velocity -= 0.5*(p(+1) - p(-1))*(w | h) per axis (own cell, in place); B(Velocity)
//   SwapVelocity         prev.xy = velocity (a one-way copy despite the name, as the book)
//   AdvectVelocity       prev.xy -> velocity: back-trace by the cell's own prev.xy, bilinear; B(Velocity)
//   ProjectStep1..3      again
//   density step:
//   AddSourceDensity     density += s.z*densityCoef*dt, prev.z = the same amount               (own cell, in place)
//   DiffuseDensity       density_in, prev.z -> density_out: one Jacobi sweep (gs_iterations times), B(Density)
//   SwapDensity          prev.z = density
//   AdvectDensity        velocity, prev.z -> density: back-trace by the current velocity, bilinear; B(Density)
//   AdvectDensityFromExt source.xy, prev.z -> density: back-trace by the brush velocity (density_only); B(Density)
//   Draw                 velocity, density -> solver = (u, v, density, 1)
//   SetBoundaryDensity / SetBoundaryVelocity / SetBoundaryDivergence (prev.y) / SetBoundaryDivPositive (prev.x):
//     BOUNDARY_EDGES   global 2*(w-2) + 2*(h-2): an edge cell copies its inner neighbour (velocity: negates the
//                      normal component of the inner cell and keeps its own tangential one)
//     BOUNDARY_CORNERS global 4: a corner = mean of its two edge neighbours
//   The edges launch reads only interior cells and the corners launch only edge cells, so no cell is read while it
//   is written (the book applies these rules in place inside every producer kernel, racing with its neighbours).
// Build defines: THREAD_X, THREAD_Y = work-group shape of the grid kernels (book: numthreads(32, 32, 1));
//   BOOK_VARIANT = 1: the original's divergence -0.5*du/w + dv/h (operator precedence), a back-trace that is never
//   clamped (its clamp() discards the result) and the divergence corner (0, h-1) reading (1, h-2) (a typo);
//   0: Stam's -0.5*(du/w + dv/h), back-trace clamped to [0.5, n - 1.5], the corner typo fixed.
// Differences from the book: one Jacobi sweep per launch from a read buffer into a write buffer (the book's in-place
// Gauss-Seidel races), global sizes rounded up to the work-group shape and guarded (the book drops partial groups),
// every neighbour read through ld*() (zero outside the grid, as D3D's out-of-range texture reads), float32 fields.
// Grids must be at least 3 x 3 (the boundary rules need an interior).

#ifndef THREAD_X
#error "build with -D THREAD_X=<work-group x> -D THREAD_Y=<work-group y> (book: 32, 32)"
#endif
#ifndef THREAD_Y
#error "build with -D THREAD_Y=<work-group y> (book: 32)"
#endif
#ifndef BOOK_VARIANT
#error "build with -D BOOK_VARIANT=1 (the original's arithmetic) or 0 (Stam's equations)"
#endif

#define BOUNDARY_EDGES 0
#define BOUNDARY_CORNERS 1

#define GRID_KERNEL __kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, 1)))
// One work-item per cell; padding items of the rounded-up global size leave at once (no kernel has a barrier).
#define CELL_OR_RETURN(w, h)              \
    const int x = get_global_id(0);       \
    const int y = get_global_id(1);       \
    if (x >= (w) || y >= (h)) return;     \
    const int i = y * (w) + x;

// {{{ zero-padded reads: D3D returns 0 for a texture read outside the grid; OpenCL has no bounds check

inline float ld1(const __global float* f, int x, int y, int w, int h) {
    return (x >= 0 && x < w && y >= 0 && y < h) ? f[y * w + x] : 0.0f;
}

inline float2 ld2(const __global float2* f, int x, int y, int w, int h) {
    return (x >= 0 && x < w && y >= 0 && y < h) ? f[y * w + x] : (float2)(0.0f);
}

inline float4 ld4(const __global float4* f, int x, int y, int w, int h) {
    return (x >= 0 && x < w && y >= 0 && y < h) ? f[y * w + x] : (float4)(0.0f);
}

// }}}

// {{{ back-trace (AdvectVelocity, AdvectDensity): the point a cell's content came from, in cells

inline float2 back_trace(int x, int y, float2 velocity, float dfdt, int w, int h) {
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

// }}}

// 0. The brush (the original blits Shaders/AddSource.shader into `source` while the mouse button is held).
// center = brush centre in uv (bottom-left origin), move = mouse delta in pixels (length <= mouse clamp),
// radius in uv units on both axes, so the brush is an ellipse on a non-square grid, as the original's.
GRID_KERNEL void AddSourceBrush(__global float4* source, int w, int h, float2 center, float2 move, float radius) {
    CELL_OR_RETURN(w, h)
    const float2 uv = (float2)(((float)x + 0.5f) / (float)w, ((float)y + 0.5f) / (float)h);
    const float2 q = (uv - center) / radius;
    const float f = clamp(1.0f - dot(q, q), 0.0f, 1.0f);  // parabolic fall-off, 1 at the centre, 0 at radius
    source[i] = (float4)(move.x * f, move.y * f, f, 0.0f);
}

// {{{ velocity step

// 1. External force term: velocity += source.xy*velocityCoef*dt; prev.xy remembers that amount (diffusion reads it).
GRID_KERNEL void AddSourceVelocity(__global float2* velocity, __global float4* prev, const __global float4* source,
                                   int w, int h, float velocity_coef, float dt) {
    CELL_OR_RETURN(w, h)
    const float2 s = source[i].xy * velocity_coef * dt;
    velocity[i] += s;
    prev[i] = (float4)(s, prev[i].z, 0.0f);
}

// 2. Viscosity, one Jacobi sweep of (1 + 4a) v = prev.xy + a * (sum of the 4 neighbours), a = dt*visc*w*h.
GRID_KERNEL void DiffuseVelocity(const __global float2* velocity_in, __global float2* velocity_out,
                                 const __global float4* prev, int w, int h, float a) {
    CELL_OR_RETURN(w, h)
    const float2 sum = ld2(velocity_in, x - 1, y, w, h) + ld2(velocity_in, x + 1, y, w, h) +
                       ld2(velocity_in, x, y - 1, w, h) + ld2(velocity_in, x, y + 1, w, h);
    velocity_out[i] = (prev[i].xy + a * sum) / (1.0f + 4.0f * a);
}

// 3. Projection step 1: the divergence of the velocity into prev.y, p = prev.x starts at 0, prev.z kept.
GRID_KERNEL void ProjectStep1(const __global float2* velocity, __global float4* prev, int w, int h) {
    CELL_OR_RETURN(w, h)
    const float du = ld2(velocity, x + 1, y, w, h).x - ld2(velocity, x - 1, y, w, h).x;
    const float dv = ld2(velocity, x, y + 1, w, h).y - ld2(velocity, x, y - 1, w, h).y;
#if BOOK_VARIANT
    const float div = -0.5f * (du / (float)w) + (dv / (float)h);  // the original's precedence: -0.5 on x only
#else
    const float div = -0.5f * (du / (float)w + dv / (float)h);  // Stam: -0.5*h*(du + dv) with h = 1/n per axis
#endif
    prev[i] = (float4)(0.0f, div, prev[i].z, 0.0f);
}

// 4. Projection step 2, one Jacobi sweep of the Poisson equation 4p - (sum of the 4 neighbours' p) = div.
GRID_KERNEL void ProjectStep2(const __global float4* prev_in, __global float4* prev_out, int w, int h) {
    CELL_OR_RETURN(w, h)
    const float4 own = prev_in[i];
    const float sum = ld4(prev_in, x - 1, y, w, h).x + ld4(prev_in, x + 1, y, w, h).x + ld4(prev_in, x, y - 1, w, h).x +
                      ld4(prev_in, x, y + 1, w, h).x;
    prev_out[i] = (float4)((own.y + sum) / 4.0f, own.yzw);
}

// 5. Projection step 3: subtract the gradient of p (central differences, in cells scaled by the grid size).
GRID_KERNEL void ProjectStep3(__global float2* velocity, const __global float4* prev, int w, int h) {
    CELL_OR_RETURN(w, h)
    float2 v = velocity[i];
    v.x -= 0.5f * (ld4(prev, x + 1, y, w, h).x - ld4(prev, x - 1, y, w, h).x) * (float)w;
    v.y -= 0.5f * (ld4(prev, x, y + 1, w, h).x - ld4(prev, x, y - 1, w, h).x) * (float)h;
    velocity[i] = v;
}

// 6. prev.xy = velocity: the field AdvectVelocity carries along (the book's "swap" is this copy).
GRID_KERNEL void SwapVelocity(const __global float2* velocity, __global float4* prev, int w, int h) {
    CELL_OR_RETURN(w, h)
    prev[i] = (float4)(velocity[i], prev[i].zw);
}

// 7. Advection term: back-trace by the cell's own (copied) velocity and interpolate prev.xy bilinearly.
GRID_KERNEL void AdvectVelocity(const __global float4* prev, __global float2* velocity, int w, int h, float dfdt) {
    CELL_OR_RETURN(w, h)
    const float2 b = back_trace(x, y, prev[i].xy, dfdt, w, h);
    const int x0 = (int)floor(b.x), y0 = (int)floor(b.y);
    const float s1 = b.x - (float)x0, s0 = 1.0f - s1;
    const float t1 = b.y - (float)y0, t0 = 1.0f - t1;
    velocity[i] = s0 * (t0 * ld4(prev, x0, y0, w, h).xy + t1 * ld4(prev, x0, y0 + 1, w, h).xy) +
                  s1 * (t0 * ld4(prev, x0 + 1, y0, w, h).xy + t1 * ld4(prev, x0 + 1, y0 + 1, w, h).xy);
}

// }}}

// {{{ density step

// 8. Source term S of the density: density += source.z*densityCoef*dt; prev.z remembers that amount.
GRID_KERNEL void AddSourceDensity(__global float* density, __global float4* prev, const __global float4* source, int w,
                                  int h, float density_coef, float dt) {
    CELL_OR_RETURN(w, h)
    const float s = source[i].z * density_coef * dt;
    density[i] += s;
    prev[i].z = s;
}

// 9. Diffusion, one Jacobi sweep of (1 + 4a) d = prev.z + a * (sum of the 4 neighbours), a = dt*diff*w*h.
GRID_KERNEL void DiffuseDensity(const __global float* density_in, __global float* density_out,
                                const __global float4* prev, int w, int h, float a) {
    CELL_OR_RETURN(w, h)
    const float sum = ld1(density_in, x - 1, y, w, h) + ld1(density_in, x + 1, y, w, h) +
                      ld1(density_in, x, y - 1, w, h) + ld1(density_in, x, y + 1, w, h);
    density_out[i] = (prev[i].z + a * sum) / (1.0f + 4.0f * a);
}

// 10. prev.z = density: the field AdvectDensity carries along.
GRID_KERNEL void SwapDensity(const __global float* density, __global float4* prev, int w, int h) {
    CELL_OR_RETURN(w, h)
    prev[i].z = density[i];
}

inline float bilinear_z(const __global float4* prev, float2 b, int w, int h) {
    const int x0 = (int)floor(b.x), y0 = (int)floor(b.y);
    const float s1 = b.x - (float)x0, s0 = 1.0f - s1;
    const float t1 = b.y - (float)y0, t0 = 1.0f - t1;
    return s0 * (t0 * ld4(prev, x0, y0, w, h).z + t1 * ld4(prev, x0, y0 + 1, w, h).z) +
           s1 * (t0 * ld4(prev, x0 + 1, y0, w, h).z + t1 * ld4(prev, x0 + 1, y0 + 1, w, h).z);
}

// 11. Advection of the density by the current (projected) velocity.
GRID_KERNEL void AdvectDensity(const __global float2* velocity, const __global float4* prev, __global float* density,
                               int w, int h, float dfdt) {
    CELL_OR_RETURN(w, h)
    density[i] = bilinear_z(prev, back_trace(x, y, velocity[i], dfdt, w, h), w, h);
}

// 11'. density_only (book: isDensityOnly): advect by the brush's velocity instead of a simulated one.
GRID_KERNEL void AdvectDensityFromExt(const __global float4* source, const __global float4* prev,
                                      __global float* density, int w, int h, float dfdt) {
    CELL_OR_RETURN(w, h)
    density[i] = bilinear_z(prev, back_trace(x, y, source[i].xy, dfdt, w, h), w, h);
}

// }}}

// 12. Output for the renderer (the original writes the RenderTexture the ink post effect samples).
GRID_KERNEL void Draw(const __global float2* velocity, const __global float* density, __global float4* solver, int w,
                      int h) {
    CELL_OR_RETURN(w, h)
    solver[i] = (float4)(velocity[i], density[i], 1.0f);
}

// {{{ boundaries (the book's SetBound* helpers, as separate launches)

// Edge item k -> the edge cell (x, y) and its inner neighbour (ix, iy); `normal_axis` 0 for the x walls, 1 for y.
// Order: left column, right column, bottom row, top row, corners excluded. Returns 0 for padding items.
inline int edge_cell(int k, int w, int h, int* x, int* y, int* ix, int* iy, int* normal_axis) {
    const int rows = h - 2, cols = w - 2;
    if (k < rows) { *x = 0; *y = k + 1; *ix = 1; *iy = *y; *normal_axis = 0; return 1; }
    k -= rows;
    if (k < rows) { *x = w - 1; *y = k + 1; *ix = w - 2; *iy = *y; *normal_axis = 0; return 1; }
    k -= rows;
    if (k < cols) { *x = k + 1; *y = 0; *ix = *x; *iy = 1; *normal_axis = 1; return 1; }
    k -= cols;
    if (k < cols) { *x = k + 1; *y = h - 1; *ix = *x; *iy = h - 2; *normal_axis = 1; return 1; }
    return 0;
}

// Corner item c (0: (0,0), 1: (0,h-1), 2: (w-1,0), 3: (w-1,h-1)) and its two edge neighbours a (along x), b (along y).
inline void corner_cell(int c, int w, int h, int* x, int* y, int* ax, int* ay, int* bx, int* by) {
    *x = (c < 2) ? 0 : w - 1;
    *y = (c % 2 == 0) ? 0 : h - 1;
    *ax = (c < 2) ? 1 : w - 2;
    *ay = *y;
    *bx = *x;
    *by = (c % 2 == 0) ? 1 : h - 2;
}

// part BOUNDARY_EDGES: global >= 2(w-2) + 2(h-2); part BOUNDARY_CORNERS: global >= 4.
__kernel void SetBoundaryDensity(__global float* density, int w, int h, int part) {
    const int k = get_global_id(0);
    int x, y, ix, iy, axis;
    if (part == BOUNDARY_EDGES) {
        if (!edge_cell(k, w, h, &x, &y, &ix, &iy, &axis)) return;
        density[y * w + x] = density[iy * w + ix];
    } else {
        if (k >= 4) return;
        int ax, ay, bx, by;
        corner_cell(k, w, h, &x, &y, &ax, &ay, &bx, &by);
        density[y * w + x] = 0.5f * (density[ay * w + ax] + density[by * w + bx]);
    }
}

// Walls: the normal component is the negated inner one (no flow through the wall), the tangential one is kept
// (not Stam's copy of the inner tangential component: the book keeps the cell's own).
__kernel void SetBoundaryVelocity(__global float2* velocity, int w, int h, int part) {
    const int k = get_global_id(0);
    int x, y, ix, iy, axis;
    if (part == BOUNDARY_EDGES) {
        if (!edge_cell(k, w, h, &x, &y, &ix, &iy, &axis)) return;
        const float2 inner = velocity[iy * w + ix];
        float2 own = velocity[y * w + x];
        if (axis == 0) own.x = -inner.x;
        else own.y = -inner.y;
        velocity[y * w + x] = own;
    } else {
        if (k >= 4) return;
        int ax, ay, bx, by;
        corner_cell(k, w, h, &x, &y, &ax, &ay, &bx, &by);
        velocity[y * w + x] = 0.5f * (velocity[ay * w + ax] + velocity[by * w + bx]);
    }
}

// prev.y (the divergence): copy the inner value; corners average.
__kernel void SetBoundaryDivergence(__global float4* prev, int w, int h, int part) {
    const int k = get_global_id(0);
    int x, y, ix, iy, axis;
    if (part == BOUNDARY_EDGES) {
        if (!edge_cell(k, w, h, &x, &y, &ix, &iy, &axis)) return;
        prev[y * w + x].y = prev[iy * w + ix].y;
    } else {
        if (k >= 4) return;
        int ax, ay, bx, by;
        corner_cell(k, w, h, &x, &y, &ax, &ay, &bx, &by);
#if BOOK_VARIANT
        // The original's typo: corner (0, h-1) reads (1, h-2) instead of (1, h-1). After the edges launch (1, h-1)
        // holds a copy of (1, h-2), so with this launch order the typo changes no value (in the original's racy
        // in-place version it could).
        if (k == 1) ay = h - 2;
#endif
        prev[y * w + x].y = 0.5f * (prev[ay * w + ax].y + prev[by * w + bx].y);
    }
}

// prev.x (p): copy the inner value (zero normal derivative at the walls); corners average.
__kernel void SetBoundaryDivPositive(__global float4* prev, int w, int h, int part) {
    const int k = get_global_id(0);
    int x, y, ix, iy, axis;
    if (part == BOUNDARY_EDGES) {
        if (!edge_cell(k, w, h, &x, &y, &ix, &iy, &axis)) return;
        prev[y * w + x].x = prev[iy * w + ix].x;
    } else {
        if (k >= 4) return;
        int ax, ay, bx, by;
        corner_cell(k, w, h, &x, &y, &ax, &ay, &bx, &by);
        prev[y * w + x].x = 0.5f * (prev[ay * w + ax].x + prev[by * w + bx].x);
    }
}

// }}}
