// space_colonization.cl: Unity Graphics Programming vol.4 ch.1, "GPU-Based Space Colonization Algorithm"
// (docs/chapters/12-space-colonization.md), the book's SpaceColonization.compute.
// Host: ugpcl/scenes/space_colonization.py (Simulation).
// Kernels, in host call order (reset: Setup, Seed, then one step; every step: Search .. Remove while the node pool
// is not empty, then always Grow):
//   1. Setup         all node slots -> node pool (slot 0 on top: see Setup), nodes[i].active = 0
//   2. Seed          seeds -> nodes (Consume a slot each): t = 1, from = -1, mass = lerp(min, max, nrand)
//   3. Search        nodes -> attractions.nearest/found: nearest active node closer than the influence distance
//   4. Attract       attractions, nodes -> candidates (Append): node + growth * mean unit vector to its attractions,
//                    for every active node with t >= 1 that some attraction found
//   5. ConnectCount  node pool and candidate counters -> connect_count = min(free slots, candidates), one work-item
//                    (ugpcl: the book's host reads both counters back; here the host does not wait)
//      Connect       candidates (Consume), node pool (Consume) -> nodes (new child, t = 0), edges (Append)
//   6. Remove        nodes -> attractions.active = 0 within the kill distance of any active node
//   7. Grow          nodes.t += dT * mass, clamped to 1
// Tiled variants (ugpcl; what GPUs and Oclgrind run for search = all_pairs; same results, see below):
//   Search_tiled    as Search, its loop over the node slots read through __local tiles
//   Attract_tiled   as Attract, its loop over the attractions read through __local tiles
//   Remove_tiled    as Remove, its loop over the node slots read through __local tiles
// Uniform-grid variants (ugpcl, Params.search = grid; same results, see below):
//   NodeGridHash   nodes -> grid keys of the active nodes (inactive slots get GRID_EMPTY_KEY and sort last);
//                  then grid.cl's counting sort: GridCountCells, the scan, GridScatter, GridSortCells (UniformGrid.sort)
//   Search_grid    as Search, visiting the 3x3x3 node-grid cells around the attraction (cell >= influence)
//   Attract_grid   as Attract, visiting the 3x3x3 attraction-grid cells around the node (cell >= influence)
//   Remove_grid    as Remove, visiting the 3x3x3 node-grid cells around the attraction (cell >= kill)
// View (ugpcl, each frame of the viewer on a GPU; CPU devices count on the host):
//   CountActiveAttractions  attractions -> active_count += the active ones (the status line's count)
// Build defines: none (the book's [numthreads(128,1,1)] is the host's local size, and TILE below).
// Atomics: the Append/Consume counters of pool.h (node pool, candidates, edges) and CountActiveAttractions' sum.
// No more consumers than items: Connect's work-items past connect_count (= min(free node slots, candidates),
// ConnectCount) return at once.
// Races: none. Every kernel writes only its own record; Connect reads a parent (an active node) and writes a child
// (a slot taken from the pool, hence inactive), so the two sets never meet. The book's Connect also rewrites the
// parent unchanged (`_Nodes[c.node] = n1`): a no-op left out here.
// Differences from the book: an attraction closer than MIN_DIRECTION to its node is skipped in Attract (the book
// adds normalize(0) = NaN); `repeat_guard` (on by default; `--set repeat_guard=false` is the book) stops a node
// emitting its last candidate again or one that sits on the node itself.
// Tiles: the book's loops (Search, Attract, Remove) have every work-item read every node slot (attraction) from
// global memory, one record after another, so on a GPU (few warps: one work-item per attraction or slot) each
// iteration waits on the cache. The _tiled variants have a work-group copy TILE records at a time into __local memory,
// each work-item then walks the tile: the same records in the same order with the same arithmetic, so the same
// results bit for bit. CPU devices keep the book's loops, which PoCL runs faster (no work-group loop per tile).
#include "grid.h"                // grid_neighbours: the one neighbour-cell loop of the sorted-key uniform grid
#include "pool.h"                // pool_append, pool_consume
#include "random.h"              // nrand (the book's Random.cginc): the node masses
#include "space_colonization.h"  // Attraction, Node, Candidate, Edge; repeats

// CreateNode: take a free slot and return a fresh active record for it (-1 when the pool is empty, which the host
// rules out by never dispatching more consumers than free slots).
inline int create_node(volatile __global int* node_pool_counter, const __global int* node_pool, Node* node) {
    const int slot = pool_consume(node_pool_counter);  // old count - 1 = the top of the pool (LIFO)
    node->px = node->py = node->pz = 0.0f;
    node->t = 0.0f;
    node->offset = 0.0f;
    node->from = -1;
    node->mass = 0.0f;
    node->active = 1u;
    return slot < 0 ? -1 : node_pool[slot];
}

// CreateEdge: append (a, b) to the edge buffer (capacity 2A in the book; only A - seeds edges can ever exist).
inline void create_edge(volatile __global int* edge_counter, __global Edge* edges, int edge_capacity, int a, int b) {
    const int slot = pool_append(edge_counter, edge_capacity);  // old count = the next free entry
    if (slot >= 0) edges[slot] = (Edge){a, b};
}

// Book: _NodesPoolAppend.Append(i), in atomic order. ugpcl writes slot i to pool entry slot_count - 1 - i instead
// (the host sets the pool's count to slot_count): the top of the pool is slot 0, so nodes take slots 0, 1, 2, ...
// and, since no node is ever freed during a run, the live nodes are exactly slots [0, live nodes): the prefix the
// views read back and draw.
__kernel void Setup(__global Node* nodes, int slot_count, __global int* node_pool) {
    const int i = get_global_id(0);
    if (i >= slot_count) return;
    node_pool[slot_count - 1 - i] = i;
    nodes[i].active = 0u;
}

__kernel void Seed(const __global float* seeds, int seed_count, __global Node* nodes,
                   volatile __global int* node_pool_counter, const __global int* node_pool, float mass_min,
                   float mass_max) {
    const int i = get_global_id(0);
    if (i >= seed_count) return;
    Node n;
    const int j = create_node(node_pool_counter, node_pool, &n);
    if (j < 0) return;
    const float3 seed = vload3(i, seeds);  // seeds are packed float3 (12-byte stride, as the book's buffer)
    n.px = seed.x;
    n.py = seed.y;
    n.pz = seed.z;
    n.t = 1.0f;  // seeds are grown: they branch in the first step
    n.offset = 0.0f;
    n.from = -1;
    n.mass = mix(mass_min, mass_max, nrand((float2)((float)i, 0.0f)));  // book: nrand(id.xy)
    nodes[j] = n;
}

__kernel void Search(__global Attraction* attractions, int attraction_count, const __global Node* nodes,
                     int slot_count, float influence_distance) {
    const int idx = get_global_id(0);
    if (idx >= attraction_count) return;
    Attraction attr = attractions[idx];
    attr.found = 0u;
    if (!attr.active) return;  // book: inactive attractions keep their stale `found`
    float min_dist = influence_distance;
    for (int i = 0; i < slot_count; i++) {  // every node slot, inactive ones skipped (the book's loop)
        const Node n = nodes[i];
        if (!n.active) continue;
        const float d = length(POSITION(attr) - POSITION(n));
        if (d < min_dist) {  // strict: ties keep the lower index
            min_dist = d;
            attr.nearest = i;
            attr.found = 1u;
        }
    }
    attractions[idx] = attr;
}

// Add the unit vector from a node at `position` to an attraction (at `attraction`) that chose it.
inline void pull_towards(float3 attraction, float3 position, float3* dir, int* counter) {
    const float3 to_attraction = attraction - position;
    if (length(to_attraction) < MIN_DIRECTION) return;  // a seed sitting on its attraction: no direction
    *dir += normalize(to_attraction);
    *counter += 1;
}

// Sum of unit vectors from node `idx` to the attractions that chose it.
inline void attract_direction(Attraction attr, int idx, float3 position, float3* dir, int* counter) {
    if (attr.active && attr.found && attr.nearest == idx) pull_towards(POSITION(attr), position, dir, counter);
}

// The end of Attract: the candidate at the mean direction (not renormalised: a step <= growth_distance).
inline void emit_candidate(int idx, float3 position, float3 dir, int counter, float growth_distance, int repeat_guard,
                           __global float4* last_candidate, volatile __global int* candidate_counter,
                           __global Candidate* candidates, int candidate_capacity) {
    if (counter == 0) return;
    const float3 c = position + dir / (float)counter * growth_distance;
    if (repeat_guard) {
        if (repeats(last_candidate[idx], position, c, growth_distance)) return;
        last_candidate[idx] = (float4)(c, 1.0f);
    }
    const int slot = pool_append(candidate_counter, candidate_capacity);  // old count = this candidate's entry
    if (slot >= 0) candidates[slot] = (Candidate){c.x, c.y, c.z, idx};
}

__kernel void Attract(const __global Attraction* attractions, int attraction_count, const __global Node* nodes,
                      int slot_count, float growth_distance, int repeat_guard, __global float4* last_candidate,
                      volatile __global int* candidate_counter, __global Candidate* candidates,
                      int candidate_capacity) {
    const int idx = get_global_id(0);
    if (idx >= slot_count) return;
    const Node n = nodes[idx];
    if (!(n.active && n.t >= 1.0f)) return;  // only grown nodes branch
    float3 dir = (float3)(0.0f);
    int counter = 0;
    for (int i = 0; i < attraction_count; i++) attract_direction(attractions[i], idx, POSITION(n), &dir, &counter);
    emit_candidate(idx, POSITION(n), dir, counter, growth_distance, repeat_guard, last_candidate, candidate_counter,
                   candidates, candidate_capacity);
}

// connect_count = min(free node slots, candidates) (book: Mathf.Min(nodesCount, CopyCount(candidates)) on the host),
// taken from the two counters before Connect changes them.
__kernel void ConnectCount(const __global int* node_pool_counter, const __global int* candidate_counter,
                           __global int* connect_count) {
    if (get_global_id(0) == 0) *connect_count = min(node_pool_counter[POOL_COUNT], candidate_counter[POOL_COUNT]);
}

__kernel void Connect(__global Node* nodes, volatile __global int* node_pool_counter, const __global int* node_pool,
                      volatile __global int* candidate_counter, const __global Candidate* candidates,
                      volatile __global int* edge_counter, __global Edge* edges, int edge_capacity,
                      const __global int* connect_count, float mass_min, float mass_max) {
    const int id = get_global_id(0);
    if (id >= *connect_count) return;  // ConnectCount: min(free node slots, candidates)
    const int slot = pool_consume(candidate_counter);  // old count - 1: the last appended candidates go first
    if (slot < 0) return;
    const Candidate c = candidates[slot];
    Node n2;
    const int idx2 = create_node(node_pool_counter, node_pool, &n2);
    if (idx2 < 0) return;
    n2.px = c.px;
    n2.py = c.py;
    n2.pz = c.pz;
    n2.offset = nodes[c.node].offset + 1.0f;  // one edge deeper than its parent
    n2.from = c.node;
    n2.mass = mix(mass_min, mass_max, nrand((float2)((float)c.node, (float)idx2)));
    nodes[idx2] = n2;
    create_edge(edge_counter, edges, edge_capacity, c.node, idx2);
}

__kernel void Remove(__global Attraction* attractions, int attraction_count, const __global Node* nodes,
                     int slot_count, float kill_distance) {
    const int idx = get_global_id(0);
    if (idx >= attraction_count) return;
    Attraction attr = attractions[idx];
    if (!attr.active) return;
    for (int i = 0; i < slot_count; i++) {
        const Node n = nodes[i];
        if (n.active && distance(POSITION(attr), POSITION(n)) < kill_distance) {
            attr.active = 0u;
            attractions[idx] = attr;
            return;
        }
    }
}

__kernel void Grow(__global Node* nodes, int slot_count, float dT) {
    const int idx = get_global_id(0);
    if (idx >= slot_count) return;
    Node n = nodes[idx];
    if (!n.active) return;
    n.t = clamp(n.t + dT * n.mass, 0.0f, 1.0f);  // book: saturate; dT = dt * growthSpeed
    nodes[idx] = n;
}

// {{{ tiled variants (ugpcl): the loops of Search, Attract and Remove through __local tiles, the same results

#define TILE 128  // work-group size of the tiled kernels = records per __local tile (LOCAL_SIZE on the host)

// A node as the tiled loops read it: position, w = 1 for an active node, 0 for a free slot or past slot_count.
inline float4 node_tile_entry(const __global Node* nodes, int i, int slot_count) {
    if (i >= slot_count) return (float4)(0.0f);
    const Node n = nodes[i];
    return (float4)(n.px, n.py, n.pz, n.active ? 1.0f : 0.0f);
}

// An attraction as Attract_tiled reads it: its position and the node it pulls (-1: none, or not active).
typedef struct {
    float px, py, pz;
    int node;
} PullingAttraction;

inline PullingAttraction pulling_attraction(const __global Attraction* attractions, int i) {
    const Attraction a = attractions[i];
    return (PullingAttraction){a.px, a.py, a.pz, a.active && a.found ? a.nearest : -1};
}

// Search; padding work-items (and inactive attractions) load their share of each tile and write nothing.
__kernel __attribute__((reqd_work_group_size(TILE, 1, 1)))
void Search_tiled(__global Attraction* attractions, int attraction_count, const __global Node* nodes, int slot_count,
                  float influence_distance) {
    __local float4 tile[TILE];  // node_tile_entry of slots base .. base + TILE - 1
    const int idx = get_global_id(0), lid = get_local_id(0);
    Attraction attr = {0};  // padding work-items: an inactive record (reading a real one races with its owner)
    if (idx < attraction_count) attr = attractions[idx];
    const bool mine = attr.active;  // book: inactive attractions keep their stale `found`
    attr.found = 0u;
    float min_dist = influence_distance;
    for (int base = 0; base < slot_count; base += TILE) {
        tile[lid] = node_tile_entry(nodes, base + lid, slot_count);
        barrier(CLK_LOCAL_MEM_FENCE);  // the tile is complete before anyone reads it
        for (int t = 0; mine && t < min(TILE, slot_count - base); t++) {
            if (tile[t].w == 0.0f) continue;
            const float d = length(POSITION(attr) - tile[t].xyz);
            if (d < min_dist) {  // strict: ties keep the lower index
                min_dist = d;
                attr.nearest = base + t;
                attr.found = 1u;
            }
        }
        barrier(CLK_LOCAL_MEM_FENCE);  // everyone is done with the tile before the next one overwrites it
    }
    if (mine) attractions[idx] = attr;
}

// Attract: the attractions pulling this node summed in index order, as the book's loop does.
__kernel __attribute__((reqd_work_group_size(TILE, 1, 1)))
void Attract_tiled(const __global Attraction* attractions, int attraction_count, const __global Node* nodes,
                   int slot_count, float growth_distance, int repeat_guard, __global float4* last_candidate,
                   volatile __global int* candidate_counter, __global Candidate* candidates, int candidate_capacity) {
    __local PullingAttraction tile[TILE];  // attractions base .. base + TILE - 1
    const int idx = get_global_id(0), lid = get_local_id(0);
    const Node n = nodes[min(idx, slot_count - 1)];
    const bool mine = idx < slot_count && n.active && n.t >= 1.0f;  // only grown nodes branch
    float3 dir = (float3)(0.0f);
    int counter = 0;
    for (int base = 0; base < attraction_count; base += TILE) {
        if (base + lid < attraction_count) tile[lid] = pulling_attraction(attractions, base + lid);
        barrier(CLK_LOCAL_MEM_FENCE);
        for (int t = 0; mine && t < min(TILE, attraction_count - base); t++) {
            if (tile[t].node == idx) pull_towards(POSITION(tile[t]), POSITION(n), &dir, &counter);
        }
        barrier(CLK_LOCAL_MEM_FENCE);
    }
    if (mine) {
        emit_candidate(idx, POSITION(n), dir, counter, growth_distance, repeat_guard, last_candidate, candidate_counter,
                       candidates, candidate_capacity);
    }
}

__kernel __attribute__((reqd_work_group_size(TILE, 1, 1)))
void Remove_tiled(__global Attraction* attractions, int attraction_count, const __global Node* nodes, int slot_count,
                  float kill_distance) {
    __local float4 tile[TILE];  // node_tile_entry of slots base .. base + TILE - 1
    const int idx = get_global_id(0), lid = get_local_id(0);
    Attraction attr = {0};  // padding work-items: an inactive record (reading a real one races with its owner)
    if (idx < attraction_count) attr = attractions[idx];
    bool alive = attr.active;  // still looking for a node within the kill distance
    bool killed = false;
    for (int base = 0; base < slot_count; base += TILE) {
        tile[lid] = node_tile_entry(nodes, base + lid, slot_count);
        barrier(CLK_LOCAL_MEM_FENCE);
        for (int t = 0; alive && t < min(TILE, slot_count - base); t++) {
            if (tile[t].w != 0.0f && distance(POSITION(attr), tile[t].xyz) < kill_distance) {
                alive = false;  // book: the first node within the kill distance ends the loop
                killed = true;
            }
        }
        barrier(CLK_LOCAL_MEM_FENCE);
    }
    if (killed) {
        attr.active = 0u;
        attractions[idx] = attr;
    }
}

// }}}

// {{{ uniform-grid variants (ugpcl): the same results as the all-pairs loops above

// Keys of the active nodes; inactive slots and padding get GRID_EMPTY_KEY, which sorts after every real key, so
// the first (active node count) sorted keys are exactly the live nodes.
__kernel void NodeGridHash(const __global Node* nodes, int slot_count, int padded, float4 origin, float cell_size,
                           int4 dims, __global ulong* keys) {
    const int i = get_global_id(0);
    if (i >= padded) return;
    if (i >= slot_count || !nodes[i].active) {
        keys[i] = GRID_EMPTY_KEY;
        return;
    }
    const int cell = grid_cell_id(grid_cell_coord(POSITION(nodes[i]), origin.xyz, cell_size, dims), dims);
    keys[i] = ((ulong)cell << 32) | (ulong)i;
}

#define GRID_ARGS                                                                                       \
    float4 origin, float cell_size, int4 dims, const __global ulong *keys, const __global int *cell_start, \
        const __global int *cell_end

// Search through the node grid. Equal distances keep the lower node index, as the all-pairs loop's strict `<` in
// index order does, so the result is the same whatever order the cells are visited in.
__kernel void Search_grid(__global Attraction* attractions, int attraction_count, const __global Node* nodes,
                          float influence_distance, GRID_ARGS) {
    const int idx = get_global_id(0);
    if (idx >= attraction_count) return;
    Attraction attr = attractions[idx];
    attr.found = 0u;
    if (!attr.active) return;
    float min_dist = influence_distance;
    const int4 home = grid_cell_coord(POSITION(attr), origin.xyz, cell_size, dims);
    GRID_FOR_EACH_NEIGHBOUR_KEY(k, home, dims, cell_start, cell_end) {
        const int i = grid_item(keys[k]);
        const float d = length(POSITION(attr) - POSITION(nodes[i]));
        if (d < min_dist || (attr.found && d == min_dist && i < attr.nearest)) {
            min_dist = d;
            attr.nearest = i;
            attr.found = 1u;
        }
    }
    attractions[idx] = attr;
}

// Attract through the attraction grid. The host stores the attractions sorted by this grid's cell, so the cells
// visited in increasing id order yield the attractions in increasing index: the same sum in the same order as
// the all-pairs loop (bitwise equal candidates).
__kernel void Attract_grid(const __global Attraction* attractions, const __global Node* nodes, int slot_count,
                           float growth_distance, int repeat_guard, __global float4* last_candidate,
                           volatile __global int* candidate_counter, __global Candidate* candidates,
                           int candidate_capacity, GRID_ARGS) {
    const int idx = get_global_id(0);
    if (idx >= slot_count) return;
    const Node n = nodes[idx];
    if (!(n.active && n.t >= 1.0f)) return;
    float3 dir = (float3)(0.0f);
    int counter = 0;
    const int4 home = grid_cell_coord(POSITION(n), origin.xyz, cell_size, dims);
    GRID_FOR_EACH_NEIGHBOUR_KEY(k, home, dims, cell_start, cell_end) {
        attract_direction(attractions[grid_item(keys[k])], idx, POSITION(n), &dir, &counter);
    }
    emit_candidate(idx, POSITION(n), dir, counter, growth_distance, repeat_guard, last_candidate, candidate_counter,
                   candidates, candidate_capacity);
}

__kernel void Remove_grid(__global Attraction* attractions, int attraction_count, const __global Node* nodes,
                          float kill_distance, GRID_ARGS) {
    const int idx = get_global_id(0);
    if (idx >= attraction_count) return;
    Attraction attr = attractions[idx];
    if (!attr.active) return;
    const int4 home = grid_cell_coord(POSITION(attr), origin.xyz, cell_size, dims);
    GRID_FOR_EACH_NEIGHBOUR_KEY(k, home, dims, cell_start, cell_end) {
        if (distance(POSITION(attr), POSITION(nodes[grid_item(keys[k])])) < kill_distance) {
            attr.active = 0u;
            attractions[idx] = attr;
            return;
        }
    }
}

// }}}

// {{{ view (ugpcl)

// The number of active attractions for the viewer's status line, so that a frame reads back 4 bytes instead of every
// attraction record (24 B each: 50 MB at side 160). Each work-group sums its flags in __local memory (a tree over
// TILE entries) and adds its sum with one atomic_add, instead of one atomic per attraction on the same int; the host
// clears active_count first.
__kernel __attribute__((reqd_work_group_size(TILE, 1, 1)))
void CountActiveAttractions(const __global Attraction* attractions, int attraction_count,
                            volatile __global int* active_count) {
    __local int partial[TILE];
    const int idx = get_global_id(0), lid = get_local_id(0);
    partial[lid] = idx < attraction_count && attractions[idx].active ? 1 : 0;
    barrier(CLK_LOCAL_MEM_FENCE);
    for (int width = TILE / 2; width > 0; width /= 2) {
        if (lid < width) partial[lid] += partial[lid + width];
        barrier(CLK_LOCAL_MEM_FENCE);  // this level's sums are in before the next level reads them
    }
    if (lid == 0 && partial[0] > 0) atomic_add(active_count, partial[0]);
}

// }}}
