// space_colonization.h: the records of Unity Graphics Programming vol.4 ch.1 (GPU space colonization,
// docs/chapters/12-space-colonization.md) and the
// helpers its two kernel files share (space_colonization.cl, space_colonization_skinned.cl).
//
// HLSL packs a float3 in a StructuredBuffer into 12 bytes; an OpenCL float3 is 16 bytes and 16-aligned. Every
// position is therefore three scalar floats, so each struct has exactly the book's size (a test probes sizeof):
//   Attraction         24 B   numpy ugpcl.scenes.space_colonization.ATTRACTION_DTYPE
//   Node               32 B   NODE_DTYPE
//   Candidate          16 B   CANDIDATE_DTYPE
//   Edge                8 B   EDGE_DTYPE
//   SkinnedAttraction  28 B   SKINNED_ATTRACTION_DTYPE
//   SkinnedNode        48 B   SKINNED_NODE_DTYPE
//   SkinnedCandidate   20 B   SKINNED_CANDIDATE_DTYPE
#ifndef UGPCL_SPACE_COLONIZATION_H
#define UGPCL_SPACE_COLONIZATION_H

typedef struct {
    float px, py, pz;  // position
    int nearest;       // index of the nearest node (-1: none; book: uint nearest = -1)
    uint found;        // a node lies within the influence distance
    uint active;       // 1 = live, 0 = removed
} Attraction;

typedef struct {
    float px, py, pz;  // position
    float t;           // growth 0..1; a node branches only once t >= 1
    float offset;      // depth: edges from its seed
    float mass;        // growth-speed factor in [mass_min, mass_max]
    int from;          // parent node (-1 for a seed)
    uint active;       // 1 = live; 0 = a free slot (its index sits in the node pool)
} Node;

typedef struct {
    float px, py, pz;  // where the new node will sit
    int node;          // the node it grows from
} Candidate;

typedef struct {
    int a, b;  // parent node, child node
} Edge;

typedef struct {
    float px, py, pz;  // bind-space position
    int bone;          // bone of the nearest mesh vertex (SetupSkin)
    int nearest;
    uint found;
    uint active;
} SkinnedAttraction;

typedef struct {
    float px, py, pz;  // bind-space position: growth happens here
    float ax, ay, az;  // position after skinning (Animate): drawing happens here
    int index0;        // its one bone
    float t, offset, mass;
    int from;
    uint active;
} SkinnedNode;

typedef struct {
    float px, py, pz;
    int node;
    int bone;  // bone of the nearest attraction that pulled the node
} SkinnedCandidate;

#define POSITION(record) ((float3)((record).px, (record).py, (record).pz))

// An attraction this close to its node gives no direction: normalize(0) is NaN (the book's seeds sit on attraction
// points, so its first Attract makes one NaN candidate per seed). Such attractions are skipped
// (docs/chapters/12-space-colonization.md, "What differs from the book").
#define MIN_DIRECTION 1e-12f

// The repeat guard (ugpcl, on by default; `--set repeat_guard=false` is the book): true when `candidate` repeats
// the last one this node emitted, or sits on the node itself. Opposite attractions cancel, the mean direction is ~0
// and the candidate lands on its parent; the copy is never closer to the attractions, so either the parent emits it
// again every step, or (the copy winning the distance tie) the copy does, and the next copy, ...
// (docs/chapters/12-space-colonization.md).
// `last.w` is 1 once the node emitted.
inline bool repeats(float4 last, float3 node, float3 candidate, float growth_distance) {
    const float tolerance2 = (1e-3f * growth_distance) * (1e-3f * growth_distance);
    const float3 d_last = candidate - last.xyz;
    const float3 d_node = candidate - node;
    return (last.w != 0.0f && dot(d_last, d_last) < tolerance2) || dot(d_node, d_node) < tolerance2;
}

#endif
