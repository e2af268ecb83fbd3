// cellular_growth.cl: Unity Graphics Programming vol.3 ch.4, "GPU-Based Cellular Growth"
// (docs/chapters/11-cellular-growth.md), the book's CellularGrowth.compute.
// Host: ugpcl/scenes/cellular_growth.py (ParticleSimulation, Simulation).
//
// Kernels, in host call order. `particles` is the Read buffer of the ping-pong pair; only UpdateParticles reads Read
// and writes Write (then the host swaps). Pools are pool.h Append/Consume stacks of indices (host: ugpcl.buffers.Pool).
//   reset (both scenes)
//     InitParticles           -> particles (all dead), particle_pool (every index, slot 0 on top: see below)
//     InitEdges               -> edges (all dead), edge_pool (every index, slot 0 on top)             [network]
//     EmitParticles           particle_pool (Consume) -> particles: emit_count cells on the unit circle around a point
//   particle-only step (CellularGrowthParticleOnly.cs): [EmitParticles while emitting], UpdateParticles, Divide:
//     UpdateParticles         Read -> Write: grow, all-pairs repulsion, drag and speed limit (ping-pong, no atomics)
//     ParticleGridKeys        (search=grid) particles -> the (cell, index) keys of ugpcl.grid.UniformGrid.sort (dead
//                             slots left out), then UpdateParticles_grid instead of UpdateParticles
//     UpdateParticles_grid    the same, visiting only the 3x3 uniform-grid cells around each cell (ugpcl, search=grid)
//     GetDividableParticles   particles -> dividable (Append): live cells with radius >= 0.95 threshold
//     DivideParticles         dividable, particle_pool (Consume) -> particles: parent and child of half size
//   network step (CellularGrowth.cs): iterations x (UpdateEdges, SpringEdges, UpdateParticles), then Divide:
//     UpdateEdges             particles -> edges.force: spring towards |pa - pb| = ra + rb
//     SpringEdges             edges -> particles.velocity (in place on Read): +-force / links over every edge slot
//     EdgeEndKeys             (search=grid) edges -> (cell, edge end) keys for UniformGrid.sort, a particle slot for a
//                             cell, then SpringEdges_sorted instead of SpringEdges
//     SpringEdges_sorted      the same sums over each cell's own edges only, found through the sorted edge ends
//     GetDividableEdges       particles, edges -> dividable (Append): live edges whose ends are both dividable and
//                             not both at max_link links
//     DivideUnconnectedParticles  (when no edge is dividable) particles with no link -> child + edge
//     DivideEdgesClosed       dividable, pools (Consume) -> particles, edges: child between a and b (ring), or a triangle
//     DivideEdgesBranch       dividable, pools (Consume) -> particles, edges: child hung on the less-linked end (tree)
//   R key (then EmitParticles):
//     ResetParticles          particles -> particle_pool (Append): every live cell dies
//     ResetEdges              edges -> edge_pool (Append): every live edge dies                         [network]
//   view (each frame)
//     LiveSlotEnds            particles, edges -> ends: one past the last live particle slot and edge slot
//
// Build defines: BOOK_TEXT = 1 selects the formulas printed in the book's text (linear growth, child threshold
// lerp(1.25, 2), random offset radius * 0.25, no wobble); 0 (default) the repository's, which made the figures.
// Local size: the book's THREAD = [numthreads(128, 1, 1)] (host GROUP_SIZE); every kernel guards its id.
//
// Pool order (ugpcl): the init kernels fill the pools in a fixed order, slot 0 on top (the book appends in atomic
// order), so consumes hand out slots 0, 1, 2, ... and the live cells and edges fill a prefix of their buffers: the
// view reads back and draws only that prefix (LiveSlotEnds), not the capacity.
//
// Atomics: the pool counters (pool.h), `faults` (consumes that found a pool empty: always 0 when the host limits
// hold), `tickets` (DivideUnconnectedParticles' cap, ugpcl) and the book's InterlockedAdd on Particle.links, here
// atomic_add(&particles[i].links, k).
// Races: the book runs the edge divisions in parallel and tolerates lost updates (marked RACE (book) below); with
// divide_count = 1 every kernel is race-free. DivideUnconnectedParticles of the book also races (a work-item may read
// the dead slot that another one is turning into a child); variant=fixed reads parents from a snapshot instead.
#include "cellular_growth.h"  // Particle (32 B), Edge (20 B), create
#include "grid.h"             // grid_neighbours: the one neighbour-cell loop of the sorted-key uniform grid
#include "pool.h"             // pool_append_index, pool_consume
#include "random.h"           // nrand, random_point_on_circle (the book's Random.cginc)

#ifndef BOOK_TEXT
#error "build with -D BOOK_TEXT=0 (repository formulas) or 1 (the book's text)"
#endif

#define DIVIDE_RATIO 0.95f     // book: dividable_particle, radius / threshold >= 0.95
#define MIN_HALF_RADIUS 0.1f   // book: divide_particle, rh = max(radius * 0.5, 0.1)
#define CLOSED_OFFSET 0.25f    // book: divide_edge_closed, offset = normalize(pb - pa) * pa.radius * 0.25
#define WOBBLE_DISTANCE 1e-4f  // repository: cells closer than this repel along a random direction
#define MIN_EDGE_LENGTH 1e-12f // ugpcl: UpdateEdges skips coincident ends (normalize(0) is NaN)
#if BOOK_TEXT
#define THRESHOLD_LERP_FROM 1.25f                   // book text: child.threshold = rh * lerp(1.25, 2, x)
#define RANDOM_OFFSET(radius) ((radius) * 0.25f)    // book text: random_point_on_circle(...) * radius * 0.25
#else
#define THRESHOLD_LERP_FROM 1.0f                    // repository: rh * lerp(1, 2, x)
#define RANDOM_OFFSET(radius) (0.1f)                // repository: random_point_on_circle(...) * 0.1
#endif

// The compute file's globals (_Particles, _ParticlePoolConsume, _Edges, _EdgePoolConsume, _Time) for the divide
// helpers. `parents` is where divide_particle reads a parent: `particles` itself, or a snapshot of it.
typedef struct {
    __global Particle* particles;
    const __global Particle* parents;
    volatile __global int* particle_pool_counter;
    const __global int* particle_pool;
    __global Edge* edges;
    volatile __global int* edge_pool_counter;
    const __global int* edge_pool;
    volatile __global int* faults;
    float time;
} Globals;

// HLSL `x = pool.Consume()`: the index on top of the pool, or -1 when it is empty. HLSL leaves an empty Consume
// undefined; the host's limits rule it out, and `faults` counts any that happen anyway (tests assert 0).
inline int consume_index(volatile __global int* counter, const __global int* items, volatile __global int* faults) {
    const int slot = pool_consume(counter);  // old count - 1 = the top of the stack (LIFO), -1 when empty
    if (slot < 0) {
        atomic_inc(faults);  // old value unused: a count of empty consumes
        return -1;
    }
    return items[slot];
}

// {{{ reset (both scenes)

// Book: _ParticlePoolAppend.Append(idx). ugpcl writes index idx to pool slot count - 1 - idx instead (the host sets
// the counter to count): the top of the stack is slot 0, so the cells take slots 0, 1, 2, ... (see the header).
__kernel void InitParticles(__global Particle* particles, int count, __global int* particle_pool) {
    const int idx = get_global_id(0);
    if (idx >= count) return;
    Particle p = create();
    p.alive = 0u;  // every slot starts dead
    particles[idx] = p;
    particle_pool[count - 1 - idx] = idx;
}

// Book: _EdgePoolAppend.Append(idx); ugpcl fills the pool in InitParticles' fixed order.
__kernel void InitEdges(__global Edge* edges, int count, __global int* edge_pool) {
    const int idx = get_global_id(0);
    if (idx >= count) return;
    Edge e;
    e.a = e.b = 0;
    e.fx = e.fy = 0.0f;
    e.alive = 0u;
    edges[idx] = e;
    edge_pool[count - 1 - idx] = idx;
}

// Threads id < emit_count (the host passes min(emit_count, pool count)) each wake one dead slot.
__kernel void EmitParticles(__global Particle* particles, volatile __global int* particle_pool_counter,
                            const __global int* particle_pool, volatile __global int* faults, float2 point,
                            int emit_count, float time) {
    const int id = get_global_id(0);
    if (id >= emit_count) return;
    const int idx = consume_index(particle_pool_counter, particle_pool, faults);
    if (idx < 0) return;
    Particle c = create();
    const float fid = (float)id;
    c.position = point + random_point_on_circle((float2)(fid, fid) + (float2)(0.0f, time));  // 1 unit from point
    c.radius = nrand((float2)(fid, fid) + (float2)(time, 0.0f));
    particles[idx] = c;
}
// }}}

// {{{ particles: the particle-only step

// Grow: the radius approaches the threshold.
inline float grown_radius(Particle p, float dt, float grow) {
#if BOOK_TEXT
    return min(p.threshold, p.radius + dt * grow);  // book text: linear
#else
    return min(p.threshold, p.radius + dt * grow * p.radius);  // repository: exponential (a radius of 0 stays 0)
#endif
}

// Repulsion: p (index idx, already grown) is pushed out of every live cell it overlaps.
inline void repel(Particle* p, int idx, Particle other, int j, float repulsion) {
    float2 dir = p->position - other.position;
    const float l = length(dir);
    const float r = (p->radius + other.radius) * repulsion;  // contact distance
    if (l < r) {
#if !BOOK_TEXT
        if (l <= WOBBLE_DISTANCE) dir += random_point_on_circle(p->position + (float2)((float)j, (float)idx));
#endif
        if (dir.x != 0.0f || dir.y != 0.0f) p->velocity += normalize(dir) * (r - l);  // normalize(0) is NaN
    }
}

// Move by the velocity, at most `limit` per update, then damp it and clamp the speed to `limit`.
inline void move(Particle* p, float dt, float drag, float limit) {
    const float2 vel = p->velocity * dt;
    const float vl = length(vel);
    if (vl > 0.0f) {  // book: check velocity length over zero to avoid a NaN position
        p->position += normalize(vel) * min(vl, limit);
        p->velocity = normalize(p->velocity) * min(length(p->velocity) * drag, limit);
    } else {
        p->velocity = (float2)(0.0f, 0.0f);
    }
}

// Book: all pairs over the whole capacity (dead slots included); reads Read, writes Write, so no work-item sees
// another one's update (the ping-pong rationale of the chapter).
__kernel void UpdateParticles(const __global Particle* particles_read, __global Particle* particles, int count,
                              float dt, float grow, float repulsion, float drag, float limit) {
    const int idx = get_global_id(0);
    if (idx >= count) return;
    Particle p = particles_read[idx];
    if (p.alive) {
        p.radius = grown_radius(p, dt, grow);
        for (int i = 0; i < count; i++) {
            const Particle other = particles_read[i];
            if (i == idx || !other.alive) continue;
            repel(&p, idx, other, i, repulsion);
        }
        move(&p, dt, drag, limit);
    }
    particles[idx] = p;  // dead slots too: Write must be fully overwritten
}

// ugpcl.grid.UniformGrid.sort input: a live cell's key as GridHash makes it ((grid cell << 32) | index), and
// GRID_EMPTY_KEY for a dead slot, which then owns no grid cell: the sort costs a pass over the slots, and its
// in-cell ordering (O(items of the cell) per item) stays with the few live cells of a cell, whatever the capacity.
__kernel void ParticleGridKeys(const __global Particle* particles, int count, float4 origin, float cell_size,
                               int4 dims, __global ulong* keys) {
    const int idx = get_global_id(0);
    if (idx >= count) return;
    const Particle p = particles[idx];
    if (!p.alive) {
        keys[idx] = GRID_EMPTY_KEY;
        return;
    }
    const int cell = grid_cell_id(grid_cell_coord((float3)(p.position, 0.0f), origin.xyz, cell_size, dims), dims);
    keys[idx] = ((ulong)cell << 32) | (ulong)idx;
}

// UpdateParticles with the repulsion loop over the 3x3 grid cells around the cell. Cell size >= the largest contact
// distance (radius <= threshold <= 1, so 2 * repulsion), so the same pairs meet; they are summed in cell order
// instead of index order, so results agree with UpdateParticles up to float rounding.
__kernel void UpdateParticles_grid(const __global Particle* particles_read, __global Particle* particles, int count,
                                   float dt, float grow, float repulsion, float drag, float limit, float4 origin,
                                   float cell_size, int4 dims, const __global ulong* keys,
                                   const __global int* cell_start, const __global int* cell_end) {
    const int idx = get_global_id(0);
    if (idx >= count) return;
    Particle p = particles_read[idx];
    if (p.alive) {
        p.radius = grown_radius(p, dt, grow);
        const int4 home = grid_cell_coord((float3)(p.position, 0.0f), origin.xyz, cell_size, dims);  // 2D: 3x3
        GRID_FOR_EACH_NEIGHBOUR_KEY(k, home, dims, cell_start, cell_end) {
            const int i = grid_item(keys[k]);
            const Particle other = particles_read[i];
            if (i == idx || !other.alive) continue;
            repel(&p, idx, other, i, repulsion);
        }
        move(&p, dt, drag, limit);
    }
    particles[idx] = p;
}

// Book: split according to the growth rate (the alternative `nrand((idx, time)) < 0.1` is commented out there).
inline bool dividable_particle(Particle p) { return p.radius / p.threshold >= DIVIDE_RATIO; }

__kernel void GetDividableParticles(const __global Particle* particles, int count,
                                    volatile __global int* dividable_counter, __global int* dividable) {
    const int idx = get_global_id(0);
    if (idx >= count) return;
    const Particle p = particles[idx];
    if (p.alive && dividable_particle(p)) {
        pool_append_index(dividable_counter, dividable, count, idx);
    }
}

// Book: divide_particle(idx, offset). Parent and child get half the radius (at least 0.1) and sit at centre -/+ offset;
// the child's threshold is random in [1, 2] (book text [1.25, 2]) x its radius; the parent keeps its threshold.
// The child's slot is consumed first (the book consumes last), so an empty pool leaves the parent untouched.
// Returns the child's index, or -1 when the particle pool was empty.
inline int divide_particle_offset(const Globals* g, int idx, float2 offset) {
    const int cidx = consume_index(g->particle_pool_counter, g->particle_pool, g->faults);
    if (cidx < 0) return -1;
    Particle parent = g->parents[idx];  // RACE (book): another work-item may be rewriting this cell
    Particle child = create();
    const float rh = max(parent.radius * 0.5f, MIN_HALF_RADIUS);
    parent.radius = child.radius = rh;
    const float2 center = parent.position;
    parent.position = center - offset;
    child.position = center + offset;
    const float x = nrand((float2)(g->time, (float)idx));
    child.threshold = rh * mix(THRESHOLD_LERP_FROM, 2.0f, x);
    g->particles[cidx] = child;
    // The whole parent struct is written back. When two work-items split edges that share this cell, one's
    // position/radius update is lost, and this plain store can erase the other's atomic_add on links.
    g->particles[idx] = parent;  // RACE (book): lost update when two divisions share a cell
    return cidx;
}

// Book: divide_particle(idx), shifting parent and child along a random direction.
inline int divide_particle(const Globals* g, int idx) {
    const Particle parent = g->parents[idx];  // RACE (book): another work-item may be rewriting this cell
    const float2 direction = random_point_on_circle((float2)((float)idx, g->time));
    return divide_particle_offset(g, idx, direction * RANDOM_OFFSET(parent.radius));
}

__kernel void DivideParticles(__global Particle* particles, volatile __global int* particle_pool_counter,
                              const __global int* particle_pool, volatile __global int* dividable_counter,
                              const __global int* dividable, volatile __global int* faults, int divide_count,
                              float time) {
    const int id = get_global_id(0);
    if (id >= divide_count) return;  // the host passes min(dividable, max_divide_count, particle pool)
    const int idx = consume_index(dividable_counter, dividable, faults);
    if (idx < 0) return;
    // distinct parents (each appended once) and distinct children (each consumed once): no two work-items meet
    const Globals g = {particles, particles, particle_pool_counter, particle_pool, 0, 0, 0, faults, time};
    divide_particle(&g, idx);
}
// }}}

// {{{ edges: the network step

// Book: the force that pulls (or pushes) a and b to the distance ra + rb, relative to it, times spring.
__kernel void UpdateEdges(const __global Particle* particles, __global Edge* edges, int count, float spring) {
    const int idx = get_global_id(0);
    if (idx >= count) return;
    Edge e = edges[idx];
    e.fx = e.fy = 0.0f;
    if (e.alive) {
        const Particle pa = particles[e.a];
        const Particle pb = particles[e.b];
        if (pa.alive && pb.alive) {
            const float2 dir = pa.position - pb.position;
            const float r = pa.radius + pb.radius;
            const float len = length(dir);
            if (fabs(len - r) > 0.0f && len > MIN_EDGE_LENGTH && r > 0.0f) {  // ugpcl: no normalize(0), no / 0
                const float l = (len - r) / r;
                const float2 f = normalize(dir) * l * spring;
                e.fx = f.x;
                e.fy = f.y;
            }
        }
    }
    edges[idx] = e;
}

// Book: every live cell scans every edge slot for its own edges; the more links, the weaker each pull.
// count = capacity of both buffers (the book's two GetDimensions calls return the same number).
__kernel void SpringEdges(__global Particle* particles, const __global Edge* edges, int count) {
    const int idx = get_global_id(0);
    if (idx >= count) return;
    Particle p = particles[idx];
    if (!p.alive || p.links <= 0) return;
    const float dif = 1.0f / (float)p.links;
    for (int i = 0; i < count; i++) {
        const Edge e = edges[i];
        if (!e.alive) continue;
        const float2 force = (float2)(e.fx, e.fy);
        if (e.a == idx) {
            p.velocity -= force * dif;
        } else if (e.b == idx) {
            p.velocity += force * dif;
        }
    }
    particles[idx] = p;  // only its own record: in place on Read is safe
}

// search=grid: the keys UniformGrid.sort orders with a particle slot for a grid cell: each live edge's ends,
// (a << 32) | 2 edge and (b << 32) | 2 edge + 1, so each cell's ends come out in edge order. SpringEdges matches
// a loop (a == b) once, at a, and never an end outside the buffer: those ends get GRID_EMPTY_KEY, like dead edges.
__kernel void EdgeEndKeys(const __global Edge* edges, int count, __global ulong* keys) {
    const int idx = get_global_id(0);
    if (idx >= count) return;
    const Edge e = edges[idx];
    const bool a_end = e.alive && e.a >= 0 && e.a < count;
    const bool b_end = e.alive && e.b >= 0 && e.b < count && e.b != e.a;
    keys[2 * idx] = a_end ? ((ulong)e.a << 32) | (ulong)(2 * idx) : GRID_EMPTY_KEY;
    keys[2 * idx + 1] = b_end ? ((ulong)e.b << 32) | (ulong)(2 * idx + 1) : GRID_EMPTY_KEY;
}

// SpringEdges over the cell's own edge ends (ends[end_start[idx]] .. ends[end_stop[idx] - 1], from EdgeEndKeys and
// the sort) instead of every edge slot: the same forces added in the same (edge) order, so the same velocities, in
// O(links) per cell rather than O(capacity).
__kernel void SpringEdges_sorted(__global Particle* particles, const __global Edge* edges, int count,
                                 const __global ulong* ends, const __global int* end_start,
                                 const __global int* end_stop) {
    const int idx = get_global_id(0);
    if (idx >= count) return;
    Particle p = particles[idx];
    if (!p.alive || p.links <= 0) return;
    const float dif = 1.0f / (float)p.links;
    for (int k = end_start[idx]; k < end_stop[idx]; k++) {
        const int end = grid_item(ends[k]);  // 2 edge (this cell is its a) or 2 edge + 1 (its b)
        const Edge e = edges[end >> 1];
        const float2 force = (float2)(e.fx, e.fy);
        if ((end & 1) == 0) {
            p.velocity -= force * dif;
        } else {
            p.velocity += force * dif;
        }
    }
    particles[idx] = p;
}

// Book: dividable_edge - not both ends at max_link links, and both ends dividable.
inline bool dividable_edge(const __global Particle* particles, Edge e, int max_link) {
    const Particle pa = particles[e.a];
    const Particle pb = particles[e.b];
    return !(pa.links >= max_link && pb.links >= max_link) && dividable_particle(pa) && dividable_particle(pb);
}

__kernel void GetDividableEdges(const __global Particle* particles, const __global Edge* edges, int count,
                                volatile __global int* dividable_counter, __global int* dividable, int max_link) {
    const int idx = get_global_id(0);
    if (idx >= count) return;
    const Edge e = edges[idx];
    if (e.alive && dividable_edge(particles, e, max_link)) {
        pool_append_index(dividable_counter, dividable, count, idx);
    }
}

// Book: connect(a, b) - a new edge a-b from the edge pool; both link counters +1.
inline bool connect(const Globals* g, int a, int b) {
    const int eidx = consume_index(g->edge_pool_counter, g->edge_pool, g->faults);
    if (eidx < 0) return false;
    // book: InterlockedAdd(_Particles[a].links, 1): several work-items may connect to the same cell (old value
    // unused). Atomic among themselves, but a plain store of the whole cell (divide_particle_offset) may erase them.
    atomic_add(&g->particles[a].links, 1);  // RACE (book): vs another division's plain store of this cell
    atomic_add(&g->particles[b].links, 1);  // RACE (book): vs another division's plain store of this cell
    Edge e;
    e.a = a;
    e.b = b;
    e.fx = e.fy = 0.0f;
    e.alive = 1u;
    g->edges[eidx] = e;
    return true;
}

// Run over every slot when no edge is dividable: each live cell without links splits and is joined to its child.
// The book dispatches this with no limit; ugpcl (variant=fixed) lets only the first `ticket_limit` work-items
// (= min(particle pool, edge pool), written by the host) proceed, and reads parents from `particles_snapshot`
// (a copy of particles taken before the launch): a work-item whose slot is dead would otherwise race with the one
// writing a child into it, and could split that child. variant=book passes particles itself and no limit.
__kernel void DivideUnconnectedParticles(const __global Particle* particles_snapshot, __global Particle* particles,
                                         int count, volatile __global int* particle_pool_counter,
                                         const __global int* particle_pool, __global Edge* edges,
                                         volatile __global int* edge_pool_counter, const __global int* edge_pool,
                                         volatile __global int* tickets, int ticket_limit,
                                         volatile __global int* faults, float time) {
    const int idx = get_global_id(0);
    if (idx >= count) return;
    const Particle parent = particles_snapshot[idx];
    if (!parent.alive || parent.links > 0) return;
    if (atomic_inc(tickets) >= ticket_limit) return;  // old value = this work-item's ticket: 0, 1, 2 ...
    const Globals g = {particles,  particles_snapshot, particle_pool_counter, particle_pool, edges, edge_pool_counter,
                       edge_pool, faults,             time};
    const int cidx = divide_particle(&g, idx);
    if (cidx >= 0) connect(&g, idx, cidx);
}

// Book: divide_edge_closed. If an end has a single link, a child of a joins both ends (a triangle, fig 4.7: two
// edge slots). Otherwise the child is inserted between a and b: a-c is new and the edge a-b becomes c-b (fig 4.8).
inline void divide_edge_closed(const Globals* g, int idx) {
    Edge e = g->edges[idx];
    // Another work-item may be rewriting a or b (it splits an edge that shares the cell): links may be stale here.
    const Particle pa = g->particles[e.a];  // RACE (book): read while another division writes the cell
    const Particle pb = g->particles[e.b];  // RACE (book): read while another division writes the cell
    if (pa.links == 1 || pb.links == 1) {
        const int cidx = divide_particle(g, e.a);
        if (cidx < 0) return;
        connect(g, e.a, cidx);
        connect(g, cidx, e.b);
    } else {
        const float2 dir = pb.position - pa.position;
        const float len = length(dir);
        const float2 offset = len > 0.0f ? dir / len * pa.radius * CLOSED_OFFSET : (float2)(0.0f, 0.0f);  // no NaN
        const int cidx = divide_particle_offset(g, e.a, offset);
        if (cidx < 0 || !connect(g, e.a, cidx)) return;
        // the edge a-b becomes c-b: a loses the link, c gains it (book: InterlockedAdd -1 / +1; old values unused)
        atomic_add(&g->particles[e.a].links, -1);  // RACE (book): vs another division's plain store of this cell
        atomic_add(&g->particles[cidx].links, 1);
        e.a = cidx;
    }
    g->edges[idx] = e;
}

// Threads id < divide_count: the host passes min(dividable, max_divide_count, particle pool, edge pool) (variant=fixed:
// edge pool / 2, since a triangle takes two edge slots).
__kernel void DivideEdgesClosed(__global Particle* particles, volatile __global int* particle_pool_counter,
                                const __global int* particle_pool, __global Edge* edges,
                                volatile __global int* edge_pool_counter, const __global int* edge_pool,
                                volatile __global int* dividable_counter, const __global int* dividable,
                                volatile __global int* faults, int divide_count, float time) {
    const int id = get_global_id(0);
    if (id >= divide_count) return;
    const int idx = consume_index(dividable_counter, dividable, faults);
    if (idx < 0) return;
    const Globals g = {particles, particles, particle_pool_counter, particle_pool, edges, edge_pool_counter,
                       edge_pool, faults,    time};
    divide_edge_closed(&g, idx);
}

// Book: divide_edge_branch - the end with fewer links (ties: a) splits, and only the child is connected to it.
inline void divide_edge_branch(const Globals* g, int idx) {
    const Edge e = g->edges[idx];
    // As in divide_edge_closed, links may be stale when another work-item splits a or b.
    const Particle pa = g->particles[e.a];  // RACE (book): read while another division writes the cell
    const Particle pb = g->particles[e.b];  // RACE (book): read while another division writes the cell
    const int i = (pb.links >= pa.links) ? e.a : e.b;  // book: lerp(e.b, e.a, step(pa.links, pb.links)) on uints
    const int cidx = divide_particle(g, i);
    if (cidx >= 0) connect(g, i, cidx);
}

__kernel void DivideEdgesBranch(__global Particle* particles, volatile __global int* particle_pool_counter,
                                const __global int* particle_pool, __global Edge* edges,
                                volatile __global int* edge_pool_counter, const __global int* edge_pool,
                                volatile __global int* dividable_counter, const __global int* dividable,
                                volatile __global int* faults, int divide_count, float time) {
    const int id = get_global_id(0);
    if (id >= divide_count) return;  // the host passes min(dividable, max_divide_count, particle pool, edge pool)
    const int idx = consume_index(dividable_counter, dividable, faults);
    if (idx < 0) return;
    const Globals g = {particles, particles, particle_pool_counter, particle_pool, edges, edge_pool_counter,
                       edge_pool, faults,    time};
    divide_edge_branch(&g, idx);
}

// }}}

// {{{ R key

// The compute file has these two (ugpcl binds them to R; the book's scripts never call them).
// Every live cell dies and returns to the particle pool.
__kernel void ResetParticles(__global Particle* particles, int count, volatile __global int* particle_pool_counter,
                             __global int* particle_pool) {
    const int idx = get_global_id(0);
    if (idx >= count || !particles[idx].alive) return;
    particles[idx].alive = 0u;
    pool_append_index(particle_pool_counter, particle_pool, count, idx);
}

// Every live edge dies and returns to the edge pool.
__kernel void ResetEdges(__global Edge* edges, int count, volatile __global int* edge_pool_counter,
                         __global int* edge_pool) {
    const int idx = get_global_id(0);
    if (idx >= count || !edges[idx].alive) return;
    edges[idx].alive = 0u;
    pool_append_index(edge_pool_counter, edge_pool, count, idx);
}

// }}}

// {{{ view

// ends[0] = one past the last live particle slot, or past the last cell a live edge names; ends[1] = one past the
// last live edge slot (the host zeroes both; edge_count = 0 in the particle-only scene). The view reads back and
// draws these prefixes, which the pools' fixed order keeps about as long as the live counts.
__kernel void LiveSlotEnds(const __global Particle* particles, const __global Edge* edges, int count, int edge_count,
                           volatile __global int* ends) {
    __local int group_ends[2];
    const int idx = get_global_id(0);
    if (get_local_id(0) == 0) group_ends[0] = group_ends[1] = 0;
    barrier(CLK_LOCAL_MEM_FENCE);
    if (idx < count && particles[idx].alive) atomic_max(&group_ends[0], idx + 1);  // old values unused
    if (idx < edge_count && edges[idx].alive) {
        const Edge e = edges[idx];
        atomic_max(&group_ends[1], idx + 1);
        atomic_max(&group_ends[0], clamp(max(e.a, e.b) + 1, 0, count));
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    if (get_local_id(0) == 0) {  // one global atomic per group
        if (group_ends[0] > 0) atomic_max(&ends[0], group_ends[0]);
        if (group_ends[1] > 0) atomic_max(&ends[1], group_ends[1]);
    }
}

// }}}
