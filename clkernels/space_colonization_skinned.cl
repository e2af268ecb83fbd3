// space_colonization_skinned.cl: Unity Graphics Programming vol.4 ch.1, section 1.4 "Application"
// (docs/chapters/12-space-colonization.md): the book's SkinnedSpaceColonization.compute. Growth runs on bind-space
// `position`; only Animate writes `animated`.
// Host: ugpcl/scenes/space_colonization_skinned.py (Simulation).
// Kernels, in host call order (construction: SetupSkin; reset: SetupAttractions, Setup, Seed, one step; every step:
// Search .. Remove while the node pool is not empty, Grow, then Animate with the frame's bone matrices):
//    1. SetupSkin         mesh vertices, their bones -> attractions.bone: the bone of the nearest mesh vertex
//    2. SetupAttractions  attractions: active 1, found 0, nearest -1 (the cloud itself is kept between resets)
//    3. Setup             all node slots -> node pool (slot 0 on top), nodes[i].active = 0 (book: SetupNodes)
//    4. Seed              seeds, attractions -> nodes: as the plain Seed, plus animated = position and the bone of
//                         the nearest attraction (all of them, no radius)
//    5. Search            as the plain kernel (bind space)
//    6. Attract           as the plain kernel, and the candidate takes the bone of the nearest attraction pulling it
//    7. ConnectCount      as the plain kernel: connect_count = min(free slots, candidates) on the device
//       Connect           as the plain kernel, plus animated = position, index0 = the candidate's bone
//    8. Remove            as the plain kernel (bind space)
//    9. Grow              as the plain kernel
//   10. Animate           nodes, bind poses, bone matrices -> nodes.animated = (bone * bind) * (position, 1)
// Tiled variants (what GPUs and Oclgrind run; the same results, see space_colonization.cl):
//       Search_tiled      as Search, its loop over the node slots read through __local tiles
//       Attract_tiled     as Attract, its loop over the attractions read through __local tiles
//       Remove_tiled      as Remove, its loop over the node slots read through __local tiles
// Matrices are numpy row-major float[16] per bone: y[r] = sum_c M[r][c] x[c] (Unity's own memory order is
// column-major; the host converts).
// Build defines: none. Atomics: the Append/Consume counters of pool.h only. Races: none (see space_colonization.cl).
#include "pool.h"                // pool_append, pool_consume
#include "random.h"              // nrand (the book's Random.cginc): the node masses
#include "space_colonization.h"  // SkinnedAttraction, SkinnedNode, SkinnedCandidate, Edge

inline int create_node(volatile __global int* node_pool_counter, const __global int* node_pool, SkinnedNode* node) {
    const int slot = pool_consume(node_pool_counter);  // old count - 1 = the top of the pool (LIFO)
    node->px = node->py = node->pz = 0.0f;
    node->ax = node->ay = node->az = 0.0f;
    node->index0 = -1;
    node->t = node->offset = node->mass = 0.0f;
    node->from = -1;
    node->active = 1u;
    return slot < 0 ? -1 : node_pool[slot];
}

__kernel void SetupSkin(__global SkinnedAttraction* attractions, int attraction_count, const __global float* vertices,
                        const __global int* bones, int vertex_count) {
    const int idx = get_global_id(0);
    if (idx >= attraction_count) return;
    SkinnedAttraction attr = attractions[idx];
    int closest = 0;
    float dist = 1e8f;
    for (int i = 0; i < vertex_count; i++) {
        const float l = distance(vload3(i, vertices), POSITION(attr));  // packed float3 vertices
        if (l < dist) {
            dist = l;
            closest = i;
        }
    }
    attr.bone = bones[closest];
    attractions[idx] = attr;
}

__kernel void SetupAttractions(__global SkinnedAttraction* attractions, int attraction_count) {
    const int idx = get_global_id(0);
    if (idx >= attraction_count) return;
    attractions[idx].active = 1u;
    attractions[idx].found = 0u;
    attractions[idx].nearest = -1;
}

// As space_colonization.cl's Setup: slot i at pool entry slot_count - 1 - i (the host sets the count to slot_count),
// so nodes take slots 0, 1, 2, ... and the live nodes are the prefix the view reads back.
__kernel void Setup(__global SkinnedNode* nodes, int slot_count, __global int* node_pool) {
    const int i = get_global_id(0);
    if (i >= slot_count) return;
    node_pool[slot_count - 1 - i] = i;
    nodes[i].active = 0u;
}

__kernel void Seed(const __global float* seeds, int seed_count, const __global SkinnedAttraction* attractions,
                   int attraction_count, __global SkinnedNode* nodes, volatile __global int* node_pool_counter,
                   const __global int* node_pool, float mass_min, float mass_max) {
    const int i = get_global_id(0);
    if (i >= seed_count) return;
    SkinnedNode n;
    const int j = create_node(node_pool_counter, node_pool, &n);
    if (j < 0) return;
    const float3 seed = vload3(i, seeds);
    n.px = n.ax = seed.x;
    n.py = n.ay = seed.y;
    n.pz = n.az = seed.z;
    n.t = 1.0f;
    n.offset = 0.0f;
    n.from = -1;
    n.mass = mix(mass_min, mass_max, nrand((float2)((float)i, 0.0f)));  // book: nrand(id.xy)
    int nearest = 0;
    float dist = 1e8f;
    for (int k = 0; k < attraction_count; k++) {
        const float l = distance(POSITION(attractions[k]), seed);
        if (l < dist) {
            nearest = k;
            dist = l;
        }
    }
    n.index0 = attractions[nearest].bone;
    nodes[j] = n;
}

__kernel void Search(__global SkinnedAttraction* attractions, int attraction_count, const __global SkinnedNode* nodes,
                     int slot_count, float influence_distance) {
    const int idx = get_global_id(0);
    if (idx >= attraction_count) return;
    SkinnedAttraction attr = attractions[idx];
    attr.found = 0u;
    if (!attr.active) return;
    float min_dist = influence_distance;
    for (int i = 0; i < slot_count; i++) {
        const SkinnedNode n = nodes[i];
        if (!n.active) continue;
        const float d = length(POSITION(attr) - POSITION(n));  // bind space, never `animated`
        if (d < min_dist) {
            min_dist = d;
            attr.nearest = i;
            attr.found = 1u;
        }
    }
    attractions[idx] = attr;
}

__kernel void Attract(const __global SkinnedAttraction* attractions, int attraction_count,
                      const __global SkinnedNode* nodes, int slot_count, float growth_distance, int repeat_guard,
                      __global float4* last_candidate, volatile __global int* candidate_counter,
                      __global SkinnedCandidate* candidates, int candidate_capacity) {
    const int idx = get_global_id(0);
    if (idx >= slot_count) return;
    const SkinnedNode n = nodes[idx];
    if (!(n.active && n.t >= 1.0f)) return;
    float3 dir = (float3)(0.0f);
    int counter = 0;
    float dist = 1e8f;
    int nearest = -1;
    for (int i = 0; i < attraction_count; i++) {
        const SkinnedAttraction attr = attractions[i];
        if (!(attr.active && attr.found && attr.nearest == idx)) continue;
        const float3 dir2 = POSITION(attr) - POSITION(n);
        const float l2 = length(dir2);
        if (l2 < MIN_DIRECTION) continue;  // a seed sitting on its attraction: no direction
        dir += normalize(dir2);
        counter++;
        if (l2 < dist) {  // the nearest pulling attraction lends its bone to the candidate
            dist = l2;
            nearest = i;
        }
    }
    if (counter == 0) return;
    const float3 c = POSITION(n) + dir / (float)counter * growth_distance;
    if (repeat_guard) {
        if (repeats(last_candidate[idx], POSITION(n), c, growth_distance)) return;
        last_candidate[idx] = (float4)(c, 1.0f);
    }
    const int slot = pool_append(candidate_counter, candidate_capacity);  // old count = this candidate's entry
    if (slot >= 0) candidates[slot] = (SkinnedCandidate){c.x, c.y, c.z, idx, attractions[nearest].bone};
}

// connect_count = min(free node slots, candidates), as the plain ConnectCount.
__kernel void ConnectCount(const __global int* node_pool_counter, const __global int* candidate_counter,
                           __global int* connect_count) {
    if (get_global_id(0) == 0) *connect_count = min(node_pool_counter[POOL_COUNT], candidate_counter[POOL_COUNT]);
}

__kernel void Connect(__global SkinnedNode* nodes, volatile __global int* node_pool_counter,
                      const __global int* node_pool, volatile __global int* candidate_counter,
                      const __global SkinnedCandidate* candidates, volatile __global int* edge_counter,
                      __global Edge* edges, int edge_capacity, const __global int* connect_count, float mass_min,
                      float mass_max) {
    const int id = get_global_id(0);
    if (id >= *connect_count) return;  // ConnectCount: min(free node slots, candidates)
    const int slot = pool_consume(candidate_counter);  // old count - 1: the last appended candidates go first
    if (slot < 0) return;
    const SkinnedCandidate c = candidates[slot];
    SkinnedNode n2;
    const int idx2 = create_node(node_pool_counter, node_pool, &n2);
    if (idx2 < 0) return;
    n2.px = n2.ax = c.px;
    n2.py = n2.ay = c.py;
    n2.pz = n2.az = c.pz;
    n2.index0 = c.bone;
    n2.offset = nodes[c.node].offset + 1.0f;
    n2.from = c.node;
    n2.mass = mix(mass_min, mass_max, nrand((float2)((float)c.node, (float)idx2)));
    nodes[idx2] = n2;
    const int edge = pool_append(edge_counter, edge_capacity);  // old count = the next free entry
    if (edge >= 0) edges[edge] = (Edge){c.node, idx2};
}

__kernel void Remove(__global SkinnedAttraction* attractions, int attraction_count, const __global SkinnedNode* nodes,
                     int slot_count, float kill_distance) {
    const int idx = get_global_id(0);
    if (idx >= attraction_count) return;
    SkinnedAttraction attr = attractions[idx];
    if (!attr.active) return;
    for (int i = 0; i < slot_count; i++) {
        const SkinnedNode n = nodes[i];
        if (n.active && distance(POSITION(attr), POSITION(n)) < kill_distance) {
            attr.active = 0u;
            attractions[idx] = attr;
            return;
        }
    }
}

__kernel void Grow(__global SkinnedNode* nodes, int slot_count, float dT) {
    const int idx = get_global_id(0);
    if (idx >= slot_count) return;
    SkinnedNode n = nodes[idx];
    if (!n.active) return;
    n.t = clamp(n.t + dT * n.mass, 0.0f, 1.0f);  // book: saturate; dT = dt * growthSpeed
    nodes[idx] = n;
}

// y = M * (x, 1) for a row-major 4x4 matrix (the w row is not needed: bone matrices are affine).
inline float3 transform_point(const __global float* m, float3 x) {
    const float4 p = (float4)(x, 1.0f);
    return (float3)(dot(vload4(0, m), p), dot(vload4(1, m), p), dot(vload4(2, m), p));
}

__kernel void Animate(__global SkinnedNode* nodes, int slot_count, const __global float* bind_poses,
                      const __global float* bone_matrices, int bone_count) {
    const int idx = get_global_id(0);
    if (idx >= slot_count) return;
    SkinnedNode node = nodes[idx];
    if (!node.active || node.index0 < 0 || node.index0 >= bone_count) return;
    // book: mul(mul(m, bind), float4(position, 1)): first into the bone's rest frame, then out by its current pose
    const float3 bind_space = transform_point(bind_poses + 16 * node.index0, POSITION(node));
    const float3 animated = transform_point(bone_matrices + 16 * node.index0, bind_space);
    node.ax = animated.x;
    node.ay = animated.y;
    node.az = animated.z;
    nodes[idx] = node;
}

// {{{ tiled variants: the loops of Search, Attract and Remove through __local tiles (see space_colonization.cl)

#define TILE 128  // work-group size of the tiled kernels = records per __local tile (LOCAL_SIZE on the host)

// A node as the tiled loops read it: bind-space position, w = 1 for an active node, 0 for a free slot or past
// slot_count.
inline float4 node_tile_entry(const __global SkinnedNode* nodes, int i, int slot_count) {
    if (i >= slot_count) return (float4)(0.0f);
    const SkinnedNode n = nodes[i];
    return (float4)(n.px, n.py, n.pz, n.active ? 1.0f : 0.0f);
}

// An attraction as Attract_tiled reads it: its bind-space position and the node it pulls (-1: none, or not active).
typedef struct {
    float px, py, pz;
    int node;
} PullingAttraction;

__kernel __attribute__((reqd_work_group_size(TILE, 1, 1)))
void Search_tiled(__global SkinnedAttraction* attractions, int attraction_count, const __global SkinnedNode* nodes,
                  int slot_count, float influence_distance) {
    __local float4 tile[TILE];  // node_tile_entry of slots base .. base + TILE - 1
    const int idx = get_global_id(0), lid = get_local_id(0);
    SkinnedAttraction attr = {0};  // padding work-items: an inactive record (reading a real one races with its owner)
    if (idx < attraction_count) attr = attractions[idx];
    const bool mine = attr.active;  // inactive attractions keep their stale `found`
    attr.found = 0u;
    float min_dist = influence_distance;
    for (int base = 0; base < slot_count; base += TILE) {
        tile[lid] = node_tile_entry(nodes, base + lid, slot_count);
        barrier(CLK_LOCAL_MEM_FENCE);  // the tile is complete before anyone reads it
        for (int t = 0; mine && t < min(TILE, slot_count - base); t++) {
            if (tile[t].w == 0.0f) continue;
            const float d = length(POSITION(attr) - tile[t].xyz);  // bind space, never `animated`
            if (d < min_dist) {
                min_dist = d;
                attr.nearest = base + t;
                attr.found = 1u;
            }
        }
        barrier(CLK_LOCAL_MEM_FENCE);  // everyone is done with the tile before the next one overwrites it
    }
    if (mine) attractions[idx] = attr;
}

__kernel __attribute__((reqd_work_group_size(TILE, 1, 1)))
void Attract_tiled(const __global SkinnedAttraction* attractions, int attraction_count,
                   const __global SkinnedNode* nodes, int slot_count, float growth_distance, int repeat_guard,
                   __global float4* last_candidate, volatile __global int* candidate_counter,
                   __global SkinnedCandidate* candidates, int candidate_capacity) {
    __local PullingAttraction tile[TILE];  // attractions base .. base + TILE - 1
    const int idx = get_global_id(0), lid = get_local_id(0);
    const SkinnedNode n = nodes[min(idx, slot_count - 1)];
    const bool mine = idx < slot_count && n.active && n.t >= 1.0f;
    float3 dir = (float3)(0.0f);
    int counter = 0;
    float dist = 1e8f;
    int nearest = -1;
    for (int base = 0; base < attraction_count; base += TILE) {
        if (base + lid < attraction_count) {
            const SkinnedAttraction a = attractions[base + lid];
            tile[lid] = (PullingAttraction){a.px, a.py, a.pz, a.active && a.found ? a.nearest : -1};
        }
        barrier(CLK_LOCAL_MEM_FENCE);
        for (int t = 0; mine && t < min(TILE, attraction_count - base); t++) {
            if (tile[t].node != idx) continue;
            const float3 dir2 = POSITION(tile[t]) - POSITION(n);
            const float l2 = length(dir2);
            if (l2 < MIN_DIRECTION) continue;  // a seed sitting on its attraction: no direction
            dir += normalize(dir2);
            counter++;
            if (l2 < dist) {  // the nearest pulling attraction lends its bone to the candidate
                dist = l2;
                nearest = base + t;
            }
        }
        barrier(CLK_LOCAL_MEM_FENCE);
    }
    if (!mine || counter == 0) return;
    const float3 c = POSITION(n) + dir / (float)counter * growth_distance;
    if (repeat_guard) {
        if (repeats(last_candidate[idx], POSITION(n), c, growth_distance)) return;
        last_candidate[idx] = (float4)(c, 1.0f);
    }
    const int slot = pool_append(candidate_counter, candidate_capacity);  // old count = this candidate's entry
    if (slot >= 0) candidates[slot] = (SkinnedCandidate){c.x, c.y, c.z, idx, attractions[nearest].bone};
}

__kernel __attribute__((reqd_work_group_size(TILE, 1, 1)))
void Remove_tiled(__global SkinnedAttraction* attractions, int attraction_count, const __global SkinnedNode* nodes,
                  int slot_count, float kill_distance) {
    __local float4 tile[TILE];  // node_tile_entry of slots base .. base + TILE - 1
    const int idx = get_global_id(0), lid = get_local_id(0);
    SkinnedAttraction attr = {0};  // padding work-items: an inactive record (reading a real one races with its owner)
    if (idx < attraction_count) attr = attractions[idx];
    bool alive = attr.active;  // still looking for a node within the kill distance
    bool killed = false;
    for (int base = 0; base < slot_count; base += TILE) {
        tile[lid] = node_tile_entry(nodes, base + lid, slot_count);
        barrier(CLK_LOCAL_MEM_FENCE);
        for (int t = 0; alive && t < min(TILE, slot_count - base); t++) {
            if (tile[t].w != 0.0f && distance(POSITION(attr), tile[t].xyz) < kill_distance) {
                alive = false;  // the first node within the kill distance ends the loop
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
