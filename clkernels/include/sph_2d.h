// sph_2d.h: the fluid particle record of vol.1 ch.5, SPH fluid 2D (docs/chapters/05-sph-2d.md).
// Book (SPH2D.compute, Particle.shader): struct FluidParticle {float2 position; float2 velocity;}: 16 bytes in HLSL,
// OpenCL (float2 is 8-byte aligned, no padding) and numpy: ugpcl.scenes.sph_2d.PARTICLE_DTYPE. The same record is the
// view's vertex buffer (two vec2 attributes, stride 16).
#ifndef UGPCL_SPH_2D_H
#define UGPCL_SPH_2D_H

typedef struct {
    float2 position;  // world units, box [0, range.x] x [0, range.y]
    float2 velocity;  // world units / s
} FluidParticle;

#endif
