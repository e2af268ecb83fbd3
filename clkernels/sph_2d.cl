// sph_2d.cl: Unity Graphics Programming vol.1 ch.5, "Fluid simulation by the SPH method"
// (docs/chapters/05-sph-2d.md).
// Weakly compressible SPH in 2D: Poly6 density, Tait pressure, Spiky pressure gradient, viscosity Laplacian,
// penalty walls, symplectic Euler.
// Kernels, in host call order per sub-step (book: RunFluidSolver):
//   1. DensityCS       particles_in -> density: sum over j != i within h of density_coef (h^2 - r^2)^3 (all pairs)
//      DensityCS_grid  the same sum over the particles in the 3x3 grid cells around particle i (search=grid), one
//                      work-item per particle in cell order
//   2. PressureCS      density -> pressure: Tait, B max((rho / rho0)^7 - 1, 0)
//   3. ForceCS         particles_in, density, pressure -> force (= acceleration): pressure + viscosity over j != i
//      ForceCS_grid    the same sums over the 3x3 grid cells around particle i (search=grid)
//   4. IntegrateCS     particles_in, force -> particles_out: mouse push, walls, gravity, v += dt a, x += dt v
//   then the host swaps particles_in and particles_out.
//   For the view only (the water colour, which needs no velocity):
//   5. PackPositions   particles_in -> positions: 8 bytes a particle for GL instead of the record's 16
// Grid variant (ugpcl, search=grid; docs/chapters/05-sph-2d.md): the host sorts the particles by cell with
// ugpcl.grid.UniformGrid (grid.h; cell size >= h) before step 1 and copies them in that order into sorted_particles
// (GridCopyItemsInCellOrder), and the *_grid kernels replace DensityCS and ForceCS: the same per-pair maths over the
// 3x3 cells around a particle instead of all N. They run one work-item per sorted slot k (particle
// P_ID = grid_item(keys[k])), so the work-items of a cell read the same neighbours from consecutive addresses, and
// write density[P_ID], force[P_ID]: every buffer the host sees stays in particle order. The neighbours are visited
// in grid.h's order (cells by id, a cell's particles by index), as when these kernels read particles_in through the
// keys: the copy changes where a neighbour is read, not the sums. PressureCS and IntegrateCS are shared.
// Build defines: none required (the book's THREAD_SIZE_X 1024 is the host's local size: no local memory, any size).
// Every kernel guards i < n and loops over real particles only (j < n), never over the padding of the global size.
// Differences from the book (all guard a division by zero that gives NaN there):
//   - a pair closer than MIN_PAIR_DISTANCE * h is skipped in the force (book: (h - r)^2 / r with r = 0);
//   - a particle of density 0 (no neighbour within h: the density excludes itself) gets acceleration 0 (book: 0/0),
//     and a neighbour of density 0 (only possible through float underflow) adds nothing;
//   - the mouse pushes nothing at its exact centre (book: normalize(0)).
// and one for stability (variant=fixed, the host's default; variant=book passes min_density = 0):
//   - ForceCS divides by max(density, min_density), min_density = density_coef h^6 (the own Poly6 term the book's
//     density leaves out). Inside the water (density ~ 8 against 0.41 in the scene) nothing changes; two spray
//     particles of density ~ 0 no longer exchange velocity with a gain far above 1 per sub-step (a viscous blow-up).
#include "grid.h"    // grid_neighbours: the one neighbour-cell loop of the shared uniform grid (ugpcl.grid)
#include "sph_2d.h"  // FluidParticle {float2 position, velocity}: 16 B; numpy mirror PARTICLE_DTYPE

#define TAIT_GAMMA 7               // book: pow(density / _RestDensity, 7) in CalculatePressure
#define MIN_PAIR_DISTANCE 1.0e-6f  // pairs closer than this times h are coincident: no direction to push along

// {{{ the book's per-pair maths (SPH2D.compute: CalculateDensity, CalculatePressure, CalculateGradPressure,
// CalculateLapVelocity); the mass is folded into the coefficients on the host

// Poly6: density_coef (h^2 - r^2)^3, density_coef = m 4 / (pi h^8); only r^2 is needed.
inline float calculate_density(float r_sq, float h_sq, float density_coef) {
    const float d = h_sq - r_sq;
    return density_coef * d * d * d;
}

// Tait equation, negative pressure clamped to 0.
inline float calculate_pressure(float density, float pressure_stiffness, float rest_density) {
    return pressure_stiffness * fmax(pown(density / rest_density, TAIT_GAMMA) - 1.0f, 0.0f);
}

// Spiky gradient with the symmetric mean pressure; grad_pressure_coef = m (-30) / (pi h^5) < 0, so with
// diff = x_j - x_i the term pushes i away from j.
inline float2 calculate_grad_pressure(float r, float P_pressure, float N_pressure, float N_density, float2 diff,
                                      float h, float grad_pressure_coef) {
    const float avg_pressure = 0.5f * (N_pressure + P_pressure);
    return grad_pressure_coef * avg_pressure / N_density * (h - r) * (h - r) / r * diff;
}

// Laplacian of the viscosity kernel: lap_viscosity_coef = m 20 / (3 pi h^5).
inline float2 calculate_lap_velocity(float r, float2 P_velocity, float2 N_velocity, float N_density, float h,
                                     float lap_viscosity_coef) {
    const float2 vel_diff = N_velocity - P_velocity;
    return lap_viscosity_coef / N_density * (h - r) * vel_diff;
}

// }}}

// {{{ neighbour sums shared by the all-pairs and the grid kernels

typedef struct {
    float2 press;  // book: press, sum of CalculateGradPressure
    float2 visco;  // book: visco, sum of CalculateLapVelocity
} ForceSums;

typedef struct {
    float h, h_sq, grad_pressure_coef, lap_viscosity_coef;
    float min_density;  // variant=fixed: densities divided by are at least this (book: 0)
} ForceCoefs;

// Density contribution of neighbour N_ID to the particle at P_position (0 outside the radius).
inline float density_term(const __global FluidParticle* particles, int N_ID, float2 P_position, float h_sq,
                          float density_coef) {
    const float2 diff = particles[N_ID].position - P_position;
    const float r_sq = dot(diff, diff);
    return r_sq < h_sq ? calculate_density(r_sq, h_sq, density_coef) : 0.0f;  // exclude those outside the radius
}

// Pressure and viscosity of the neighbour at particles[N_record] added to the sums of particle P (book: ForceCS loop
// body). Its density and pressure are at its ID: N_record itself, or grid_item(keys[N_record]) when `particles` is
// the grid's cell-ordered copy (keys != 0; read only for neighbours within h).
inline void force_term(ForceSums* sums, const ForceCoefs* c, const __global FluidParticle* particles, int N_record,
                       const __global ulong* keys, const __global float* density, const __global float* pressure,
                       FluidParticle P, float P_pressure) {
    const FluidParticle N = particles[N_record];
    const float2 diff = N.position - P.position;
    const float r_sq = dot(diff, diff);
    if (r_sq >= c->h_sq) return;  // outside the radius
    const int N_ID = keys ? grid_item(keys[N_record]) : N_record;
    const float r = sqrt(r_sq);
    const float N_density = fmax(density[N_ID], c->min_density);
    if (r < MIN_PAIR_DISTANCE * c->h || N_density <= 0.0f) return;  // coincident pair / empty neighbour: no NaN
    sums->press += calculate_grad_pressure(r, P_pressure, pressure[N_ID], N_density, diff, c->h, c->grad_pressure_coef);
    sums->visco += calculate_lap_velocity(r, P.velocity, N.velocity, N_density, c->h, c->lap_viscosity_coef);
}

// Book: acceleration = (press + viscosity visco) / density; an isolated particle (density 0) accelerates by 0.
inline float2 acceleration_of(const ForceSums* sums, const ForceCoefs* c, float viscosity, float P_density) {
    P_density = fmax(P_density, c->min_density);
    return P_density > 0.0f ? (sums->press + viscosity * sums->visco) / P_density : (float2)(0.0f);
}

// }}}

// {{{ 1. density

__kernel void DensityCS(const __global FluidParticle* particles_in, __global float* density, int n, float h,
                        float density_coef) {
    const int P_ID = get_global_id(0);
    if (P_ID >= n) return;
    const float h_sq = h * h;
    const float2 P_position = particles_in[P_ID].position;
    float sum = 0.0f;
    for (int N_ID = 0; N_ID < n; N_ID++) {  // all pairs, O(n^2), as the book
        if (N_ID == P_ID) continue;         // skip own ID: the self term is excluded (book)
        sum += density_term(particles_in, N_ID, P_position, h_sq, density_coef);
    }
    density[P_ID] = sum;
}

// The same sum over the particles in the 3x3 cells around P (cell size >= h: every neighbour within h is there),
// for the particle in sorted slot P_slot; sorted_particles = particles_in in the grid's cell order.
__kernel void DensityCS_grid(const __global FluidParticle* sorted_particles, __global float* density, int n, float h,
                             float density_coef, float4 origin, float cell_size, int4 dims,
                             const __global ulong* keys, const __global int* cell_start, const __global int* cell_end) {
    const int P_slot = get_global_id(0);
    if (P_slot >= n) return;
    const float h_sq = h * h;
    const float2 P_position = sorted_particles[P_slot].position;
    const int4 home = grid_cell_coord((float3)(P_position, 0.0f), origin.xyz, cell_size, dims);  // 2D: 3x3 cells
    float sum = 0.0f;
    GRID_FOR_EACH_NEIGHBOUR_KEY(N_slot, home, dims, cell_start, cell_end) {
        if (N_slot == P_slot) continue;  // skip own ID (book)
        sum += density_term(sorted_particles, N_slot, P_position, h_sq, density_coef);
    }
    density[grid_item(keys[P_slot])] = sum;
}

// }}}

// {{{ 2. pressure

__kernel void PressureCS(const __global float* density, __global float* pressure, int n, float pressure_stiffness,
                         float rest_density) {
    const int P_ID = get_global_id(0);
    if (P_ID >= n) return;
    pressure[P_ID] = calculate_pressure(density[P_ID], pressure_stiffness, rest_density);
}

// }}}

// {{{ 3. force

__kernel void ForceCS(const __global FluidParticle* particles_in, const __global float* density,
                      const __global float* pressure, __global float2* force, int n, float h,
                      float grad_pressure_coef, float lap_viscosity_coef, float viscosity, float min_density) {
    const int P_ID = get_global_id(0);
    if (P_ID >= n) return;
    const ForceCoefs c = {h, h * h, grad_pressure_coef, lap_viscosity_coef, min_density};
    const FluidParticle P = particles_in[P_ID];
    const float P_pressure = pressure[P_ID];
    ForceSums sums = {(float2)(0.0f), (float2)(0.0f)};
    for (int N_ID = 0; N_ID < n; N_ID++) {  // all pairs, O(n^2), as the book
        if (N_ID == P_ID) continue;         // skip own ID
        force_term(&sums, &c, particles_in, N_ID, 0, density, pressure, P, P_pressure);
    }
    force[P_ID] = acceleration_of(&sums, &c, viscosity, density[P_ID]);  // book: _ParticlesForceBufferWrite.acceleration
}

// For the particle in sorted slot P_slot, as DensityCS_grid; density and pressure are in particle order.
__kernel void ForceCS_grid(const __global FluidParticle* sorted_particles, const __global float* density,
                           const __global float* pressure, __global float2* force, int n, float h,
                           float grad_pressure_coef, float lap_viscosity_coef, float viscosity, float min_density,
                           float4 origin, float cell_size, int4 dims, const __global ulong* keys,
                           const __global int* cell_start, const __global int* cell_end) {
    const int P_slot = get_global_id(0);
    if (P_slot >= n) return;
    const ForceCoefs c = {h, h * h, grad_pressure_coef, lap_viscosity_coef, min_density};
    const int P_ID = grid_item(keys[P_slot]);
    const FluidParticle P = sorted_particles[P_slot];
    const float P_pressure = pressure[P_ID];
    const int4 home = grid_cell_coord((float3)(P.position, 0.0f), origin.xyz, cell_size, dims);  // 2D: 3x3 cells
    ForceSums sums = {(float2)(0.0f), (float2)(0.0f)};
    GRID_FOR_EACH_NEIGHBOUR_KEY(N_slot, home, dims, cell_start, cell_end) {
        if (N_slot == P_slot) continue;  // skip own ID
        force_term(&sums, &c, sorted_particles, N_slot, keys, density, pressure, P, P_pressure);
    }
    force[P_ID] = acceleration_of(&sums, &c, viscosity, density[P_ID]);
}

// }}}

// {{{ 4. integrate

// Book: IntegrateCS. The walls are the book's penalty planes (1,0,0), (0,1,0), (-1,0,range.x), (0,-1,range.y):
// a particle a distance d outside a wall is pushed back by wall_stiffness * d.
__kernel void IntegrateCS(const __global FluidParticle* particles_in, const __global float2* force,
                          __global FluidParticle* particles_out, int n, float dt, float wall_stiffness, float2 gravity,
                          float2 range, float2 mouse_pos, float mouse_radius, float mouse_gain, int mouse_down) {
    const int P_ID = get_global_id(0);
    if (P_ID >= n) return;
    float2 position = particles_in[P_ID].position;
    float2 velocity = particles_in[P_ID].velocity;
    float2 acceleration = force[P_ID];

    // mouse: push away from the cursor, harder the closer to it (book: 100 * pushBack * normalize(dir))
    const float2 dir = position - mouse_pos;
    const float dist_to_mouse = length(dir);
    if (mouse_down && dist_to_mouse < mouse_radius && dist_to_mouse > 0.0f) {  // at the exact centre: no direction
        acceleration += mouse_gain * (mouse_radius - dist_to_mouse) * (dir / dist_to_mouse);
    }

    // walls (penalty method): -wall_stiffness * min(signed distance to the plane, 0) along the plane's normal
    acceleration.x += -wall_stiffness * fmin(position.x, 0.0f);            // left:   x >= 0
    acceleration.y += -wall_stiffness * fmin(position.y, 0.0f);            // bottom: y >= 0
    acceleration.x += wall_stiffness * fmin(range.x - position.x, 0.0f);   // right:  x <= range.x
    acceleration.y += wall_stiffness * fmin(range.y - position.y, 0.0f);   // top:    y <= range.y

    acceleration += gravity;

    // the book's "forward Euler" is symplectic: the position moves with the new velocity
    velocity += dt * acceleration;
    position += dt * velocity;
    particles_out[P_ID].position = position;
    particles_out[P_ID].velocity = velocity;
}

// }}}

// The view's copy of the positions alone (viewer/views/sph_2d.py, colour mode water): GL takes host data at about
// 4 GB/s on the lent H200, so a million particles' velocities (8 MB a frame) are left on the device when not shown.
__kernel void PackPositions(const __global FluidParticle* particles_in, __global float2* positions, int n) {
    const int i = get_global_id(0);
    if (i < n) positions[i] = particles_in[i].position;
}
