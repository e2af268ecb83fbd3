// marching_cubes.h: the triangle record of vol.1 ch.7's OpenCL path (docs/chapters/07-marching-cubes.md).
// numpy mirror: ugpcl.scenes.marching_cubes.TRIANGLE_DTYPE (76 bytes; a test checks sizeof on the device).
// Flat float arrays, never float3: an OpenCL float3 is 16 bytes, numpy's (3,) float32 is 12.
#ifndef UGPCL_MARCHING_CUBES_H
#define UGPCL_MARCHING_CUBES_H

typedef struct {
    float position[9];  // 3 vertices x (x, y, z), object space [-0.5, 0.5]^3 (vstore3 at 0, 3, 6)
    float normal[9];    // 3 unit normals, pointing out of the high-density region
    uint cell;          // x + N * (y + N * z) of the cell that made it: sorting by it gives a deterministic order
} McTriangle;

#endif
