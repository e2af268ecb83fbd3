// stable_fluids_3d.cl: Unity Graphics Programming vol.1 ch.4, "Fluid simulation by lattice method": the 3D solver
// the original ships as Solver3D.compute but never runs (spec 04, sections 4 and 10).
// Jos Stam, "Stable Fluids", SIGGRAPH 1999: implicit diffusion, projection, semi-Lagrangian advection on a grid.
//
// Fields: row-major w x h x d grids, cell (x, y, z) at index (z*h + y)*w + x, y = 0 at the bottom. float4 fields:
//   velocity (u, v, w, 0); source (velocity source xyz, density source w); solver (u, v, w, density);
//   prev, multiplexed as the book does: xyz = velocity source or copy of velocity, w = density source or copy of
//   density; during the projection x = p and y = div (z, w kept: later kernels read the leftovers).
// Kernels, in host call order per step (B(f) = SetBoundary<f> launched three times: faces, edges, corners):
//   AddSourceBrush3D     -> source: spherical emitter f = clamp(1 - |(uvw - c)/r|^2, 0, 1), source = (dir*f, f)
//   velocity step (skipped when density_only):
//   AddSourceVelocity    velocity += s.xyz*velocityCoef*dt, prev.xyz = s.xyz*velocityCoef*dt   (own cell, in place)
//   DiffuseVelocity      velocity_in, prev.xyz -> velocity_out: one Jacobi sweep (host: gs_iterations times), B(Velocity)
//   ProjectStep1         velocity -> prev = (0, div, prev.z, prev.w) (own cell, in place); B(Div), B(P)
//   ProjectStep2         prev_in -> prev_out: one Jacobi sweep of the Poisson equation for p (gs_iterations), B(P)
//   ProjectStep3         velocity -= 0.5*(p(+1) - p(-1))*(w | h | d) per axis (own cell, in place); B(Velocity)
//   SwapVelocity         prev.xyz = velocity (a one-way copy despite the name, as the book)
//   AdvectVelocity       prev.xyz -> velocity: back-trace by the cell's own prev.xyz, trilinear; B(Velocity)
//   ProjectStep1..3      again
//   density step:
//   AddSourceDensity     density += s.w*densityCoef*dt, prev.w = s.w*densityCoef*dt   (own cell, in place)
//   DiffuseDensity       density_in, prev.w -> density_out: one Jacobi sweep (gs_iterations times), B(Density)
//   SwapDensity          prev.w = density
//   AdvectDensity        velocity, prev.w -> density: back-trace by the current velocity; B(Density)
//   AdvectDensityFromExt source.xyz, prev.w -> density: back-trace by the source (density_only); B(Density)
//   Draw                 velocity, density -> solver = (u, v, w, density)
//   SetBoundaryDensity / SetBoundaryVelocity / SetBoundaryDiv (prev.y) / SetBoundaryP (prev.x), argument `part`:
//     BOUNDARY_FACES   global (max(w,h), max(h,d), 6): a face cell copies its inner neighbour (velocity: negates
//                      the normal component of the inner cell, keeps its own tangential components)
//     BOUNDARY_EDGES   global (max(w,h,d), 12): an edge cell = mean of its 2 neighbouring face cells
//     BOUNDARY_CORNERS global 8: a corner = mean of its 3 neighbouring edge cells
//   Each launch reads only cells the launch before wrote, so no cell is read while it is written (the book
//   applies these rules in place inside every kernel, racing with its neighbours).
// Build defines: THREAD_X, THREAD_Y, THREAD_Z = work-group shape of the grid kernels (book: numthreads 8, 8, 4);
//   BOOK_VARIANT = 1: the original's divergence -0.5*du/w + dv/h + dw/d (operator precedence) and a back-trace that
//   is never clamped (its clamp() discards the result); 0: Stam's -0.5*(du/w + dv/h + dw/d), back-trace clamped
//   to [0.5, n - 1.5]. Bugs of Solver3D.compute fixed in both (spec 04 section 10): `id.x < d` guards, AdvectDensity
//   sampling prev.z, a velocity volume without z (RGHalf), integer-division uvw, the last corner rule without
//   z == d-1, a_v without d.
// Differences from the book: one Jacobi sweep per launch from a read buffer into a write buffer (the book's in-place
// Gauss-Seidel races), guarded global sizes rounded up to the work-group shape (the book drops partial groups),
// every neighbour read through ld() (zero outside the grid, as D3D's out-of-range texture reads), float32 fields.

#ifndef THREAD_X
#error "build with -D THREAD_X=<work-group x> -D THREAD_Y=<y> -D THREAD_Z=<z> (book: 8, 8, 4)"
#endif
#if !defined(THREAD_Y) || !defined(THREAD_Z)
#error "build with -D THREAD_Y=<work-group y> -D THREAD_Z=<work-group z> (book: 8, 4)"
#endif
#ifndef BOOK_VARIANT
#error "build with -D BOOK_VARIANT=1 (the original's arithmetic) or 0 (Stam's equations)"
#endif

#define BOUNDARY_FACES 0
#define BOUNDARY_EDGES 1
#define BOUNDARY_CORNERS 2
#define ONE_THIRD (1.0f / 3.0f)  // corner mean as a product (the book divides by 3): the same rounding as numpy's

#define GRID_KERNEL __kernel __attribute__((reqd_work_group_size(THREAD_X, THREAD_Y, THREAD_Z)))

// {{{ helpers

inline int cell(int x, int y, int z, int4 n) { return (z * n.y + y) * n.x + x; }

inline bool inside(int x, int y, int z, int4 n) { return x >= 0 && y >= 0 && z >= 0 && x < n.x && y < n.y && z < n.z; }

// The book reads neighbours with texture[] and relies on D3D returning 0 outside the texture; here explicitly.
inline float ld(const __global float* f, int x, int y, int z, int4 n) {
    return inside(x, y, z, n) ? f[cell(x, y, z, n)] : 0.0f;
}

inline float4 ld4(const __global float4* f, int x, int y, int z, int4 n) {
    return inside(x, y, z, n) ? f[cell(x, y, z, n)] : (float4)(0.0f);
}

// Sum of the 6 face neighbours (the 3D Laplacian stencil without its centre).
inline float4 neighbours4(const __global float4* f, int x, int y, int z, int4 n) {
    return ld4(f, x - 1, y, z, n) + ld4(f, x + 1, y, z, n) + ld4(f, x, y - 1, z, n) + ld4(f, x, y + 1, z, n) +
           ld4(f, x, y, z - 1, n) + ld4(f, x, y, z + 1, n);
}

inline float neighbours(const __global float* f, int x, int y, int z, int4 n) {
    return ld(f, x - 1, y, z, n) + ld(f, x + 1, y, z, n) + ld(f, x, y - 1, z, n) + ld(f, x, y + 1, z, n) +
           ld(f, x, y, z - 1, n) + ld(f, x, y, z + 1, n);
}

// Where a back-traced point may lie (book: clamp(x, 0.5, w - 1.5) with its result dropped).
inline float3 clamp_back_trace(float3 b, int4 n) {
#if BOOK_VARIANT
    // No clamp, as the book: taps outside read 0. Any coordinate below -1 or at/above n reads only zeros, so pinning
    // b to [-2, n + 1] changes no value; it only keeps the float -> int conversion below defined.
    return clamp(b, (float3)(-2.0f), convert_float3(n.xyz) + 1.0f);
#else
    return clamp(b, (float3)(0.5f), convert_float3(n.xyz) - 1.5f);
#endif
}

// Trilinear interpolation of f at the grid point b (book: s0/s1, t0/t1, u0/u1 weights of the 8 cells around b).
inline float4 trilinear(const __global float4* f, float3 b, int4 n) {
    const float3 b0 = floor(b);
    const int x0 = (int)b0.x, y0 = (int)b0.y, z0 = (int)b0.z;
    const float s1 = b.x - b0.x, t1 = b.y - b0.y, u1 = b.z - b0.z;
    const float s0 = 1.0f - s1, t0 = 1.0f - t1, u0 = 1.0f - u1;
    return s0 * u0 * (t0 * ld4(f, x0, y0, z0, n) + t1 * ld4(f, x0, y0 + 1, z0, n)) +
           s1 * u0 * (t0 * ld4(f, x0 + 1, y0, z0, n) + t1 * ld4(f, x0 + 1, y0 + 1, z0, n)) +
           s0 * u1 * (t0 * ld4(f, x0, y0, z0 + 1, n) + t1 * ld4(f, x0, y0 + 1, z0 + 1, n)) +
           s1 * u1 * (t0 * ld4(f, x0 + 1, y0, z0 + 1, n) + t1 * ld4(f, x0 + 1, y0 + 1, z0 + 1, n));
}

// }}}

// {{{ boundaries

// One boundary cell of a launch and the cells its value comes from.
typedef struct {
    int target;     // the boundary cell written
    int count;      // 0: this work-item has no cell; 1: a face cell; 2: an edge cell; 3: a corner
    int source[3];  // face: the inner neighbour; edge: the 2 face cells next to it; corner: the 3 edge cells
    int axis;       // face only: the axis normal to the face (0 x, 1 y, 2 z)
} BoundaryCell;

inline int cell_of(const int c[3], int4 n) { return cell(c[0], c[1], c[2], n); }

// Face f (0: x = 0, 1: x = w-1, 2: y = 0, 3: y = h-1, 4: z = 0, 5: z = d-1) = get_global_id(2); (i, j) = the two
// tangential coordinates; only the face's inner part (edges and corners excluded) is written.
inline BoundaryCell face_cell(int4 n) {
    const int dims[3] = {n.x, n.y, n.z};
    const int face = get_global_id(2), axis = face / 2, high = face % 2;
    const int t1 = axis == 0 ? 1 : 0, t2 = axis == 2 ? 1 : 2;  // tangential axes: (y, z), (x, z) or (x, y)
    const int i = get_global_id(0), j = get_global_id(1);
    BoundaryCell b = {0, 0, {0, 0, 0}, axis};
    if (i < 1 || i > dims[t1] - 2 || j < 1 || j > dims[t2] - 2) return b;
    int c[3];
    c[t1] = i;
    c[t2] = j;
    c[axis] = high ? dims[axis] - 1 : 0;
    b.target = cell_of(c, n);
    c[axis] = high ? dims[axis] - 2 : 1;
    b.source[0] = cell_of(c, n);
    b.count = 1;
    return b;
}

// Edge e = get_global_id(1) runs along axis e / 4; bits 0 and 1 of e put it on the low or high side of the two
// other axes; get_global_id(0) = the coordinate along the edge (its two corners excluded).
inline BoundaryCell edge_cell(int4 n) {
    const int dims[3] = {n.x, n.y, n.z};
    const int edge = get_global_id(1), along = edge / 4, t = get_global_id(0);
    const int o1 = (along + 1) % 3, o2 = (along + 2) % 3;
    const int high1 = edge & 1, high2 = (edge >> 1) & 1;
    BoundaryCell b = {0, 0, {0, 0, 0}, 0};
    if (t < 1 || t > dims[along] - 2) return b;
    int c[3];
    c[along] = t;
    c[o1] = high1 ? dims[o1] - 1 : 0;
    c[o2] = high2 ? dims[o2] - 1 : 0;
    b.target = cell_of(c, n);
    const int edge1 = c[o1], edge2 = c[o2];
    c[o1] = high1 ? dims[o1] - 2 : 1;  // one step inwards across axis o1: a face cell
    b.source[0] = cell_of(c, n);
    c[o1] = edge1;
    c[o2] = high2 ? dims[o2] - 2 : 1;  // one step inwards across axis o2
    b.source[1] = cell_of(c, n);
    c[o2] = edge2;
    b.count = 2;
    return b;
}

// Corner k = get_global_id(0) in 0..7: bit a puts it on the high side of axis a; its 3 sources step inwards along x,
// y and z (each an edge cell).
inline BoundaryCell corner_cell(int4 n) {
    const int dims[3] = {n.x, n.y, n.z};
    const int k = get_global_id(0);
    BoundaryCell b = {0, 0, {0, 0, 0}, 0};
    if (k > 7) return b;
    int c[3];
    for (int a = 0; a < 3; a++) c[a] = (k >> a) & 1 ? dims[a] - 1 : 0;
    b.target = cell_of(c, n);
    for (int a = 0; a < 3; a++) {
        const int corner = c[a];
        c[a] = (k >> a) & 1 ? dims[a] - 2 : 1;
        b.source[a] = cell_of(c, n);
        c[a] = corner;
    }
    b.count = 3;
    return b;
}

inline BoundaryCell boundary_cell(int part, int4 n) {
    if (part == BOUNDARY_FACES) return face_cell(n);
    if (part == BOUNDARY_EDGES) return edge_cell(n);
    return corner_cell(n);
}

// Copy (face) or mean (edge, corner) of one float per cell, read `stride` floats apart starting at `offset`.
inline float boundary_value(const __global float* f, int stride, int offset, const BoundaryCell* b) {
    const float a = f[b->source[0] * stride + offset];
    if (b->count == 1) return a;
    const float c = f[b->source[1] * stride + offset];
    if (b->count == 2) return (a + c) * 0.5f;
    return (a + c + f[b->source[2] * stride + offset]) * ONE_THIRD;
}

__kernel void SetBoundaryDensity(__global float* density, int w, int h, int d, int part) {
    const int4 n = (int4)(w, h, d, 0);
    const BoundaryCell b = boundary_cell(part, n);
    if (b.count == 0) return;
    density[b.target] = boundary_value(density, 1, 0, &b);
}

__kernel void SetBoundaryVelocity(__global float4* velocity, int w, int h, int d, int part) {
    const int4 n = (int4)(w, h, d, 0);
    const BoundaryCell b = boundary_cell(part, n);
    if (b.count == 0) return;
    if (b.count == 1) {  // a wall: the normal component mirrors the inner cell's, the tangential ones stay
        const float4 inner = velocity[b.source[0]];
        float4 v = velocity[b.target];
        v.x = b.axis == 0 ? -inner.x : v.x;
        v.y = b.axis == 1 ? -inner.y : v.y;
        v.z = b.axis == 2 ? -inner.z : v.z;
        velocity[b.target] = v;
    } else if (b.count == 2) {
        velocity[b.target] = (velocity[b.source[0]] + velocity[b.source[1]]) * 0.5f;
    } else {
        velocity[b.target] = (velocity[b.source[0]] + velocity[b.source[1]] + velocity[b.source[2]]) * ONE_THIRD;
    }
}

__kernel void SetBoundaryDiv(__global float4* prev, int w, int h, int d, int part) {
    const int4 n = (int4)(w, h, d, 0);
    const BoundaryCell b = boundary_cell(part, n);
    if (b.count == 0) return;
    prev[b.target].y = boundary_value((const __global float*)prev, 4, 1, &b);  // prev.y = div
}

__kernel void SetBoundaryP(__global float4* prev, int w, int h, int d, int part) {
    const int4 n = (int4)(w, h, d, 0);
    const BoundaryCell b = boundary_cell(part, n);
    if (b.count == 0) return;
    prev[b.target].x = boundary_value((const __global float*)prev, 4, 0, &b);  // prev.x = p
}

// }}}

// {{{ external force (source) terms

// Proposal of spec 04 (the original's 3D source texture has no producer): a spherical emitter at c (uvw units) of
// radius r blowing along dir.
GRID_KERNEL void AddSourceBrush3D(__global float4* source, int w, int h, int d, float4 center, float4 direction,
                                  float radius) {
    const int x = get_global_id(0), y = get_global_id(1), z = get_global_id(2);
    if (x >= w || y >= h || z >= d) return;
    const int4 n = (int4)(w, h, d, 0);
    const float3 uvw = ((float3)(x, y, z) + 0.5f) / convert_float3(n.xyz);
    const float3 q = (uvw - center.xyz) / radius;
    const float f = clamp(1.0f - dot(q, q), 0.0f, 1.0f);
    source[cell(x, y, z, n)] = (float4)(direction.xyz * f, f);
}

GRID_KERNEL void AddSourceVelocity(__global float4* velocity, __global float4* prev, const __global float4* source,
                                   int w, int h, int d, float velocity_coef, float dt) {
    const int x = get_global_id(0), y = get_global_id(1), z = get_global_id(2);
    if (x >= w || y >= h || z >= d) return;
    const int id = cell(x, y, z, (int4)(w, h, d, 0));
    const float3 s = source[id].xyz * velocity_coef * dt;
    velocity[id] = (float4)(velocity[id].xyz + s, 0.0f);
    prev[id] = (float4)(s, prev[id].w);
}

// }}}

// {{{ velocity step

// Implicit viscosity: (1 + 6a) v - a * sum6(v) = prev.xyz, one Jacobi sweep. Note that the book feeds prev (the
// source, or leftovers of the last projection) where Stam has the previous velocity; with the scene's a ~ 1e5 the
// sweep is effectively "replace by the mean of the 6 neighbours" (spec 04 section 10: reproduced, not corrected).
GRID_KERNEL void DiffuseVelocity(const __global float4* velocity_in, const __global float4* prev,
                                 __global float4* velocity_out, int w, int h, int d, float dt, float visc) {
    const int x = get_global_id(0), y = get_global_id(1), z = get_global_id(2);
    if (x >= w || y >= h || z >= d) return;
    const int4 n = (int4)(w, h, d, 0);
    const float a = dt * visc * (float)w * (float)h * (float)d;  // Solver3D.compute omits d (spec 04 section 10)
    const float3 v = (prev[cell(x, y, z, n)].xyz + a * neighbours4(velocity_in, x, y, z, n).xyz) / (1.0f + 6.0f * a);
    velocity_out[cell(x, y, z, n)] = (float4)(v, 0.0f);
}

// Divergence into prev.y, p = 0 into prev.x.
GRID_KERNEL void ProjectStep1(const __global float4* velocity, __global float4* prev, int w, int h, int d) {
    const int x = get_global_id(0), y = get_global_id(1), z = get_global_id(2);
    if (x >= w || y >= h || z >= d) return;
    const int4 n = (int4)(w, h, d, 0);
    const float du = ld4(velocity, x + 1, y, z, n).x - ld4(velocity, x - 1, y, z, n).x;
    const float dv = ld4(velocity, x, y + 1, z, n).y - ld4(velocity, x, y - 1, z, n).y;
    const float dw = ld4(velocity, x, y, z + 1, n).z - ld4(velocity, x, y, z - 1, n).z;
#if BOOK_VARIANT
    const float div = -0.5f * (du / w) + dv / h + dw / d;  // book: -0.5 * (uvd.x * du) + (uvd.y * dv) + (uvd.z * dw)
#else
    const float div = -0.5f * (du / w + dv / h + dw / d);  // Stam: -0.5 * h * (du + dv + dw)
#endif
    const int id = cell(x, y, z, n);
    const float4 p = prev[id];
    prev[id] = (float4)(0.0f, div, p.z, p.w);
}

// Poisson equation sum6(p) - 6p = -div, one Jacobi sweep: p = (div + sum6(p)) / 6.
GRID_KERNEL void ProjectStep2(const __global float4* prev_in, __global float4* prev_out, int w, int h, int d) {
    const int x = get_global_id(0), y = get_global_id(1), z = get_global_id(2);
    if (x >= w || y >= h || z >= d) return;
    const int4 n = (int4)(w, h, d, 0);
    const float4 me = prev_in[cell(x, y, z, n)];
    prev_out[cell(x, y, z, n)] = (float4)((me.y + neighbours4(prev_in, x, y, z, n).x) / 6.0f, me.yzw);
}

// Subtract the gradient of p (central differences, scaled back from uv units: book's / uvd).
GRID_KERNEL void ProjectStep3(__global float4* velocity, const __global float4* prev, int w, int h, int d) {
    const int x = get_global_id(0), y = get_global_id(1), z = get_global_id(2);
    if (x >= w || y >= h || z >= d) return;
    const int4 n = (int4)(w, h, d, 0);
    float4 v = velocity[cell(x, y, z, n)];
    v.x -= 0.5f * (ld4(prev, x + 1, y, z, n).x - ld4(prev, x - 1, y, z, n).x) * (float)w;
    v.y -= 0.5f * (ld4(prev, x, y + 1, z, n).x - ld4(prev, x, y - 1, z, n).x) * (float)h;
    v.z -= 0.5f * (ld4(prev, x, y, z + 1, n).x - ld4(prev, x, y, z - 1, n).x) * (float)d;
    velocity[cell(x, y, z, n)] = v;
}

GRID_KERNEL void SwapVelocity(const __global float4* velocity, __global float4* prev, int w, int h, int d) {
    const int x = get_global_id(0), y = get_global_id(1), z = get_global_id(2);
    if (x >= w || y >= h || z >= d) return;
    const int id = cell(x, y, z, (int4)(w, h, d, 0));
    prev[id] = (float4)(velocity[id].xyz, prev[id].w);
}

// Semi-Lagrangian self-advection: back-trace by the cell's own copied velocity, dfdt cells per unit velocity.
GRID_KERNEL void AdvectVelocity(const __global float4* prev, __global float4* velocity, int w, int h, int d, float dt) {
    const int x = get_global_id(0), y = get_global_id(1), z = get_global_id(2);
    if (x >= w || y >= h || z >= d) return;
    const int4 n = (int4)(w, h, d, 0);
    const float dfdt = dt * (float)(w + h + d) / 3.0f;
    const float3 b = clamp_back_trace((float3)(x, y, z) - dfdt * prev[cell(x, y, z, n)].xyz, n);
    velocity[cell(x, y, z, n)] = (float4)(trilinear(prev, b, n).xyz, 0.0f);
}

// }}}

// {{{ density step

GRID_KERNEL void AddSourceDensity(__global float* density, __global float4* prev, const __global float4* source,
                                  int w, int h, int d, float density_coef, float dt) {
    const int x = get_global_id(0), y = get_global_id(1), z = get_global_id(2);
    if (x >= w || y >= h || z >= d) return;
    const int id = cell(x, y, z, (int4)(w, h, d, 0));
    const float s = source[id].w * density_coef * dt;
    density[id] += s;
    prev[id].w = s;
}

GRID_KERNEL void DiffuseDensity(const __global float* density_in, const __global float4* prev,
                                __global float* density_out, int w, int h, int d, float dt, float diff) {
    const int x = get_global_id(0), y = get_global_id(1), z = get_global_id(2);
    if (x >= w || y >= h || z >= d) return;
    const int4 n = (int4)(w, h, d, 0);
    const float a = dt * diff * (float)w * (float)h * (float)d;
    density_out[cell(x, y, z, n)] =
        (prev[cell(x, y, z, n)].w + a * neighbours(density_in, x, y, z, n)) / (1.0f + 6.0f * a);
}

GRID_KERNEL void SwapDensity(const __global float* density, __global float4* prev, int w, int h, int d) {
    const int x = get_global_id(0), y = get_global_id(1), z = get_global_id(2);
    if (x >= w || y >= h || z >= d) return;
    const int id = cell(x, y, z, (int4)(w, h, d, 0));
    prev[id].w = density[id];
}

// Back-trace by the velocity after the second projection; the density copy lives in prev.w (the original samples
// prev.z, the velocity's z: fixed).
GRID_KERNEL void AdvectDensity(const __global float4* velocity, const __global float4* prev, __global float* density,
                               int w, int h, int d, float dt) {
    const int x = get_global_id(0), y = get_global_id(1), z = get_global_id(2);
    if (x >= w || y >= h || z >= d) return;
    const int4 n = (int4)(w, h, d, 0);
    const float dfdt = dt * (float)(w + h + d) / 3.0f;
    const float3 b = clamp_back_trace((float3)(x, y, z) - dfdt * velocity[cell(x, y, z, n)].xyz, n);
    density[cell(x, y, z, n)] = trilinear(prev, b, n).w;
}

// density_only: the source's velocity replaces the solved one (the original samples the source at uvw = 0).
GRID_KERNEL void AdvectDensityFromExt(const __global float4* source, const __global float4* prev,
                                      __global float* density, int w, int h, int d, float dt) {
    const int x = get_global_id(0), y = get_global_id(1), z = get_global_id(2);
    if (x >= w || y >= h || z >= d) return;
    const int4 n = (int4)(w, h, d, 0);
    const float dfdt = dt * (float)(w + h + d) / 3.0f;
    const float3 b = clamp_back_trace((float3)(x, y, z) - dfdt * source[cell(x, y, z, n)].xyz, n);
    density[cell(x, y, z, n)] = trilinear(prev, b, n).w;
}

// }}}

GRID_KERNEL void Draw(const __global float4* velocity, const __global float* density, __global float4* solver, int w,
                      int h, int d) {
    const int x = get_global_id(0), y = get_global_id(1), z = get_global_id(2);
    if (x >= w || y >= h || z >= d) return;
    const int id = cell(x, y, z, (int4)(w, h, d, 0));
    solver[id] = (float4)(velocity[id].xyz, density[id]);
}
