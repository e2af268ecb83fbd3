// cellular_growth.h: the records and random helpers of Unity Graphics Programming vol.3 ch.4, "GPU-Based Cellular
// Growth" (spec 11): Particle_t, Edge_t, nrand, random_point_on_circle and create() of CellularGrowth.compute.
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

// Book (Random.cginc): nrand(uv) = frac(sin(dot(uv, (12.9898, 78.233))) * 43758.5453), in [0, 1). Its value for
// large arguments depends on the device's sin (PoCL vs NVIDIA): compare random-driven results statistically.
inline float nrand(float2 uv) {
    const float x = sin(dot(uv, (float2)(12.9898f, 78.233f))) * 43758.5453f;
    return x - floor(x);  // frac (OpenCL's fract needs a pointer argument)
}

// Book (repository): a point on the unit circle at angle nrand(uv) * 2 pi.
inline float2 random_point_on_circle(float2 uv) {
    const float theta = nrand(uv) * 2.0f * M_PI_F;
    return (float2)(cos(theta), sin(theta));
}

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
