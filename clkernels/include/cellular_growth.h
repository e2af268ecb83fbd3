// cellular_growth.h: the records of Unity Graphics Programming vol.3 ch.4, "GPU-Based Cellular Growth"
// (docs/chapters/11-cellular-growth.md): Particle_t, Edge_t and create() of CellularGrowth.compute (its nrand and
// random_point_on_circle are in random.h).
// Used by clkernels/cellular_growth.cl and by the layout probe of tests/test_cellular_growth.py.
#ifndef UGPCL_CELLULAR_GROWTH_H
#define UGPCL_CELLULAR_GROWTH_H

// Particle_t (book: Particle.cs): one cell. 32 bytes, 8-byte aligned, as the HLSL/C# stride 32.
// numpy mirror: ugpcl.scenes.cellular_growth.PARTICLE_DTYPE.
typedef struct {
    float2 position;  // @0
    float2 velocity;  // @8
    float radius;     // @16 current size
    float threshold;  // @20 size the cell grows to
    int links;        // @24 connected edges; a plain 4-byte int so atomic_add(&p.links, k) is legal
    uint alive;       // @28 activation flag (HLSL bool in a structured buffer: 4 bytes)
} Particle;

// Edge_t (book: Edge.cs): a spring between particles a and b. 20 bytes, 4-byte aligned, as the HLSL/C# stride 20.
// The book's `float2 force` would give the OpenCL struct 8-byte alignment and sizeof 24, so the force is two floats.
// numpy mirror: ugpcl.scenes.cellular_growth.EDGE_DTYPE.
typedef struct {
    int a, b;      // @0, @4 particle indices
    float fx, fy;  // @8 book: force (attraction a -> b, written by UpdateEdges)
    uint alive;    // @16
} Edge;

// Book (repository): create() - a fresh live cell at the origin with radius = threshold = 1 and no links.
inline Particle create(void) {
    Particle p;
    p.position = (float2)(0.0f, 0.0f);
    p.velocity = (float2)(0.0f, 0.0f);
    p.radius = 1.0f;
    p.threshold = 1.0f;
    p.links = 0;
    p.alive = 1u;
    return p;
}

#endif
