// boid.h: the boid record of vol.1 ch.3 (docs/chapters/03-boids.md).
// The book's HLSL BoidData {float3 velocity; float3 position;} is 24 bytes; an OpenCL struct of two float3 would be
// 32 bytes with hidden padding, so both fields are float4 (w = 0). numpy mirror: ugpcl.scenes.boids.BOID_DTYPE.
// The same 32-byte record is the GL instance buffer of the view (two vec4 attributes, divisor 1).
#ifndef UGPCL_BOID_H
#define UGPCL_BOID_H

typedef struct {
    float4 velocity;  // xyz: velocity, w: 0
    float4 position;  // xyz: position, w: 0
} Boid;

#endif
